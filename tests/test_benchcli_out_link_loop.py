"""pyshadow-bench's --out folder holding an output name that is a symbolic link leading back to itself."""
import os

import pytest

from pyshadow.bench import cli


class _Stop(Exception):
    """Raised in place of the single benchmark."""


def test_an_output_link_that_loops_is_an_argument_error(monkeypatch, capsys, tmp_path):
    """Was: a traceback (``RuntimeError: Symlink loop``, Python 3.11 and 3.12), or on 3.13 the run let through, to
    fail at its first write with ELOOP after the whole benchmark. Now the parser's error (exit 2) names the link,
    for a loop of one link and of two."""
    def fake_run(args, *rest, **kw):
        raise _Stop(args)

    monkeypatch.setattr(cli, "run_main", fake_run)
    out = tmp_path / "out"
    out.mkdir()
    os.symlink(out / "ao.png", out / "ao.png")
    os.symlink(out / "reference.png", out / "b")
    os.symlink(out / "b", out / "reference.png")
    for name in ("ao.png", "reference.png"):
        with pytest.raises(SystemExit) as e:
            cli.main(["--quiet", "--no-cache", "--out", str(out)])
        assert e.value.code == 2
        assert f"{name} is a symbolic link that leads back to itself" in capsys.readouterr().err
        os.unlink(out / name)
    os.symlink(tmp_path / "elsewhere.png", out / "ao.png")       # a link into an existing folder: written through
    with pytest.raises(_Stop):
        cli.main(["--quiet", "--no-cache", "--out", str(out)])
