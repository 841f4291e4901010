"""Shared fixtures: the bundled test meshes, small helpers, scenes, and the stand-alone guard.

The test meshes are the ones bundled in ``pyshadow/data/meshes`` (see
:func:`pyshadow.data.mesh`); the suite needs nothing beside the repository.
Scene helpers shared by the query tests (``test_scene``, ``test_visibility``,
``test_render``, ``test_sampling``, ``test_compat``): ``from conftest import
unit_frame, on_ground, surface_queries``, and the fixtures ``bunny_scene``,
``two_object_scene`` (module scope: built once per test module),
``small_scene`` and ``no_launch``.

An audit hook (:func:`sys.addaudithook`) records every file this process
opens or lists under the repository's parent folder but outside the
repository (a sibling folder of the clone) and fails the test that did it;
reads outside any test fail the session. See ``tests/test_standalone.py``.
"""
from __future__ import annotations

import atexit
import contextlib
import math
import os
import shutil
import site
import sys
import tempfile
import threading
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]


def mesh_path(name: str) -> Path:
    """A file path of a test mesh, for code that wants a path (CLIs, load_mesh on a file).

    A bundled mesh (``pyshadow.data.MESHES``) is written, as its original file,
    into a temporary folder of this session; pyvista's bundled meshes are
    named ``'pyvista:airplane'`` and come from the installed pyvista wheel.
    """
    if name.startswith("pyvista:"):
        from pyvista import examples

        return Path(examples.__file__).parent / (name.split(":", 1)[1] + ".ply")
    import pyshadow

    global _extract_dir
    if _extract_dir is None:
        _extract_dir = tempfile.mkdtemp(prefix="pyshadow-test-meshes-")
        atexit.register(shutil.rmtree, _extract_dir, True)
    path = Path(_extract_dir) / name
    if not path.is_file():
        path = pyshadow.data.mesh_file(name, _extract_dir)
    return path


_extract_dir: str | None = None
_cache: dict = {}


def load(name: str, fill_holes: bool = False):
    """Load (and cache) a test mesh: a bundled one by name, or ``'pyvista:...'``."""
    import pyshadow

    key = (name, fill_holes)
    if key not in _cache:
        if name.startswith("pyvista:"):
            _cache[key] = pyshadow.load_mesh(mesh_path(name), fill_holes=fill_holes)
        else:
            _cache[key] = pyshadow.data.mesh(name, fill_holes=fill_holes)
    return _cache[key]


def modules_run(fn) -> set:
    """The package's modules (paths relative to the package, '/'-separated) whose functions run in ``fn()``,
    traced with :func:`sys.setprofile`: what a code digest must cover."""
    import pyshadow

    pkg = Path(pyshadow.__file__).resolve().parent
    ran = set()

    def note(frame, event, arg):
        if event == "call":
            f = Path(frame.f_code.co_filename)
            if f.is_relative_to(pkg):
                ran.add(f.relative_to(pkg).as_posix())

    sys.setprofile(note)
    try:
        fn()
    finally:
        sys.setprofile(None)
    return ran


def wall_scene():
    """Ground y = 0, a thick wall (40 x 10 x 0.5, front face z = 0) and a 0.3 box on the floor, all casters
    (4 x 8 maps of 16 texels)."""
    import pyshadow
    import trimesh

    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    wall = trimesh.creation.box((40.0, 10.0, 0.5))
    wall.apply_translation([0.0, 5.0, -0.25])
    scene.add(wall)
    scene.add(trimesh.creation.box((0.3, 0.3, 0.3)), trimesh.transformations.translation_matrix([0.8, 0.15, 0.7]))
    return scene


def unprivileged_python():
    """The command prefix that runs Python without the power to read or write files it has no
    permission for (root: setpriv without capabilities), or None where there is none."""
    if not hasattr(os, "geteuid"):
        return None
    if os.geteuid() != 0:
        return [sys.executable]
    setpriv = shutil.which("setpriv")
    return [setpriv, "--bounding-set=-all", "--inh-caps=-all", sys.executable] if setpriv else None


def csm_fields(csm, **change):
    """The keyword arguments that make ``csm`` again with :class:`pyshadow.CoherentShadowMap` (its arrays
    copied), with ``change`` applied."""
    kw = dict(views=csm.views, resolution=csm.resolution, depth_bits=csm.depth_bits, layer_rule=csm.layer_rule,
              centre=csm.centre, radius=csm.radius, mesh_hash=csm.mesh_hash, offsets=np.array(csm.offsets),
              iend=np.array(csm.iend), depth=np.array(csm.depth), box=csm.box,
              front_margin_texels=csm.front_margin_texels, two_sided=csm.two_sided,
              both_sided_faces=csm.both_sided_faces)
    kw.update(change)
    return kw


def glb_bytes(tree: dict, blob) -> bytes:
    """A GLB file of the glTF JSON ``tree`` and the binary chunk ``blob`` (each padded to 4 bytes)."""
    import json
    import struct

    j = json.dumps(tree).encode()
    j += b" " * (-len(j) % 4)
    blob = bytes(blob) + b"\0" * (-len(blob) % 4)
    body = struct.pack("<II", len(j), 0x4E4F534A) + j + struct.pack("<II", len(blob), 0x004E4942) + blob
    return struct.pack("<III", 0x46546C67, 2, 12 + len(body)) + body


def gltf_bytes(tree: dict, blob, glb: bool) -> bytes:
    """``tree`` and its one buffer ``blob`` as a GLB (:func:`glb_bytes`), or as a ``.gltf`` whose buffer is a
    base64 ``data:`` URI."""
    import base64
    import json

    if glb:
        return glb_bytes(tree, blob)
    tree["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(bytes(blob)).decode()
    return json.dumps(tree).encode()


def all_pairs(csm):
    """Every (map, row, col) of a CSM as three (D, R, R) index arrays."""
    D, R = csm.maps, csm.resolution
    return np.meshgrid(np.arange(D), np.arange(R), np.arange(R), indexing="ij")


@pytest.fixture(autouse=True)
def deprecations_warn_every_test():
    """Each old form warns once per process; forget before every test, so that a test
    using one fails (warnings are errors) whatever ran before it."""
    from pyshadow import _compat

    _compat.reset()
    yield


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


# ---------------------------------------------------------------------------
# references shared by the sun-disc tests and the filter tests
# ---------------------------------------------------------------------------
def disc_texel_shares(env, d, r, n=400_000):
    """The solid angle (sr) of a disc (unit centre ``d``, angular radius ``r``) in every texel of ``env``,
    independently of add_sun_disc: n sunflower points, uniform in solid angle over the cap, each
    Omega_disc / n into the texel it falls in (texel_index)."""
    from pyshadow.lighting import disc_solid_angle

    a = np.array([1.0, 0.0, 0.0]) if abs(d[0]) < 0.9 else np.array([0.0, 0.0, 1.0])
    e1 = np.cross(d, a)
    e1 = e1 / np.linalg.norm(e1)
    e2 = np.cross(d, e1)
    j = np.arange(n)
    u = (j + 0.5) / n * (2.0 * math.sin(0.5 * r) ** 2)                 # 1 - cos(rho)
    ph = 2.0 * math.pi * np.mod(j * (math.sqrt(5.0) - 1.0) / 2.0, 1.0)
    s = np.sqrt(u * (2.0 - u))
    p = (1.0 - u)[:, None] * d + (s * np.cos(ph))[:, None] * e1 + (s * np.sin(ph))[:, None] * e2
    idx = env.texel_index(p / np.linalg.norm(p, axis=1, keepdims=True))
    return np.bincount(idx, minlength=int(np.prod(env.grid_shape))) * (disc_solid_angle(r) / n)


def filter_guide(H=12, W=20, seed=2):
    """A G-buffer guide with two depth levels, tilted unit normals (float32) and background pixels
    (rows 0, 5, 10 x columns 0, 7, 14), and an AO image in [0.5, 1): (ao, depth, normal)."""
    rng = np.random.default_rng(seed)
    depth = np.where(np.arange(W) < W // 2, 2.0, 2.03).astype(np.float32) * np.ones((H, 1), np.float32)
    depth[::5, ::7] = np.inf
    n = rng.normal(size=(H, W, 3))
    n[..., 2] += 4
    n = (n / np.linalg.norm(n, axis=-1, keepdims=True)).astype(np.float32)
    return rng.uniform(0.5, 1.0, (H, W)).astype(np.float32), depth, n


# ---------------------------------------------------------------------------
# scenes shared by test_scene, test_visibility, test_render, test_sampling, test_compat
# ---------------------------------------------------------------------------
def unit_frame(mesh, scale=1.0, offset=(0.0, 0.0, 0.0), rotation=None):
    """Transform that puts ``mesh``'s bounding sphere at ``offset`` with radius ``scale``."""
    import pyshadow

    c, r = pyshadow.bounding_sphere(mesh)
    T = np.eye(4)
    if rotation is not None:
        T[:3, :3] = rotation
    T[:3, :3] *= scale / r
    T[:3, 3] = np.asarray(offset, dtype=float) - T[:3, :3] @ c
    return T


def on_ground(mesh, T):
    """Shift transform ``T`` up or down so the mesh's lowest vertex touches y = 0."""
    T = T.copy()
    T[1, 3] -= (mesh.vertices @ T[:3, :3].T + T[:3, 3])[:, 1].min()
    return T


def surface_queries(scene, instance_id, n_points, samples, rng, uniform=False):
    """Points sampled uniformly on an instance's faces, with directions in the
    hemispheres of their face normals (cosine-weighted AO directions, or uniform)."""
    import trimesh

    import pyshadow

    inst = scene.instances[instance_id]
    T = inst.transform
    seed = int(rng.integers(1 << 30))
    local, face = trimesh.sample.sample_surface(inst.mesh, n_points, seed=seed)
    p = local @ T[:3, :3].T + T[:3, 3]
    n = inst.mesh.face_normals[face] @ inst.rotation.T
    if uniform:
        d = rng.normal(size=(n_points * samples, 3))
        n_rep = np.repeat(n, samples, axis=0)
        d = np.where(np.einsum("ij,ij->i", d, n_rep)[:, None] < 0, -d, d)
    else:
        d = pyshadow.sample_directions(n, sampling=pyshadow.Sampling(samples, seed=seed)).reshape(-1, 3)
    return np.repeat(p, samples, axis=0), d.astype(np.float64)


@pytest.fixture(scope="module")
def bunny_scene():
    """The bunny on its ground plane, CSM of 64x128 maps at 128^2 (built once per module)."""
    import pyshadow

    bunny = load("stanford-bunny.obj")
    scene = pyshadow.Scene(ground=float(bunny.bounds[0, 1]), views=pyshadow.ViewSet.zigzag(64, 128),
                           resolution=128)
    scene.add(bunny)
    return scene


@pytest.fixture(scope="module")
def two_object_scene(bunny_scene):
    """The bunny (bunny_scene's CSM) and a turned fandisk standing on the ground y = 0."""
    import trimesh

    import pyshadow

    bunny = load("stanford-bunny.obj")
    fan = load("fandisk.obj")
    bunny_csm = bunny_scene.instances[0].csm
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(64, 128), resolution=128)
    scene.add(bunny_csm, on_ground(bunny, unit_frame(bunny)), mesh=bunny)
    rot = trimesh.transformations.rotation_matrix(0.9, [0.3, 1.0, 0.2])[:3, :3]
    scene.add(fan, on_ground(fan, unit_frame(fan, scale=0.8, rotation=rot, offset=(1.7, 0.0, 0.4))))
    return scene


def far_sphere_scene():
    """A sphere of radius 1 (icosphere, edges about 0.08) at the origin above a ground plane at y = -0.9."""
    import trimesh

    import pyshadow

    s = pyshadow.Scene(ground=-0.9, views=pyshadow.ViewSet.zigzag(8, 16), resolution=32)
    s.add(trimesh.creation.icosphere(3, radius=1.0))
    return s


def far_camera(distance: float):
    """A 40x30 view of :func:`far_sphere_scene` from ``distance`` radii, its field of view framing 1.3 radii."""
    import pyshadow

    fov = float(np.degrees(2.0 * np.arctan(1.3 / distance)))
    return pyshadow.Camera(eye=(0.3 * distance, 0.5 * distance, distance), target=(0.0, 0.0, 0.0), fov_y=fov,
                           width=40, height=30)


def box_and_ball(maps, resolution: int, subdivisions: int, size):
    """A unit box and a ball of radius 0.5 on the ground (zigzag ``maps`` CSMs at ``resolution``, the ball an
    icosphere of ``subdivisions``), a camera of ``size`` (width, height) on them, and the CSMs' bytes."""
    import trimesh

    import pyshadow

    scene = pyshadow.Scene(ground=0.0)
    views = pyshadow.ViewSet.zigzag(*maps)
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    ball = trimesh.creation.icosphere(subdivisions, 0.5)
    for mesh, pos in ((box, (0.0, 0.5, 0.0)), (ball, (1.6, 0.5, 0.3))):
        csm = pyshadow.CoherentShadowMap.build(mesh, views, resolution=resolution, progress=False)
        scene.add(csm, trimesh.transformations.translation_matrix(pos), mesh=mesh)
    cam = pyshadow.Camera([4.0, 3.0, 5.0], [0.8, 0.3, 0.0], width=size[0], height=size[1])
    return scene, cam, sum(scene.instances[i].csm.stats["bytes"] for i in scene.casters)


@pytest.fixture(scope="module")
def box_csm():
    """A 0.3 m box mesh and its small CSM (8 x 16 maps at 32^2): the body of the moving-scene tests."""
    import trimesh

    import pyshadow

    box = trimesh.creation.box((0.3, 0.3, 0.3))
    return box, pyshadow.CoherentShadowMap.build(box, pyshadow.ViewSet.zigzag(8, 16), resolution=32,
                                                   progress=False)


@pytest.fixture
def small_scene():
    """A unit box on the ground, CSM of 4x8 maps at 16^2: quick to build and to ask."""
    import trimesh

    import pyshadow

    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    scene.add(trimesh.creation.box((1.0, 1.0, 1.0)))
    return scene


@pytest.fixture
def no_launch(monkeypatch):
    """Fail the test if any OpenCL kernel is built or launched (input checks come first)."""
    from pyshadow import _cl

    def boom(*a, **k):
        raise AssertionError("a kernel was launched")
    monkeypatch.setattr(_cl, "kernel", boom)


# ---------------------------------------------------------------------------
# the suite stands alone: no file of a sibling folder of the clone
# ---------------------------------------------------------------------------
_AUDITED = frozenset({"open", "os.listdir", "os.scandir"})
_REPO_REAL = os.path.realpath(REPO)
_PARENT_REAL = os.path.dirname(_REPO_REAL)


def _inside(path: str, folder: str) -> bool:
    return path == folder or path.startswith(folder.rstrip(os.sep) + os.sep)


def _exempt_folders() -> tuple[str, ...]:
    """Folders beside the clone that the interpreter itself may read.

    The virtual environment, the interpreter's prefixes and site-packages,
    the temporary folder and ``PYSHADOW_AUDIT_ALLOW`` (``os.pathsep``
    separated), each only when it lies beside the repository without
    holding it (a folder holding the repository would exempt everything).
    """
    cands = [sys.prefix, sys.base_prefix, sys.exec_prefix, sys.base_exec_prefix,
             tempfile.gettempdir(), *site.getsitepackages()]
    with contextlib.suppress(Exception):
        cands.append(site.getusersitepackages())
    cands += [p for p in os.environ.get("PYSHADOW_AUDIT_ALLOW", "").split(os.pathsep) if p]
    out = []
    for c in cands:
        r = os.path.realpath(c)
        if _inside(r, _PARENT_REAL) and not _inside(_REPO_REAL, r) and not _inside(r, _REPO_REAL):
            out.append(r)
    return tuple(sorted(set(out)))


_EXEMPT = _exempt_folders()
_pending: list[tuple[str, str]] = []        # (resolved path, audit event) not yet reported
_busy = threading.local()


def outside_path(path) -> str | None:
    """The resolved path if ``path`` lies beside the repository (in a sibling folder), else None.

    Hidden siblings (``~/.cache`` when the clone sits in the home folder) and
    the exempt folders of the interpreter do not count.
    """
    try:
        p = os.fsdecode(path)
    except TypeError:
        return None
    r = os.path.realpath(p)
    if not _inside(r, _PARENT_REAL) or r == _PARENT_REAL or _inside(r, _REPO_REAL):
        return None
    first = os.path.relpath(r, _PARENT_REAL).split(os.sep, 1)[0]
    if first.startswith(".") or any(_inside(r, e) for e in _EXEMPT):
        return None
    return r


def _audit(event, args):
    if event not in _AUDITED or getattr(_busy, "on", False):
        return
    path = args[0] if args else None
    if path is None or isinstance(path, int):     # os.listdir() of the cwd, or a file descriptor
        return
    _busy.on = True
    try:
        r = outside_path(path)
        if r is not None:
            _pending.append((r, event))
    except Exception:                              # never break the audited call
        pass
    finally:
        _busy.on = False


# a clone at the top of the file system has every folder beside it: no guard there
if os.path.dirname(_PARENT_REAL) != _PARENT_REAL:
    sys.addaudithook(_audit)   # for the life of the process (audit hooks cannot be removed)


def _drain() -> list[tuple[str, str]]:
    out = list(dict.fromkeys(_pending))
    _pending.clear()
    return out


@contextlib.contextmanager
def outside_reads():
    """Collect (and take off the books) the outside reads made inside the block.

    Yields a list that holds the ``(resolved path, audit event)`` pairs once
    the block ends; they are then not reported as a failure of the test.
    """
    before = _drain()
    seen: list[tuple[str, str]] = []
    try:
        yield seen
    finally:
        seen.extend(_drain())
        _pending.extend(before)


def _describe(reads) -> str:
    return "; ".join(f"{p} ({ev})" for p, ev in reads)


_outside_tests: list[str] = []


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    outcome = yield
    rep = outcome.get_result()
    reads = _drain()
    if not reads:
        return
    msg = (f"{item.nodeid} ({call.when}) read outside the repository {_REPO_REAL}: "
           f"{_describe(reads)}. The test suite must stand alone: use pyshadow.data.mesh() "
           "or files inside the repository.")
    if rep.outcome == "failed":
        rep.sections.append(("reads outside the repository", msg))
    else:
        rep.outcome = "failed"
        rep.longrepr = msg


def pytest_collection_finish(session):
    reads = _drain()
    if reads:
        _outside_tests.append(f"during collection: {_describe(reads)}")


def pytest_sessionfinish(session, exitstatus):
    reads = _drain()
    if reads:
        _outside_tests.append(f"outside any test: {_describe(reads)}")
    if _outside_tests and session.exitstatus == 0:
        session.exitstatus = pytest.ExitCode.TESTS_FAILED


def pytest_terminal_summary(terminalreporter):
    if _outside_tests:
        terminalreporter.section("reads outside the repository", red=True)
        for line in _outside_tests:
            terminalreporter.write_line(line)


# ---------------------------------------------------------------------------
# every device, and every lane width of each
# ---------------------------------------------------------------------------
# test modules whose kernels work on lanes (kernels/lanes.h): each of their
# tests runs at every width the device passed the probe at
LANE_TEST_MODULES = frozenset({"test_raster", "test_csm", "test_scene", "test_visibility",
                               "test_visibility_backends", "test_render", "test_surface_rule",
                               "test_sampled_kernel"})


def test_targets(lanes: bool):
    """(device 'P:D', lane width or None) pairs the kernel tests run on.

    Every OpenCL device found, unless ``PYSHADOW_DEVICE`` names one; per
    device every width it supports when ``lanes``, unless ``PYSHADOW_LANES``
    names one.
    """
    from pyshadow import _cl

    if os.environ.get("PYSHADOW_DEVICE", "").strip():
        devs = [_cl.device_info()["index"]]
    else:
        devs = _cl.devices()
    out = []
    for d in devs:
        if not lanes:
            out.append((d, None))
            continue
        with _cl.use_device(d):
            choice = _cl.lane_choice()
            widths = [choice["lanes"]] if choice["source"] == "PYSHADOW_LANES" else choice["supported"]
        out += [(d, w) for w in widths]
    return out


def pytest_configure(config):
    # matplotlib before 3.10.7 (setup.cfg allows 3.7) calls pyparsing's camelCase names, which pyparsing 3.3
    # deprecates: a DeprecationWarning inside matplotlib (hidden outside tests), not an error of ours
    config.addinivalue_line("filterwarnings", r"ignore:'[A-Za-z]+' deprecated - use:DeprecationWarning:matplotlib\..*")


def pytest_generate_tests(metafunc):
    if "cl_target" in metafunc.fixturenames:
        module = metafunc.module.__name__.rsplit(".", 1)[-1]
        targets = test_targets(module in LANE_TEST_MODULES)
        metafunc.parametrize("cl_target", targets, indirect=True,
                             ids=[d if w is None else f"{d}-lanes{w}" for d, w in targets])


@pytest.fixture(autouse=True)
def cl_target(request):
    """Run the test on one device (and lane width) of :func:`test_targets`."""
    from pyshadow import _cl

    device, width = request.param
    with _cl.use_device(device):
        if width is None:
            yield request.param
        else:
            with _cl.use_lanes(width):
                yield request.param


def two_body_scene():
    """Bunny and a turned fandisk on the ground, coarse CSMs (16x32 maps at 64^2), with meshes."""
    import trimesh

    import pyshadow

    bunny, fan = load("stanford-bunny.obj"), load("fandisk.obj")
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(16, 32), resolution=64)
    scene.add(bunny, on_ground(bunny, unit_frame(bunny)))
    scene.add(fan, on_ground(fan, unit_frame(fan, 0.7, rotation=trimesh.transformations.rotation_matrix(
        0.5, [0, 1, 0])[:3, :3], offset=(1.6, 0, 0.3))))
    return scene


@pytest.fixture(scope="module")
def two_bodies():
    """:func:`two_body_scene`, built once per test module."""
    return two_body_scene()


def ground_grid(n=40, half=3.0):
    """An n x n grid of points on the ground y = 0 over [-half, half]^2 and their normals (+y)."""
    x, z = np.meshgrid(np.linspace(-half, half, n), np.linspace(-half, half, n))
    p = np.c_[x.ravel(), np.zeros(n * n), z.ravel()]
    return p, np.tile([0.0, 1.0, 0.0], (len(p), 1))
