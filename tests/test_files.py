"""calibench/files.py: one file under two names is one file, whatever names it."""

import os

from calibench.files import first_repeat, same_file


def _files(tmp_path):
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    a.write_text("x\n1\n")
    b.write_text("x\n1\n")  # the same content is another file
    link, hard = tmp_path / "link.csv", tmp_path / "hard.csv"
    link.symlink_to(a)
    os.link(a, hard)
    return a, b, link, hard


def test_same_file_sees_through_names_and_links(tmp_path, monkeypatch):
    a, b, link, hard = _files(tmp_path)
    monkeypatch.chdir(tmp_path)
    assert same_file(a, "a.csv") and same_file(a, link) and same_file(hard, link)
    assert not same_file(a, b)
    # a path not yet written is another file unless it resolves to the same name
    assert same_file(tmp_path / "new.json", "new.json")
    assert not same_file(tmp_path / "new.json", a)


def test_first_repeat_is_the_first_second_name(tmp_path):
    a, b, link, hard = _files(tmp_path)
    assert first_repeat([a, b]) is None
    assert first_repeat([b, a, hard, link]) == hard
    assert first_repeat([link, b, str(a)]) == a
    # an unreadable path repeats nothing: its reader says it is missing
    gone = tmp_path / "gone.csv"
    assert first_repeat([gone, a, gone]) is None
    # the answer agrees with same_file's, pair by pair
    paths = [b, a, hard, link]
    first = next(p for i, p in enumerate(paths) if any(same_file(p, q) for q in paths[:i]))
    assert first_repeat(paths) == first
