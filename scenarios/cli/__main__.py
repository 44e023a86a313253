"""``python -m calibench.scenarios.cli``: the ``calibench`` command."""

import sys

from calibench.scenarios.cli.entry import main

if __name__ == "__main__":
    sys.exit(main())
