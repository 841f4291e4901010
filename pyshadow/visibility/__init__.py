"""Visibility queries, one protocol with backends registered by name.

``visible(scene, points, directions, ...)`` and ``ambient_occlusion(scene,
points, normals, ...)`` are answered by the backend named in ``backend=``:

=============  ==============================================================
``"csm"``      the visibility kernel, one texel of each caster's nearest map
``"csm-vote"`` the kernel's vote over four maps times four texels
``"numpy"``    the float64 NumPy mirror of ``"csm"`` (``"numpy-vote"``:
               of ``"csm-vote"``), for small inputs and tests
``"embree"``   Embree ray tracing against the casters' meshes: ground truth
=============  ==============================================================

Later methods register themselves with :func:`register` and answer through
the same calls (and through :func:`pyshadow.render.render`). The protocol is
in :mod:`pyshadow.visibility.base`.
"""
from __future__ import annotations

from .._validate import flag
from . import finite
from .base import VisibilityBackend, backends, check_bias, get_backend, register
from .csm import CSMVisibility
from .mirror import NumPyVisibility, ambient_occlusion_reference, visible_reference
from .raytraced import EmbreeVisibility

__all__ = ["visible", "ambient_occlusion", "VisibilityBackend", "register", "get_backend", "backends",
           "CSMVisibility", "NumPyVisibility", "EmbreeVisibility", "visible_reference",
           "ambient_occlusion_reference"]


def visible(scene, points, directions, *, backend="csm", bias=None, surface_ids=None, normals=None,
            max_distance=None, straddle="error"):
    """Does each ray reach the sky?

    Parameters
    ----------
    scene : pyshadow.Scene
    points : array_like, shape (N, 3)
        World positions (a point on a caster's surface is not occluded by
        that surface itself: see ``bias``). float64 or float32 C-contiguous
        arrays are read in place by the kernel backends (no copy); other
        dtypes are converted to float64 first.
    directions : array_like, shape (N, 3)
        World directions, float64 or float32 as for ``points``; normalised
        here, so any non-zero length works (lengths far outside float32's
        range are first scaled by an exact power of two).
    backend : str or VisibilityBackend, optional
        A registered name (:func:`backends`) or a backend object.
    bias : float, optional
        Depth tolerance (>= 0) in normalised depth units (1 = the diameter
        of a CSM's bounding sphere) against every caster. Default: a self-bias
        against the caster a point lies on (see ``surface_ids``), the depth
        quantum against the others (:mod:`pyshadow.visibility.csm` gives
        the rule).
    surface_ids : int or array_like of int, optional
        Instance id of the surface each point lies on; ``-1`` (default)
        means unknown (the self-bias then applies against every caster),
        ``pyshadow.scene.GROUND_ID`` (-2) the ground plane. Points on
        receivers and the ground need no self-bias, so contact shadows stay
        sharp. A ground (or receiver) point that lies on a face of an open
        caster lying on the ground (the floor of a box without a lid) is
        that caster's surface there and is asked as it
        (:func:`pyshadow.contact.ground_sheet_slots`).
    normals : array_like, shape (N, 3), optional
        World normal of the surface each point lies on (normalised here;
        zero or non-finite rows are an error). With them, a ray leaving a
        caster's own surface is answered by the surface rule
        (:mod:`pyshadow.csm.surface_rule`): grazing rays over a flat face
        are not shadowed by the face itself, and each tap compares the
        stored depth with the plane through the point with that normal at
        the tap's texel centre (the default bias; with ``bias=`` the point
        is lifted off the surface instead), so a wall rising beside the
        point is seen. ``ambient_occlusion``
        always applies it. Backends that need no normals (``"embree"``) ignore them.
    max_distance : float or array_like, shape (N,), optional
        Finite shadow rays: the length of each ray, world units (> 0;
        ``inf``: unbounded), e.g. the distance to a point light. Occluders
        beyond it do not count; a caster whose bounding sphere holds the
        ray's end cannot be answered by a CSM (:mod:`pyshadow.visibility.finite`
        gives the rules, the ground plane's included). Default: unbounded.
    straddle : {'error', 'embree'}, optional
        With ``max_distance``: refuse rays that end inside a caster's
        bounding sphere with a ``ValueError`` naming the instance (default),
        or answer those rays only with Embree (needs the casters' meshes).

    Returns
    -------
    ndarray, shape (N,), bool
        True where the ray reaches the sky.
    """
    _check_scene(scene)
    extra = {} if normals is None else {"normals": normals}
    check_bias(bias)
    finite.check_straddle(straddle)     # also without max_distance: a bad value is not silently dropped
    if max_distance is not None:        # backends without finite rays still answer the default query
        extra.update(max_distance=max_distance, straddle=straddle)
    return get_backend(backend).visible(scene, points, directions, bias=bias, surface_ids=surface_ids, **extra)


def ambient_occlusion(scene, points, normals, *, backend="csm", sampling=None, return_bent_normals=False,
                      bias=None, indices=None, surface_ids=None, max_distance=None, obscurance=None,
                      quadrature=16, straddle="error"):
    """Ambient occlusion of surface points (1 = open).

    By default every occluder counts, however far (seed 002 eq. 3.5). With
    ``max_distance`` D only those a sample ray meets within D (seed 002's
    marching limit: rho a step at D); with ``obscurance`` tau each ray
    contributes rho(L) = 1 - exp(-tau L) of its first-hit distance L (seed
    002 eq. 3.3/3.4, after [IKSZ03]; 1 beyond D, and for a miss). Embree
    answers these exactly; the CSM backends (and the NumPy mirror) answer
    "is the ray free up to t" only, so weighted AO is the midpoint
    quadrature of :mod:`pyshadow.visibility.finite` with ``quadrature`` Q
    lengths per ray: within 1 / (2Q) of rho for every ray, exact for
    rays that reach beyond D.

    Parameters
    ----------
    scene : pyshadow.Scene
    points, normals : array_like, shape (N, 3)
        World positions and surface normals (normalised here; zero normals
        are an error).
    backend : str or VisibilityBackend, optional
    sampling : pyshadow.Sampling, optional
        Default ``Sampling()`` (36 Hammersley directions, 256 patterns).
    return_bent_normals : bool, optional
        Also return the normalised sum of the unoccluded directions (the
        normal itself where every direction is occluded).
    bias, surface_ids : optional
        As in :func:`visible`.
    indices : array_like of int, shape (N,), optional
        Sample-pattern index of each point; default ``arange(N)``.
    max_distance : float or array_like, shape (N,), optional
        Distance limit D of each point's sample rays, world units (> 0;
        ``inf``: unbounded). Default: unbounded -- exactly the AO of before
        (the same kernel, compiled as before).
    obscurance : float, optional
        tau of rho(L) = 1 - exp(-tau L), 1 / world units (> 0): distance-
        weighted AO. Default: none (rho a step at D).
    quadrature : int, optional
        Q, 1 .. 256: lengths asked per ray for weighted AO on the CSM
        backends (Q finite queries per ray; Embree ignores it).
    straddle : {'error', 'embree', 'infinite'}, optional
        Distance AO on the CSM backends: a ray whose end lies inside a
        caster's bounding sphere is first asked unbounded -- free there means
        free (exact). If the unbounded ray is occluded, a CSM cannot tell
        whether the occluder lies within D: ``'error'`` (default) raises a
        ValueError naming the instance, ``'embree'`` traces those rays
        (exact; needs the casters' meshes), ``'infinite'`` keeps the
        unbounded answer (too dark by the occluders beyond D, never too
        bright). Points on a caster with D below its size straddle for
        most rays.

    Returns
    -------
    ao : ndarray, shape (N,), float32
        Unoccluded cosine-weighted fraction in [0, 1].
    bent : ndarray, shape (N, 3), float32
        Only with ``return_bent_normals=True``.
    """
    from ..sampling import Sampling

    _check_scene(scene)
    if sampling is None:
        sampling = Sampling()
    elif not isinstance(sampling, Sampling):
        raise TypeError(f"sampling must be a pyshadow.Sampling, got {sampling!r}")
    extra = {}
    check_bias(bias)
    finite.check_ao_options(obscurance, quadrature, straddle)     # checked even where unused: not dropped
    if max_distance is not None or obscurance is not None:     # other backends answer the default query
        extra = dict(max_distance=max_distance, obscurance=obscurance, quadrature=quadrature, straddle=straddle)
    return get_backend(backend).ambient_occlusion(scene, points, normals, sampling=sampling,
                                                  return_bent_normals=flag(return_bent_normals, "return_bent_normals"),
                                                  bias=bias, indices=indices, surface_ids=surface_ids, **extra)


def _check_scene(scene) -> None:
    """TypeError unless ``scene`` is a :class:`pyshadow.Scene`, or an object that answers as one (a wrapper
    passing on its attributes): the (scene, camera) pair of ``pyshadow.data.default_scene()``, a
    CoherentShadowMap or a mesh failed in a backend with "'tuple' object has no attribute 'caster_slots'"
    (Embree: "... 'instances'")."""
    from ..scene import Scene

    if not isinstance(scene, Scene) and not all(hasattr(scene, a) for a in ("instances", "caster_slots", "anchor")):
        hint = ""
        if isinstance(scene, tuple) and scene and isinstance(scene[0], Scene):
            hint = " (a tuple whose first item is one: pyshadow.data.default_scene() returns (scene, camera))"
        elif type(scene).__name__ in ("CoherentShadowMap", "Trimesh"):
            hint = " (place it in a Scene with Scene.add)"
        raise TypeError(f"scene must be a pyshadow.Scene, got {type(scene).__name__}{hint}")
