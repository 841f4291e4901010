"""Cube-map AO as a visibility backend: each ray marched through the best probe that sees its point.

An object of :class:`CubeMapVisibility` answers the protocol of
:mod:`pyshadow.visibility` (``visible`` and ``ambient_occlusion``) and can be
passed wherever a backend is accepted (``pyshadow.visibility.visible(...,
backend=obj)``, ``pyshadow.render.render(..., visibility=obj)``). Unlike the
per-texel AO projected by :meth:`CubeMapAO.project`, every ray here starts at
the query point itself, so the answers are comparable with Embree's on
identical rays. Occluders count within ``max_distance`` only (the probes'
``D`` by default): cube-map AO is distance-limited by construction.
"""
from __future__ import annotations

import numpy as np

from .._validate import nonzero, rows3, unit_normals
from ..sampling import ao_from_samples, sample_directions
from .estimators import raymarch_visible
from .project import CubeMapAO, check_tolerance

__all__ = ["CubeMapVisibility"]

UNSEEN = ("error", "open")


class CubeMapVisibility:
    """Visibility by marching rays through a :class:`CubeMapAO`'s probes.

    Parameters
    ----------
    maps : CubeMapAO
        Probes of the scene that will be queried (its estimator does not
        matter: rays are always marched, ``"raymarch"`` rule, with its
        :attr:`~CubeMapAO.march_options`).
    unseen : {'error', 'open'}, optional
        Points no probe sees: ``ValueError`` naming how many (default), or
        every ray from them answered as unoccluded.
    tolerance : float, optional
        Relative depth tolerance of the probe's visibility test.
    """

    name = "cubemap"

    def __init__(self, maps: CubeMapAO, *, unseen: str = "error", tolerance: float = 0.02):
        if not isinstance(maps, CubeMapAO):
            raise TypeError(f"maps must be a pyshadow.cubemap.CubeMapAO, got {type(maps).__name__}")
        if unseen not in UNSEEN:
            raise ValueError(f"unseen must be one of {UNSEEN}, got {unseen!r}")
        self.maps, self.unseen, self.tolerance = maps, unseen, check_tolerance(tolerance)

    def __repr__(self) -> str:
        return f"<CubeMapVisibility 'cubemap': {len(self.maps.probes)} probes, D = {self.maps.max_distance}>"

    def _distance(self, scene, max_distance) -> float:
        if scene is not self.maps.scene:
            raise ValueError("this cube-map backend was built for another scene")
        if self.maps.stale:
            raise ValueError("the probes are stale (the scene changed since they were rendered): call refresh()")
        if not self.maps.probes:
            raise ValueError("no probe placed yet (add_probe or place first)")
        if max_distance is None:
            return self.maps.max_distance
        d = np.asarray(max_distance, np.float64)
        if d.size == 0:
            raise ValueError("max_distance is empty: the cube-map backend takes one max_distance for all rays")
        bad = d[~(np.isfinite(d) & (d > 0))].reshape(-1)  # (NaNs read as unequal: "takes one max_distance")
        if bad.size:
            raise ValueError(f"max_distance must be a finite distance > 0 (world units), got {float(bad[0])!r}")
        if d.size != 1 and not (d == d.reshape(-1)[0]).all():
            raise ValueError("the cube-map backend takes one max_distance for all rays")
        return float(d.reshape(-1)[0])

    def _assign(self, points, normals, surface_ids):
        """Probe index of each point; ``ValueError`` for unseen points unless ``unseen='open'`` (-1 then)."""
        probe_of, _q = self.maps.assign(points, normals, surface_ids, tolerance=self.tolerance)
        lost = probe_of < 0
        if lost.any() and self.unseen == "error":
            raise ValueError(f"no probe sees {int(lost.sum())} of the {len(points)} query points "
                             "(place more probes, or unseen='open')")
        return probe_of

    def _march(self, probe_of, points, directions, D):
        """Visibility of rays (one per row) through probe ``probe_of`` of each; -1: open."""
        vis = np.ones(len(points), bool)
        for i in np.unique(probe_of[probe_of >= 0]):
            sel = np.flatnonzero(probe_of == i)
            vis[sel] = raymarch_visible(self.maps.probes[i], points[sel], directions[sel], D,
                                        device=self.maps.device, **self.maps.march_options)
        return vis

    def visible(self, scene, points, directions, *, bias=None, surface_ids=None, normals=None,
                max_distance=None, straddle="error"):
        """``(N,)`` bool: rays unoccluded within ``max_distance`` (default the probes' ``D``).

        ``bias`` and ``straddle`` do not apply (validated by the caller);
        ``normals`` and ``surface_ids`` sharpen the choice of probe.
        """
        D = self._distance(scene, max_distance)
        p = rows3(points, "points")
        w = rows3(directions, "directions", len(p))
        nonzero(w, "directions")
        return self._march(self._assign(p, normals, surface_ids), p, w, D)

    def ambient_occlusion(self, scene, points, normals, *, sampling, return_bent_normals=False, bias=None,
                          indices=None, surface_ids=None, max_distance=None, obscurance=None, quadrature=16,
                          straddle="error"):
        """Distance-limited AO of pyshadow's sample directions, each marched through the point's probe.

        ``obscurance`` (distance weighting) is not supported: ``ValueError``.
        """
        if obscurance is not None:
            raise ValueError("the cube-map backend answers distance-limited AO only (obscurance=None)")
        D = self._distance(scene, max_distance)
        p = rows3(points, "points")
        n = unit_normals(normals, len(p))
        dirs = sample_directions(n, sampling=sampling, indices=indices).astype(np.float64)
        S = dirs.shape[1]
        probe_of = np.repeat(self._assign(p, n, surface_ids), S)
        vis = self._march(probe_of, np.repeat(p, S, axis=0), dirs.reshape(-1, 3), D)
        return ao_from_samples(dirs, vis.reshape(-1, S), n, return_bent_normals)
