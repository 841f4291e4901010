"""benchmarks/side_by_side.py: a command that fails, prints no JSON or lacks a --key ends in one line (exit 1)."""
from __future__ import annotations

import sys

import pytest

from conftest import REPO

sys.path.insert(0, str(REPO / "benchmarks"))


@pytest.mark.parametrize("code, key, says", [
    ("print('no json')", "t", "printed no JSON object on stdout"),
    ("print('{\"t\": 1.0}')", "u", "--key u: no number under that key"),
    ("import sys; sys.exit(3)", "t", "failed (3)"),
])
def test_a_bad_command_is_one_line(code, key, says, tmp_path, capsys):
    """Was: ValueError (substring not found) for no JSON, KeyError for a missing key, RuntimeError for a
    failing command: each a traceback of side_by_side.py itself."""
    import side_by_side

    rc = side_by_side.main(["--old", str(tmp_path), "--new", str(tmp_path), "--rounds", "1", "--key", key,
                            "--", sys.executable, "-c", code])
    err = capsys.readouterr().err
    assert rc == 1 and says in err and "Traceback" not in err


def test_medians_of_a_json_command(tmp_path, capsys):
    """A command printing one JSON object: the medians of each --key, old against new."""
    import side_by_side

    assert side_by_side.main(["--old", str(tmp_path), "--new", str(tmp_path), "--rounds", "2", "--key", "a.b",
                              "--", sys.executable, "-c", "print('{\"a\": {\"b\": 2.5}}')"]) == 0
    assert "old 2.5  new 2.5  new/old 1.000" in capsys.readouterr().out
