"""The ``calibench`` command line (docs/formats.md). Bad input: one line on stderr, exit status 2.

``parser`` declares the verbs and their options, ``entry`` holds ``main`` (exit statuses, bad
input in one line, internal errors to OUT/error.log) and ``command`` (the executable around it),
``verbs`` one handler per verb and ``status`` the exit statuses.
"""

from calibench.scenarios.cli.entry import command, main

__all__ = ["command", "main"]
