"""Python 3.13's ``Path.resolve()`` leaves a loop of symbolic links unresolved (it returns the link, as
``os.path.realpath`` does) where 3.10-3.12 raised RuntimeError: on 3.13 an atomic write to a link that leads
back to itself replaced the link with a file, without a word, instead of OSError ELOOP naming the path.
Here ``Path.resolve`` is made 3.13's on every Python, so the test fails before the fix on any of them."""
import errno
import os
from pathlib import Path

import numpy as np
import pytest

from pyshadow._files import write_bytes_atomic
from pyshadow.io import write_image


@pytest.fixture
def resolve_as_in_313(monkeypatch):
    monkeypatch.setattr(Path, "resolve", lambda self, strict=False: type(self)(os.path.realpath(self)))


@pytest.mark.parametrize("links", [1, 2])
def test_a_loop_of_links_is_eloop_and_left_as_it_was(tmp_path, resolve_as_in_313, links):
    """One link to itself, and two that lead to each other."""
    names = [tmp_path / f"loop{k}.png" for k in range(links)]
    for k, p in enumerate(names):
        os.symlink(names[(k + 1) % links], p)
    for write in (lambda p: write_image(p, np.zeros((2, 2), np.float32)), lambda p: write_bytes_atomic(p, b"x")):
        with pytest.raises(OSError) as info:
            write(names[0])
        assert info.value.errno == errno.ELOOP and info.value.filename == str(names[0])
        assert sorted(os.listdir(tmp_path)) == sorted(p.name for p in names)
        assert all(p.is_symlink() for p in names)


def test_links_that_end_in_a_file_or_nothing_are_still_written_through(tmp_path, resolve_as_in_313):
    """A chain of two links to a file replaces the file; a dangling link creates the file it names."""
    (tmp_path / "data.bin").write_bytes(b"old")
    os.symlink(tmp_path / "data.bin", tmp_path / "mid")
    os.symlink(tmp_path / "mid", tmp_path / "top")
    os.symlink(tmp_path / "new.bin", tmp_path / "dangling")
    write_bytes_atomic(tmp_path / "top", b"new")
    write_bytes_atomic(tmp_path / "dangling", b"made")
    assert (tmp_path / "data.bin").read_bytes() == b"new" and (tmp_path / "new.bin").read_bytes() == b"made"
    assert (tmp_path / "top").is_symlink() and (tmp_path / "mid").is_symlink() and (tmp_path / "dangling").is_symlink()
