"""The test suite stands alone: bundled meshes, no reads beside the repository.

The real test meshes live in ``pyshadow/data/meshes`` (original files, xz);
``tests/conftest.py`` fails any test that opens or lists a file in a sibling
folder of the clone (an audit hook), and the text scan below keeps such paths
out of the sources (subprocesses are not audited).
"""
from __future__ import annotations

import configparser
import hashlib
import os
import re
import shutil
import subprocess
import sys
import textwrap
import uuid
from pathlib import Path

import numpy as np
import pytest

import pyshadow
from conftest import REPO, load, mesh_path, outside_path, outside_reads

# SHA-256 of the original files, as received in the project's test collection
ORIGINALS = {
    "cow.obj": "69afce548640bc2beb0c44894d1a24d5766cc9cd3fd74f3ec55b4e229104b23f",
    "fandisk.obj": "27e201141bf9c869b922ce4f03fdef7b5dfc62b7e721f77b44efae1e2aecdce9",
    "featuretype.STL": "c9946c4bb8034cd43522526a2f325200e2d2322a0c7258f848a81f00e418dab3",
    "homer.obj": "b20b1391fd62964f65703d748514d86d747d1202d38e55e0f1addac7a5a10e8b",
    "spot.obj": "0738b5e8608fed74e5e8c7aa8dd0af97b4b74f9f6cbf7aac84cd7e40b2e44a75",
    "stanford-bunny.obj": "1eb35d1e21ce99e5ce911353b6be278990713448dd9e8f5c9387f9de39b32205",
    "suzanne.ply": "08ba5aad744d2963f1462d35861c3a4fb627e6780e63bbedc50faee5b79685a5",
    "teapot.obj": "1b5396fedd74b577e32cef41146582c2f2e1a050d5b4915193c0ac1ad4187ed4",
    "torus.STL": "91441a7f60479bda93c59dd88134da3b4f33d1df71729fe71e1b2ae989974da3",
}
MESH_DIR = REPO / "pyshadow" / "data" / "meshes"


# ---------------------------------------------------------------------------
# the bundled meshes
# ---------------------------------------------------------------------------
def test_bundled_meshes_are_the_original_files():
    assert pyshadow.data.MESHES == tuple(sorted(ORIGINALS))
    assert sorted(p.name for p in MESH_DIR.glob("*.xz")) == [n + ".xz" for n in sorted(ORIGINALS)]
    for name, digest in ORIGINALS.items():
        assert hashlib.sha256(pyshadow.data.mesh_bytes(name)).hexdigest() == digest, name


@pytest.mark.parametrize("name", sorted(ORIGINALS))
def test_mesh_is_bit_identical_to_load_mesh_of_the_file(name, tmp_path):
    """data.mesh parses in memory; load_mesh on the written original gives the same arrays."""
    a = pyshadow.data.mesh(name)
    b = pyshadow.load_mesh(pyshadow.data.mesh_file(name, tmp_path))
    assert (tmp_path / name).read_bytes() == pyshadow.data.mesh_bytes(name)
    for x, y in ((a.vertices, b.vertices), (a.faces, b.faces)):
        assert x.dtype == y.dtype and x.shape == y.shape
        assert x.tobytes() == y.tobytes()


def test_mesh_names_fill_holes_and_errors():
    full = pyshadow.data.mesh("teapot.obj")
    for alias in ("teapot", "TEAPOT.OBJ", " Teapot "):
        np.testing.assert_array_equal(pyshadow.data.mesh(alias).faces, full.faces)
    assert len(pyshadow.data.mesh("torus.stl").faces) == 8700
    filled = pyshadow.data.mesh("teapot", fill_holes=True)
    assert filled.is_watertight and not full.is_watertight
    np.testing.assert_array_equal(filled.faces[: len(full.faces)], full.faces)
    # the suite's helper passes fill_holes through and caches
    assert load("teapot.obj", fill_holes=True).faces.tobytes() == filled.faces.tobytes()
    assert load("teapot.obj") is load("teapot.obj")
    for bad in ("bunny", "teapot.ply", "", None):
        with pytest.raises(ValueError, match=r"no bundled mesh .*available: cow\.obj, .*torus\.STL"):
            pyshadow.data.mesh(bad)


def test_mesh_path_gives_a_loadable_file_outside_the_package():
    p = mesh_path("suzanne.ply")
    assert p.name == "suzanne.ply" and p.is_file() and REPO not in p.parents
    assert pyshadow.load_mesh(p).faces.tobytes() == load("suzanne.ply").faces.tobytes()
    assert mesh_path("suzanne.ply") == p


def test_meshes_install_with_the_package():
    cfg = configparser.ConfigParser()
    cfg.read(REPO / "setup.cfg")
    globs = [g.strip() for g in cfg["options.package_data"]["pyshadow.data"].split(",")]
    assert "meshes/*.xz" in globs and "meshes/README.md" in globs


def test_meshes_readme_names_every_file_with_its_digest():
    text = (MESH_DIR / "README.md").read_text()
    for name, digest in ORIGINALS.items():
        row = next((line for line in text.splitlines() if line.startswith(f"| {name} |")), None)
        assert row is not None and f"`{digest[:16]}`" in row, name
        assert f"{(MESH_DIR / (name + '.xz')).stat().st_size:,}" in row, name


# ---------------------------------------------------------------------------
# nothing beside the repository
# ---------------------------------------------------------------------------
SCANNED = ("tests", "benchmarks", "examples", "pyshadow")
FORBIDDEN = re.compile(r"""shared[/\\]+meshes|\.\.[/\\]+shared\b|['"]shared['"]|PYSHADOW_SHARED""")


def test_no_source_names_the_folder_beside_the_clone():
    hits = []
    for top in SCANNED:
        for p in sorted((REPO / top).rglob("*")):
            if (not p.is_file() or p.suffix not in (".py", ".md", ".cfg", ".toml", ".txt", ".json", ".cl", ".h")
                    or "__pycache__" in p.parts or p == Path(__file__).resolve()):
                continue
            for i, line in enumerate(p.read_text(errors="replace").splitlines(), 1):
                if FORBIDDEN.search(line):
                    hits.append(f"{p.relative_to(REPO)}:{i}: {line.strip()}")
    assert not hits, "paths beside the repository:\n" + "\n".join(hits)


def test_the_text_scan_would_catch_the_old_paths():
    for line in ('MESHES = REPO.parent / "shared" / "meshes"',
                 "m = load_mesh({str(REPO.parent / 'shared' / 'meshes' / 'suzanne.ply')!r})",
                 "the tests need ../shared/meshes beside the clone",
                 'os.environ.get("PYSHADOW_SHARED")'):
        assert FORBIDDEN.search(line), line
    assert not FORBIDDEN.search("the machine is shared with other jobs")


def _hooked() -> bool:
    return os.path.dirname(REPO.parent) != str(REPO.parent)


@pytest.mark.skipif(not _hooked(), reason="clone at the top of the file system: no guard")
def test_outside_path_tells_siblings_from_the_repository():
    sib = REPO.parent / "shared" / "meshes" / "teapot.obj"
    assert outside_path(sib) == os.path.realpath(sib)
    assert outside_path(os.fsencode(sib)) == os.path.realpath(sib)
    assert outside_path(REPO / "pyshadow" / "data" / "meshes" / "teapot.obj.xz") is None
    assert outside_path(REPO / ".." / REPO.name / "setup.cfg") is None
    assert outside_path(REPO.parent) is None                    # the parent itself (cwd walks)
    assert outside_path(REPO.parent / ".cache" / "x") is None   # hidden: caches of a home folder
    assert outside_path(REPO / ".." / "shared") == os.path.realpath(REPO.parent / "shared")


@pytest.mark.skipif(not _hooked(), reason="clone at the top of the file system: no guard")
def test_audit_hook_records_a_read_beside_the_repository(tmp_path):
    probe = REPO.parent / f"pyshadow-audit-probe-{uuid.uuid4().hex}"   # never created
    with outside_reads() as seen:
        with pytest.raises(FileNotFoundError):
            open(probe / "meshes" / "teapot.obj", "rb")
        with pytest.raises(FileNotFoundError):
            os.listdir(REPO / ".." / probe.name)
        (REPO / "setup.cfg").read_bytes()             # inside: not recorded
        (tmp_path / "x").write_text("x")              # elsewhere: not recorded
    assert seen == [(os.path.realpath(probe / "meshes" / "teapot.obj"), "open"),
                    (os.path.realpath(probe), "os.listdir")]
    assert not probe.exists()


@pytest.mark.skipif(not _hooked(), reason="clone at the top of the file system: no guard")
def test_audit_hook_fails_the_test_that_reads_beside_the_clone(tmp_path):
    """An inner pytest run with this conftest: the reading test fails, named with the file."""
    clone, sibling = tmp_path / "clone", tmp_path / "shared" / "meshes" / "probe.obj"
    (clone / "tests").mkdir(parents=True)
    sibling.parent.mkdir(parents=True)
    sibling.write_text("v 0 0 0\n")
    (clone / "pytest.ini").write_text("[pytest]\n")
    shutil.copy(REPO / "tests" / "conftest.py", clone / "tests" / "conftest.py")
    (clone / "tests" / "test_inner.py").write_text(textwrap.dedent("""
        from pathlib import Path
        SIBLING = Path(__file__).resolve().parents[2] / "shared" / "meshes" / "probe.obj"

        def test_reads_the_sibling():
            assert SIBLING.read_text().startswith("v ")

        def test_reads_inside():
            assert "addaudithook" in (Path(__file__).parent / "conftest.py").read_text()
    """))
    (clone / "tests" / "test_import_time.py").write_text(textwrap.dedent("""
        from pathlib import Path
        DATA = (Path(__file__).resolve().parents[2] / "shared" / "meshes" / "probe.obj").read_bytes()

        def test_passes():
            assert DATA
    """))
    env = {k: v for k, v in os.environ.items() if k not in ("PYSHADOW_AUDIT_ALLOW", "PYTEST_ADDOPTS")}

    def inner(*args):
        res = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                              "--basetemp", str(clone / ".tmp"), *args],
                             cwd=clone, env=env, capture_output=True, text=True, timeout=300)
        return res.returncode, res.stdout + res.stderr

    # a read at import time alone: every test passes, the session fails
    rc, out = inner("tests/test_import_time.py")
    assert rc == 1 and re.search(r"\b1 passed\b", out) and "failed" not in out, out
    assert f"during collection: {os.path.realpath(sibling)} (open)" in out, out
    rc, out = inner("tests")
    assert rc == 1, out
    assert re.search(r"\b1 failed, 2 passed\b", out), out
    assert "FAILED tests/test_inner.py::test_reads_the_sibling" in out, out
    # the test id carries the device it ran on (conftest's cl_target), e.g. [0:0]
    assert re.search(re.escape("tests/test_inner.py::test_reads_the_sibling") + r"(\[[^\]]*\])?"
                     + re.escape(" (call) read outside the repository "
                                 f"{os.path.realpath(clone)}: {os.path.realpath(sibling)} (open)"),
                     out), out
    assert f"during collection: {os.path.realpath(sibling)} (open)" in out, out
