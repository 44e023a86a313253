"""The one exception of bad input: what the user gave cannot be used as it is.

Every room raises it (or a subclass) for a problem of the input, with a message that names the
problem; the command line prints that message in one line and exits 2. Any other exception is a
defect of calibench (exit 3). Needs nothing but Python.
"""


class BadInput(ValueError):
    """Input that cannot be used: a missing file, a malformed value, a degenerate data set."""
