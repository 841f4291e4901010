"""The contact rule's cost benchmark (benchmarks/contact_cost.py) and the batched search behind it
(pyshadow/contact_parts.py: pairs in runs of ``_CHUNK``)."""
from __future__ import annotations

import sys

import numpy as np

from conftest import REPO

sys.path.insert(0, str(REPO / "benchmarks"))


def test_runs_cover_every_item_whatever_the_total():
    """Every (item, part) pair comes once, in runs that end on item boundaries: a total of exactly
    ``_CHUNK`` pairs (a boundary found on the wrong side of an equal sum would drop the last item), items
    of no parts, one item larger than a run."""
    from pyshadow.contact_parts import _CHUNK, _expanded

    rng = np.random.default_rng(0)
    for counts in ([_CHUNK], [1, _CHUNK - 1], [0, _CHUNK, 0, 3], [2 * _CHUNK + 1], [0, 0], [],
                   list(rng.integers(0, 3 * _CHUNK // 4, 9))):
        counts = np.asarray(counts, np.intp)
        seen = np.zeros(len(counts), np.intp)
        pairs = set()
        for s, e, c, j in _expanded(counts):
            np.add.at(seen, c + s, 1)
            assert np.all(c + s < e)
            pairs.update(zip((c + s).tolist(), j.tolist()))
        assert np.array_equal(seen, counts)
        assert len(pairs) == counts.sum()                   # each (item, part) once


def test_patches_of_the_three_scenes():
    """Boxes 1 m apart touch nothing; each of four boxes on a floor mesh touches it with its underside
    (one patch each: the floor is a receiver, which closes nothing in); a 2 x 2 pile of columns of four unit
    boxes: every box has two neighbours beside it, the three lower layers a box above, the three upper a
    box below (the ground is not a body): 16 * 2 + 12 + 12 = 56 patches, each of two triangles; the
    bodies on the ground (all four apart, the pile's lowest four) have footprints, the floor's none."""
    import contact_cost
    from pyshadow.contact_bodies import body_patches

    sc = contact_cost.scenes(4, 4, 2)
    assert [len(body_patches(sc[k][0])) for k in ("apart", "floor", "pile")] == [0, 4, 56]
    assert all(len(p[5]) == 2 and len(p[6]) == 4 for p in body_patches(sc["pile"][0]))
    assert [len(body_patches(sc[k][1])) for k in ("apart", "floor", "pile")] == [0, 0, 0]   # no meshes
    from pyshadow.contact import footprints

    assert [len(footprints(sc[k][0])) for k in ("apart", "floor", "pile")] == [4, 0, 4]     # no ground: none
    normals = np.array([p[0] for p in body_patches(sc["floor"][0])])
    assert np.array_equal(normals, np.tile([0.0, 1.0, 0.0], (4, 1)))     # into the box above the floor


def test_one_box_apart_runs_and_prints_its_table(capsys):
    """Was: ``contact_cost.py --apart 1`` ended in IndexError (no instance 1: the body slid was instance 1,
    and a scene of one box has only instance 0), and without --json nothing at all was printed."""
    import contact_cost

    assert contact_cost.main(["--apart", "1", "--floor", "1", "--pile", "1", "--tiles", "1", "--points", "8",
                              "--rounds", "1"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[1].split()[:3] == ["scene", "bodies", "patches"]
    assert [line.split()[:2] for line in out[2:]] == [["apart", "1"], ["floor", "2"], ["pile", "4"], ["tiles", "1"]]
