"""``python -m docs.figures`` (from the repository's root): see the package's docstring."""

import sys

if not __package__:  # run as ``python docs/figures``: make the package importable by its name
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
    from docs.figures import main
else:
    from . import main

sys.exit(main())
