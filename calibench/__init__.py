"""calibench: a simulation-first test bench for calibrating measuring machines.

The four rooms install as subpackages (the folders stay at the repository's top level):
``calibench.scenes`` (what the machines are), ``calibench.sim`` (the as-built world and its
sensors), ``calibench.estimators`` (pure algorithms) and ``calibench.scenarios`` (experiments,
reports, the command line).

Importing the package sets one thing in the environment: OpenCV's bound on the pixels an image
decoder may allocate (``OPENCV_IO_MAX_IMAGE_PIXELS``, :data:`MAX_IMAGE_PIXELS`), which OpenCV
reads once, when cv2 loads. Every room's module is under this package, so it is set before any
of them imports cv2; a program that imports cv2 first gets OpenCV's own default (a gigapixel),
and ``calibench camera`` then refuses to decode (:mod:`calibench.scenarios.camera`).
"""

import os

__version__ = "0.2.0"

# px: the most pixels any image calibench decodes may have, whatever its format: OpenCV checks
# it between reading a header and allocating, where a 644 KB deflate TIFF of 14000 x 14000 took
# 1.1 GB. Sized by the hungriest decoder of a photo format (a 16-bit RGBA TIFF in one strip,
# 11.5 bytes a pixel) so that a command on one photo stays under 600 MB: a 32-megapixel sensor
# is 6912 x 4608, and a calibration needs no more
MAX_IMAGE_PIXELS = 32_000_000


# set, not defaulted: the refusal's message names this limit, and a larger one from the
# environment would undo the bound (the spawned workers of a study inherit it)
os.environ["OPENCV_IO_MAX_IMAGE_PIXELS"] = str(MAX_IMAGE_PIXELS)
