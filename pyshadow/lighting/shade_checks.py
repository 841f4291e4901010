"""What shading checks before it asks a visibility backend: the points, and whether AO is asked.

:func:`pyshadow.lighting.shade_terms` and :func:`pyshadow.render.render` ask ambient occlusion only
where it is needed or is their product: a :class:`~pyshadow.lighting.Lighting` without a sky
(:attr:`Lighting.has_sky` False: sun and local lights only) and a
:class:`~pyshadow.lighting.phong.PhongLighting` with a constant ambient factor (``ao="off"``) or an
ambient colour of 0 need none, so a backend that answers only light rays (one whose
``answers_ambient_occlusion`` is False: :class:`~pyshadow.lighting.ShadowMapVisibility`) shades them;
a lighting that needs AO on such a backend is refused, saying which backends answer it.
"""
from __future__ import annotations

import numpy as np

__all__ = ["answers_ambient_occlusion", "needs_ambient_occlusion", "asks_ambient_occlusion", "check_albedo_ids"]

#: Backends that answer ambient occlusion, for the advice of :func:`asks_ambient_occlusion`'s error.
AO_BACKENDS = "'csm', 'csm-vote' or 'embree'"


def answers_ambient_occlusion(backend) -> bool:
    """Whether ``backend`` (a registered name or a backend object) answers ambient occlusion: False where
    it says so (``answers_ambient_occlusion = False``), True otherwise (every backend of the protocol)."""
    from ..visibility import get_backend

    return bool(getattr(get_backend(backend), "answers_ambient_occlusion", True))


def needs_ambient_occlusion(lighting) -> bool:
    """Whether shading ``lighting`` asks AO or rays about the normals: a :class:`~pyshadow.lighting.Lighting`
    with a sky (:attr:`Lighting.has_sky`), a :class:`~pyshadow.lighting.phong.PhongLighting` whose ambient
    factor is not constant (``ao="ao"``, or ``"normal"``: one ray along each normal) and weighs something
    (an ``ambient`` colour other than 0)."""
    from .phong import PhongLighting

    if isinstance(lighting, PhongLighting):
        return lighting.ao != "off" and bool(lighting.ambient.any())
    return lighting.has_sky


def asks_ambient_occlusion(lighting, backend, caller: str) -> bool:
    """Whether ``caller`` asks ``backend`` for AO with ``lighting``: True where the backend answers AO,
    False where it does not and the lighting needs none.

    Raises
    ------
    ValueError
        The lighting needs AO (:func:`needs_ambient_occlusion`) and the backend does not answer it:
        the message names both and the backends to use.
    """
    if answers_ambient_occlusion(backend):
        return True
    if needs_ambient_occlusion(lighting):
        from .phong import PhongLighting

        what = f"its ambient term (ao={lighting.ao!r})" if isinstance(lighting, PhongLighting) else \
            f"its sky term (mode {lighting.mode!r})"
        raise ValueError(f"{caller}: the lighting needs ambient occlusion for {what}, and the visibility backend "
                         f"{backend!r} answers only light rays, not AO: use backend {AO_BACKENDS}, or a lighting "
                         f"without one (Lighting(sun=..., lights=...) with no sky; PhongLighting(ao='off'))")
    return False


def check_albedo_ids(scene, lighting, caller: str) -> None:
    """Refuse a lighting whose ``albedos`` name an instance id the scene never held (``>= len(scene.instances)``:
    a mistyped id coloured nothing, silently). An id of a removed instance (:meth:`pyshadow.Scene.remove`,
    whose ids are not given again) is accepted: it names no surface.

    Raises
    ------
    ValueError
        Naming ``albedos``, the first such id and the scene's ids.
    """
    n = len(scene.instances)
    bad = sorted(k for k in getattr(lighting, "albedos", None) or {} if k >= n)
    if bad:
        held = f"0 .. {n - 1}" if n else "none, it is empty"
        raise ValueError(f"{caller}: {type(lighting).__name__}(albedos=) names instance id {bad[0]}, which the "
                         f"scene has never held (its instance ids: {held}; ids are those Scene.add returned)")


def _check_points(scene, points, normals, surface_ids, indices, lighting=None, caller="", sampling=None):
    """The points, unit normals and pattern indices, checked by name with the ids, the lighting's albedo ids
    and ``sampling`` (also where no AO is asked: no sky, no points; ``sampling=16`` passed unread there)."""
    from .._validate import check_indices, rows3, unit_normals
    from ..sampling import Sampling

    if lighting is not None:
        check_albedo_ids(scene, lighting, caller)
    if sampling is not None and not isinstance(sampling, Sampling):
        raise TypeError(f"sampling must be a pyshadow.Sampling, got {sampling!r}")

    p = rows3(points, "points")
    nrm = unit_normals(normals, len(p))
    idx = check_indices(indices, len(p))
    if surface_ids is not None:
        ids = np.asarray(surface_ids)
        if not np.issubdtype(ids.dtype, np.integer) or ids.shape not in ((), (len(p),)):
            raise ValueError(f"surface_ids: expected an int or ({len(p)},) ints (got shape {ids.shape}, "
                             f"dtype {ids.dtype})")
        flat = np.atleast_1d(ids)
        bad = flat[(flat < -2) | (flat >= len(scene.instances))]
        if np.size(bad):
            raise ValueError(f"surface_ids: {np.ravel(bad)[0]} is neither an instance id of the scene "
                             f"(0 .. {len(scene.instances) - 1}), -1 nor GROUND_ID (-2)")
    return p, nrm, idx
