"""An asset's CSM parameters from the accuracy asked for, by measurement against Embree.

Each asset climbs :data:`LADDER`, from the cheapest CSM up: at each rung the
CSM is built and its answers on the asset's own AO rays (points sampled on
its surface, cosine-weighted directions) are compared with Embree's on the
identical rays; the first rung whose disagreement is at most ``max_error``
is kept. The choice and every measurement are returned for the manifest.
This measures instead of predicting, so it costs a build per rung tried and
an Embree pass; it is deterministic (fixed seeds), so every worker chooses
alike.
"""
from __future__ import annotations

import numpy as np

__all__ = ["LADDER", "disagreement", "choose_csm"]

#: (theta, phi, resolution) rungs, by increasing texel count (maps x resolution^2).
LADDER = ((16, 32, 64), (32, 64, 64), (32, 64, 128), (64, 128, 128), (64, 128, 256), (128, 256, 256))
#: Surface points and directions per point of the measurement.
POINTS, SAMPLES, SEED = 2000, 16, 7


def disagreement(scene, mesh, lookup: str = "nearest", points: int = POINTS, samples: int = SAMPLES,
                 seed: int = SEED) -> float:
    """Share of AO rays from instance 0's surface that the CSM answers unlike Embree.

    Parameters
    ----------
    scene : pyshadow.Scene
        Instance 0 is ``mesh`` with its CSM, identity transform.
    mesh : trimesh.Trimesh
    lookup : {'nearest', 'vote'}
    points, samples, seed : int
        ``points`` surface points (area-uniform, ``trimesh.sample``), each
        with ``samples`` cosine-weighted directions about its face normal.

    Returns
    -------
    float
        Fraction in [0, 1] of the ``points * samples`` rays whose visibility
        differs from :func:`pyshadow.embree.visible`.
    """
    import trimesh

    from .. import embree
    from ..sampling import Sampling, sample_directions

    local, face = trimesh.sample.sample_surface(mesh, points, seed=seed)
    n = np.asarray(mesh.face_normals)[face]
    d = sample_directions(n, sampling=Sampling(samples, seed=seed)).reshape(-1, 3).astype(np.float64)
    P = np.repeat(local, samples, axis=0)
    N = np.repeat(n, samples, axis=0)
    truth = embree.visible(scene, P, d)
    ours = scene.visible(P, d, surface_ids=np.zeros(len(P), np.int64), normals=N, lookup=lookup)
    return float(np.mean(ours != truth))


def choose_csm(mesh, params):
    """The cheapest rung of :data:`LADDER` meeting ``params.max_error``, and what was measured.

    Parameters
    ----------
    mesh : trimesh.Trimesh
    params : pyshadow.bake.AssetParams
        ``max_error`` (fraction), ``depth_bits``, ``lookup``, ``ground``.

    Returns
    -------
    csm : CoherentShadowMap
        The chosen rung's CSM; the finest rung's when none meets the target.
    choice : dict
        ``target``, ``met`` (bool), ``maps`` (theta, phi), ``resolution``,
        ``disagreement`` of the chosen rung, ``tried``: every rung measured
        (maps, resolution, disagreement, bytes).
    """
    from ..csm import CoherentShadowMap
    from ..scene import Scene
    from ..views import ViewSet

    tried = []
    for theta, phi, res in LADDER:
        csm = CoherentShadowMap.build(mesh, ViewSet.zigzag(theta, phi), resolution=res,
                                      depth_bits=params.depth_bits, progress=False)
        scene = Scene(ground=float(np.min(mesh.vertices[:, 1])) if params.ground else None)
        scene.add(csm, np.eye(4), mesh=mesh)
        e = disagreement(scene, mesh, params.lookup)
        tried.append({"maps": [theta, phi], "resolution": res, "disagreement": e, "bytes": csm.stats["bytes"]})
        if e <= params.max_error:
            break
    best = tried[-1]
    return csm, {"target": float(params.max_error), "met": best["disagreement"] <= params.max_error,
                 "maps": best["maps"], "resolution": best["resolution"],
                 "disagreement": best["disagreement"], "tried": tried}
