"""One asset's bake, as a worker runs it: mesh bytes in, CSM and AO-baked mesh bytes out.

The worker never touches the output folder: it receives the source file's
bytes and returns the bytes of every output, so that the same task runs in
this process, in a process pool or on any Dask worker, with or without a
shared file system, and only the driver writes files (atomically).
"""
from __future__ import annotations

import hashlib
import json
import os
import socket
import tempfile
import time
import traceback
import warnings
from pathlib import Path, PurePosixPath

import numpy as np

from .params import AssetParams, code_digest

__all__ = ["bake_asset", "output_names", "baked_mesh_bytes", "read_baked_mesh", "csm_file_bytes", "side_files"]


def output_names(name: str, params: AssetParams) -> dict:
    """Relative output paths of asset ``name``: ``{"csm": ..., "mesh": ...}``."""
    return {"csm": f"csm/{name}.csm", "mesh": f"meshes/{name}.{params.mesh_format}"}


def _sha256(b: bytes) -> str:
    return hashlib.sha256(b).hexdigest()


def _beside(uri: str) -> bool:
    """True for a file name that lies in its mesh file's folder or below it (not ``data:``, absolute or ``..``)."""
    rel = PurePosixPath(uri)
    return (bool(rel.parts) and not rel.is_absolute() and ".." not in rel.parts and "base64," not in uri
            and not uri.startswith("data:"))


def side_files(path) -> dict:
    """The files a mesh file reads besides itself, which must travel with it to a worker.

    A ``.gltf`` names its binary buffers and images by ``uri``, files of
    its folder (the usual export: ``model.gltf`` and ``model.bin``); a
    worker reads the mesh from a temporary folder, where they must be too.
    Other formats give their geometry in the one file (an OBJ's
    materials hold none).

    Parameters
    ----------
    path : str or path-like
        The mesh file.

    Returns
    -------
    dict
        Name -> path, for each file a ``uri`` means that is in the mesh
        file's folder or below it, found as the mesh reader finds it
        (:class:`pyshadow.gltf_files.GltfResolver`: a percent-encoded
        ``my%20chair.bin`` is the file ``my chair.bin``); the name is the
        one found, relative to the folder (the ``uri`` as written where it
        names the file as it is). Empty for other formats and for a
        ``.gltf`` that cannot be read (its bake then reports the error).
    """
    path = Path(path)
    if path.suffix.lower() != ".gltf":
        return {}
    from ..gltf_files import GltfResolver, gltf_file_uris

    try:
        uris = gltf_file_uris(json.loads(path.read_bytes()), every=True)
        found = [GltfResolver(str(path)).match(uri) for _, _, uri in uris]
    except (OSError, ValueError, TypeError, AttributeError, RecursionError):
        return {}
    return {name: file for name, file in filter(None, found) if _beside(name)}


def baked_mesh_bytes(mesh, ao, bent, mesh_format: str) -> bytes:
    """The mesh with per-vertex AO and bent normals, as PLY or GLB bytes.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        Vertices and faces written (positions as float32 in both formats).
    ao : ndarray, float32, shape (V,)
        AO per vertex in [0, 1]; stored as the float vertex property ``ao``
        (PLY) or attribute ``_ao`` (GLB), and as the vertex colour, grey,
        8 bits, alpha 255, in each format's colour space so that a viewer
        shows AO's brightness: sRGB-encoded in the PLY (display-encoded, as
        PLY viewers take vertex colours), linear in the GLB's ``COLOR_0``
        (``round(255 * ao)``: glTF 2.0 defines ``COLOR_0`` as a linear
        multiplier of the base colour, and :func:`pyshadow.load_mesh` reads
        it back as linear).
    bent : ndarray, float32, shape (V, 3)
        Unit bent normals in the mesh's own frame; PLY properties
        ``bent_nx``, ``bent_ny``, ``bent_nz``, GLB attribute ``_bent_normal``
        (VEC3).
    mesh_format : {'ply', 'glb'}

    Returns
    -------
    bytes
        The file's bytes (binary little-endian PLY, or binary glTF).

    Raises
    ------
    ValueError
        An unknown ``mesh_format``; a mesh without triangles or with
        vertices beyond float32's range; ``ao`` not (V,) in [0, 1] or
        ``bent`` not (V, 3) finite (either would be dropped or written as
        garbage, not stored).
    TypeError
        ``ao`` or ``bent`` not real numbers.
    """
    import trimesh

    from ..io import linear_to_srgb
    from ..mesh import check_mesh

    if mesh_format not in ("ply", "glb"):
        raise ValueError(f"mesh_format must be 'ply' or 'glb', got {mesh_format!r}")
    check_mesh(mesh)
    V = len(mesh.vertices)
    if not np.abs(np.asarray(mesh.vertices)).max() <= np.finfo(np.float32).max:
        raise ValueError("mesh: vertices beyond float32's range (they would be written as inf)")
    ao, bent = np.asarray(ao), np.asarray(bent)
    for arr, what, shape in ((ao, "ao", (V,)), (bent, "bent", (V, 3))):
        if arr.dtype.kind not in "iuf":
            raise TypeError(f"{what} must hold real numbers, got dtype {arr.dtype}")
        if arr.shape != shape:
            raise ValueError(f"{what} must have shape {shape} (one per vertex), got {arr.shape}")
    bad = ~((ao >= 0.0) & (ao <= 1.0))         # NaN included
    if bad.any():
        raise ValueError(f"ao must lie in [0, 1]: {int(bad.sum())} of {V} values do not, e.g. {float(ao[bad][0])}")
    if not np.isfinite(bent).all():
        raise ValueError("bent must be finite (unit normals), got NaN or inf")

    out = trimesh.Trimesh(np.asarray(mesh.vertices), np.asarray(mesh.faces), process=False)
    level = np.clip(ao.astype(np.float64), 0.0, 1.0)
    grey = np.round(255.0 * (linear_to_srgb(level) if mesh_format == "ply" else level)).astype(np.uint8)
    colours = np.empty((len(ao), 4), np.uint8)
    colours[:, :3] = grey[:, None]
    colours[:, 3] = 255
    out.visual = trimesh.visual.ColorVisuals(out, vertex_colors=colours)
    ao = np.ascontiguousarray(ao, np.float32)
    bent = np.ascontiguousarray(bent, np.float32)
    if mesh_format == "ply":
        out.vertex_attributes["ao"] = ao
        for k, axis in enumerate("xyz"):
            out.vertex_attributes[f"bent_n{axis}"] = np.ascontiguousarray(bent[:, k])
        return out.export(file_type="ply", encoding="binary", include_attributes=True)
    out.vertex_attributes["ao"] = ao
    out.vertex_attributes["bent_normal"] = bent
    return out.export(file_type="glb")


def read_baked_mesh(path):
    """A baked mesh file back: the mesh, its AO and its bent normals as :func:`baked_mesh_bytes` stored them.

    pyvista's PLY reader (VTK's) keeps only the vertex colours of such a file, the AO's 8-bit grey; this reads
    the float32 values themselves.

    Parameters
    ----------
    path : str or os.PathLike
        A ``.ply`` or ``.glb`` file written by ``pyshadow-bake assets``.

    Returns
    -------
    mesh : trimesh.Trimesh
        The vertices (float32 values, in the mesh's own frame) and faces, in the file's order.
    ao : ndarray, float32, shape (V,)
        AO per vertex in [0, 1], as stored.
    bent : ndarray, float32, shape (V, 3)
        Unit bent normals per vertex, in the mesh's own frame, as stored.

    Raises
    ------
    FileNotFoundError
        No file at ``path``.
    ValueError
        A suffix other than ``.ply`` or ``.glb``, a file trimesh cannot read, a GLB holding other than one mesh,
        or a mesh without the baked properties (``ao``, ``bent_nx/ny/nz``; GLB ``_ao``, ``_bent_normal``).
    """
    import trimesh

    path = Path(os.fspath(path))
    kind = path.suffix.lower().lstrip(".")
    if kind not in ("ply", "glb"):
        raise ValueError(f"{path}: a baked mesh is a .ply or .glb file, not {path.suffix or 'one without a suffix'}")
    if not path.is_file():
        raise FileNotFoundError(f"no baked mesh at {path}")
    try:
        loaded = trimesh.load(path, file_type=kind, process=False)
    except Exception as exc:
        raise ValueError(f"{path}: cannot read it as {kind.upper()} ({type(exc).__name__}: {exc})") from exc
    if kind == "glb":
        found = list(getattr(loaded, "geometry", {None: loaded}).values())
        if len(found) != 1 or not isinstance(found[0], trimesh.Trimesh):
            raise ValueError(f"{path}: a baked GLB holds one mesh, this one holds {len(found)} geometries")
        mesh, attrs = found[0], found[0].vertex_attributes
        names, get = ("_ao", "_bent_normal"), lambda k: np.asarray(attrs[k])
        have = all(k in attrs for k in names)
    else:
        mesh = loaded
        data = mesh.metadata.get("_ply_raw", {}).get("vertex", {}).get("data")
        fields = () if data is None or data.dtype.names is None else data.dtype.names
        names = ("ao", "bent_nx", "bent_ny", "bent_nz")
        have = all(k in fields for k in names)
        get = lambda k: np.asarray(data[k])   # noqa: E731
    if not have:
        raise ValueError(f"{path}: not a baked mesh (its vertices lack the properties {', '.join(names)})")
    V = len(mesh.vertices)
    ao = np.ascontiguousarray(get(names[0]).reshape(-1), np.float32)
    bent = np.ascontiguousarray(np.column_stack([get(k) for k in names[1:]]).reshape(-1, 3), np.float32)
    if ao.shape != (V,) or bent.shape != (V, 3):
        raise ValueError(f"{path}: {V} vertices but {ao.shape[0]} AO values and {bent.shape[0]} bent normals")
    return trimesh.Trimesh(np.asarray(mesh.vertices), np.asarray(mesh.faces), process=False), ao, bent


def other_code(worker_code, code: str, worker) -> str | None:
    """Why outputs a worker made must not be stored under ``code``'s key, or None when they may.

    ``worker_code`` is the :func:`pyshadow.bake.params.code_digest` the task reported (None: it reported
    none); another one (a Dask cluster's worker running another pyshadow) would make a rerun keep those
    outputs as this code's for good. Used by the asset and the frame bake alike.
    """
    if worker_code == code:
        return None
    return (f"its worker {worker} runs other pyshadow code (digest {str(worker_code)[:12]}, here "
            f"{code[:12]}): install the same pyshadow on every worker, and leave it unchanged while a bake runs")


def csm_file_bytes(csm) -> bytes:
    """The bytes of ``csm``'s file as ``save(..., reproducible=True)`` writes it."""
    with tempfile.TemporaryDirectory(prefix="pyshadow-bake-") as d:
        path = Path(d) / "asset.csm"
        csm.save(path, reproducible=True)
        return path.read_bytes()


def _source_name(name: str, suffix: str) -> str:
    """The source file's name in messages: ``name`` (its stem) and ``suffix``, whose first of two
    extensions (``.tar.gz``, ``.ply.bz2``) ends the stem already."""
    head, dot, tail = suffix[1:].partition(".")
    return f"{name}.{tail}" if dot and name.lower().endswith(f".{head}") else name + suffix


def bake_asset(name: str, suffix: str, data: bytes, params: dict, key: str, side: dict | None = None) -> dict:
    """Bake one asset: build its CSM, bake per-vertex AO and bent normals.

    The task function of :func:`pyshadow.bake.bake_assets`; it never raises
    for a bad asset (the error is returned) and writes nothing but a
    temporary copy of the source and its side files (the mesh readers want
    files).

    Parameters
    ----------
    name : str
        The asset's name (output file stem).
    suffix : str
        The source file's extension with its dot (``".obj"``; a compressed
        file's last two, ``".ply.bz2"``): tells the reader the format.
    data : bytes
        The source file's content.
    params : dict
        :meth:`AssetParams.to_dict`.
    key : str
        :func:`pyshadow.bake.params.asset_key` of this asset (stored in the
        record).
    side : dict, optional
        The files the mesh file reads besides itself (:func:`side_files`):
        ``uri`` -> bytes, written beside the temporary copy of the source.

    Returns
    -------
    dict
        ``record``: the asset's manifest entry (``status`` 'baked' or
        'failed', ``error``, ``notes`` (cleanup warnings), ``mesh``, ``csm``
        and ``ao`` summaries, ``timings`` in seconds, ``worker``, ``code``:
        :func:`pyshadow.bake.params.code_digest` of the code that ran it,
        which the driver compares with its own); ``files``: relative output
        path -> bytes (empty when failed).
    """
    from ..mesh import load_mesh
    from ..sampling import Sampling
    from ..scene import Scene

    t0 = time.perf_counter()
    p = AssetParams.from_dict(params)
    record = {"name": name, "key": key, "source_sha256": _sha256(data), "params": p.to_dict(),
              "status": "failed", "error": None, "notes": [], "timings": {},
              "worker": f"{socket.gethostname()}:{os.getpid()}", "code": code_digest()}
    src = None
    try:
        with tempfile.TemporaryDirectory(prefix="pyshadow-bake-") as d:
            for uri, content in (side or {}).items():
                if _beside(uri):        # never outside the temporary folder
                    (Path(d) / uri).parent.mkdir(parents=True, exist_ok=True)
                    (Path(d) / uri).write_bytes(content)
            src = Path(d) / f"asset{suffix}"
            src.write_bytes(data)
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                mesh = load_mesh(src, fill_holes=p.fill_holes)
        record["notes"] = sorted({str(w.message).replace(str(src), name) for w in caught})
        record["mesh"] = {"vertices": int(len(mesh.vertices)), "faces": int(len(mesh.faces)),
                          "watertight": bool(mesh.is_watertight)}
        t1 = time.perf_counter()
        if p.max_error is not None:
            from .choose import choose_csm

            csm, choice = choose_csm(mesh, p)
            record["choice"] = choice
        else:
            from ..views import ViewSet

            csm = _build(mesh, ViewSet.zigzag(p.theta, p.phi), p.resolution, p.depth_bits)
        t2 = time.perf_counter()
        scene = Scene(ground=float(np.min(mesh.vertices[:, 1])) if p.ground else None)
        scene.add(csm, np.eye(4), mesh=mesh)
        ao, bent = scene.vertex_ao(0, sampling=Sampling(p.samples), return_bent_normals=True, lookup=p.lookup)
        t3 = time.perf_counter()
        names = output_names(name, p)
        files = {names["csm"]: csm_file_bytes(csm),
                 names["mesh"]: baked_mesh_bytes(mesh, ao, bent, p.mesh_format)}
        s = csm.stats
        record["csm"] = {k: s[k] for k in ("layout", "maps", "resolution", "depth_bits", "segments", "bytes",
                                           "ratio")}
        record["csm"]["build_seconds"] = t2 - t1
        record["ao"] = {"mean": float(ao.mean()), "min": float(ao.min()), "max": float(ao.max())}
        record["timings"] = {"load_s": t1 - t0, "csm_s": t2 - t1, "ao_s": t3 - t2,
                             "encode_s": time.perf_counter() - t3}
        record["status"] = "baked"
    except Exception as e:          # a bad asset is reported, never fatal to the job
        message = f"{type(e).__name__}: {e}"
        record["error"] = message.replace(str(src), _source_name(name, suffix)) if src is not None else message
        record["traceback"] = traceback.format_exc(limit=6)
        files = {}
    record["timings"]["total_s"] = time.perf_counter() - t0
    return {"record": record, "files": files}


def _build(mesh, views, resolution, depth_bits):
    from ..csm import CoherentShadowMap

    return CoherentShadowMap.build(mesh, views, resolution=resolution, depth_bits=depth_bits, progress=False)
