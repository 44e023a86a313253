"""The ``calibench`` command's exit statuses (docs/formats.md, "Command line")."""

EXIT_OK, EXIT_CHECK_FAILED, EXIT_BAD_INPUT, EXIT_INTERNAL = 0, 1, 2, 3
EXIT_INTERRUPTED = 130  # finished work kept


def run_verdict(failed: list[str], total: int, say: bool) -> int:
    """The exit status of a run of ``total`` scenarios, ``failed`` naming those whose checks
    failed; ``say`` (``run all``) prints the overall verdict first, in one line, so that a long
    run's last line is its answer and agrees with its status.

    Parameters
    ----------
    failed : list of str
        The scenarios whose checks failed, in the order run.
    total : int
        How many scenarios ran.
    say : bool
        Print the verdict (one scenario's own last line already is).

    Returns
    -------
    int
        EXIT_OK when none failed, EXIT_CHECK_FAILED otherwise.
    """
    if say:
        print(
            f"\nall {total} scenarios passed"
            if not failed
            else f"\n{len(failed)} of {total} scenarios failed: {', '.join(failed)}"
        )
    return EXIT_CHECK_FAILED if failed else EXIT_OK


def one_line(text: str) -> str:
    """``text`` as one line: a newline or another control character (in a file's name, in an
    argument) written as its escape, so that a message is never split."""
    return "".join(c if c.isprintable() or c == " " else repr(c)[1:-1] for c in text)
