"""The ``calibench`` command's exit statuses (CONTRACT.md, "Command line")."""

EXIT_OK, EXIT_CHECK_FAILED, EXIT_BAD_INPUT, EXIT_INTERNAL = 0, 1, 2, 3
EXIT_INTERRUPTED = 130  # finished work kept
