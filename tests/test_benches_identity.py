"""benchmarks/identity.py: --save F writes F itself (atomically), so --compare F reads back what was saved."""
from __future__ import annotations

import sys

import numpy as np

from conftest import REPO

sys.path.insert(0, str(REPO / "benchmarks"))


def test_save_then_compare_with_a_name_without_npz(tmp_path, monkeypatch, capsys):
    """Was: ``--save rec`` wrote ``rec.npz`` (np.savez adds the suffix) while printing "into rec", and
    ``--compare rec`` then stopped with FileNotFoundError; no temporary file is left beside it now."""
    import identity

    monkeypatch.setattr(identity, "record", lambda meshes, quick: {"a": np.arange(3.0), "b/x": np.ones(2)})
    path = tmp_path / "rec"
    assert identity.main(["--save", str(path)]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rec"]
    assert identity.main(["--compare", str(path)]) == 0
    assert "bit-identical" in capsys.readouterr().out
