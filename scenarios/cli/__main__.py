"""``python -m calibench.scenarios.cli``: the ``calibench`` command."""

from calibench.scenarios.cli.entry import command

if __name__ == "__main__":
    command()
