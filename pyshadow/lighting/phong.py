"""Thesis 000's shading modes: a point light with Phong specular and an AO-weighted ambient term.

Thesis 000 eq. 3.2 (section 3.2.1; eq. 2.2 without ``AO``), in Shirley's
notation::

    c = c_r (A c_a + V c_l max(0, n . l)) + V c_l c_p max(0, e . r)^p

per surface point ``x`` with unit normal ``n`` (facing the camera), ``l`` the
unit vector from ``x`` to the light, ``e`` the unit vector from ``x`` to the
eye, ``r = 2 (n . l) n - l`` the reflected light vector, and RGB triples
``c_r`` (diffuse colour: the surface's albedo, times its mesh colour where it
has one), ``c_a`` (ambient colour), ``c_l`` (light colour), ``c_p`` (specular
colour) and the exponent ``p > 0``. The specular term is 0 where
``n . l <= 0`` (the light behind the surface), as in the fixed-function
pipelines the thesis builds on. Two factors the thesis adds to eq. 2.2:

``A`` (``ao=``)
    ``"ao"`` (eq. 3.2, Fig. 6.5(b)): the point's ambient occlusion in [0, 1];
    ``"off"`` (eq. 2.2, Fig. 6.5(a)): 1, the constant ambient of the
    classic model; ``"normal"`` (the thesis's "No Ambient Occlusion" setting
    of its viewer, section 5.4.3): one shadow sample along the normal,
    ``V(x, n)`` in {0, 1} from :func:`pyshadow.visibility.visible` (the
    only visibility that setting evaluates; the thesis does not say how the
    sample enters the colour: here it takes AO's place, a one-sample AO).
``V`` (``shadows=``)
    The point light's shadow: 1 if the segment from ``x`` to the light is
    free (:func:`pyshadow.visibility.visible` with ``max_distance`` = the
    distance to the light, on the given backend; Embree for the truth),
    else 0; ``shadows=False`` gives ``V = 1`` (eq. 3.2 as printed). A light
    inside a caster's bounding sphere is refused (or answered by Embree,
    ``straddle="embree"``), as for :mod:`pyshadow.lighting.local`.

Units. This is a display-referred model, not a physical one: ``c`` is the
colour the thesis writes to its 8-bit frame buffer (values in [0, 1] show as
0..255, above 1 they clip; no tone mapping, no display gamma applied on top),
and ``c_a``, ``c_l``, ``c_p`` are colours, not radiometric quantities: the
point light has no inverse-square falloff and there is no ``1 / pi``.
``Frame.radiance`` holds ``c`` unchanged for a :class:`PhongLighting`; it is
not in the units of :class:`~pyshadow.lighting.Lighting` and must not be
added to them. :func:`display` gives the thesis's 8-bit frame buffer.

The thesis's viewer lights per vertex in the "No Ambient Occlusion" setting
(Gouraud): ``per_vertex=True`` evaluates the light's two terms
(``max(0, n . l)`` and the specular factor, without ``V``) at the three
corners of each pixel's triangle with the mesh's vertex normals and
interpolates them with the pixel's barycentric coordinates
(:func:`vertex_terms`); ``A``, ``V`` and ``c_r`` stay per pixel.
:meth:`PhongLighting.no_ao` is that setting: ``ao="normal"``,
``per_vertex=True``, ``shadows=False``.
"""
from __future__ import annotations

import math

import numpy as np

from ._checks import _floats, straddle_advice

__all__ = ["PhongLighting", "AO_MODES", "phong_colour", "phong_shade", "vertex_terms", "display",
           "light_terms"]

#: Values of ``PhongLighting(ao=)``.
AO_MODES = ("ao", "off", "normal")


def _colour(x, name: str) -> np.ndarray:
    v = _floats(x, name, "an RGB colour of shape (3,) or a scalar")
    if v.shape not in ((3,), ()):
        raise ValueError(f"{name}: expected an RGB colour of shape (3,) or a scalar (got {x!r})")
    v = np.broadcast_to(v, (3,)).copy()
    if not np.isfinite(v).all() or (v < 0).any():
        raise ValueError(f"{name}: must be finite and >= 0 per channel (got {v.tolist()})")
    return v


def _exponent(p) -> float:
    if isinstance(p, (bool, np.bool_, str, bytes)):
        raise ValueError(f"exponent: expected a finite number > 0 (got {p!r})")
    try:
        v = float(p)
    except (TypeError, ValueError):
        raise ValueError(f"exponent: expected a finite number > 0 (got {p!r})") from None
    if not (math.isfinite(v) and v > 0):
        raise ValueError(f"exponent: must be a finite number > 0 (got {p!r})")
    return v


class PhongLighting:
    """Thesis 000's point light + (AO-weighted) ambient + Phong specular (module docstring).

    Parameters
    ----------
    light : array_like (3,) or PointLight
        World position of the point light (a :class:`~pyshadow.lighting.PointLight`
        of radius 0 gives its position; its intensity is not used: the
        light's colour is ``light_colour``; a :class:`~pyshadow.lighting.SpotLight`
        is refused: its cone has no place in the model).
    ambient : float or array_like (3,)
        ``c_a``, display RGB >= 0.
    light_colour : float or array_like (3,)
        ``c_l``, display RGB >= 0.
    specular : float or array_like (3,)
        ``c_p``, display RGB >= 0 (0: no highlight).
    exponent : float
        ``p``, finite and > 0.
    albedo, albedos, ground_albedo :
        ``c_r`` per surface, in [0, 1], as for :class:`~pyshadow.lighting.Lighting`.
    ao : {"ao", "off", "normal"} or bool
        The ambient factor ``A`` (True: "ao", False: "off").
    shadows : bool
        Shadow the light (``V``) through finite shadow rays.
    per_vertex : bool
        Gouraud: the light's terms at the triangle corners, interpolated
        (needs the meshes: :func:`pyshadow.render.render` only).
    straddle : {"error", "embree"}
        Shadow rays ending inside a caster's bounding sphere: refused or
        answered by Embree (:func:`pyshadow.visibility.visible`).

    Raises
    ------
    ValueError
        A non-finite light position, a sphere light (radius > 0), a spot light, negative
        or non-finite colours, an albedo outside [0, 1], ``exponent <= 0`` or
        not finite, an unknown ``ao`` mode.
    """

    def __init__(self, light, *, ambient=(0.2, 0.2, 0.2), light_colour=(1.0, 1.0, 1.0), specular=(0.0, 0.0, 0.0),
                 exponent: float = 32.0, albedo=None, albedos=None, ground_albedo=None, ao="ao",
                 shadows: bool = True, per_vertex: bool = False, straddle: str = "error"):
        from ..visibility.finite import check_straddle
        from .local import PointLight, SpotLight
        from .shade import DEFAULT_ALBEDO, DEFAULT_GROUND_ALBEDO, Lighting

        if isinstance(light, PointLight):
            if isinstance(light, SpotLight):        # its cone would be dropped without a word
                raise ValueError(f"light: the thesis's model has an omnidirectional point light; got a "
                                 f"{type(light).__name__} (its cone is not modelled): pass its position instead")
            if light.radius > 0:
                raise ValueError(f"light: the thesis's model has a point light; got a sphere light of radius "
                                 f"{light.radius:g}")
            light = light.position
        pos = _floats(light, "light", "a finite 3-vector position or a PointLight")
        if pos.shape != (3,) or not np.isfinite(pos).all():
            raise ValueError(f"light: expected a finite 3-vector position or a PointLight (got {light!r})")
        if isinstance(ao, (bool, np.bool_)):        # NumPy's too (np.True_ was refused as no bool)
            ao = "ao" if ao else "off"
        if not (isinstance(ao, str) and ao in AO_MODES):    # an array's ``in`` has no truth value
            raise ValueError(f"ao: expected one of {', '.join(AO_MODES)} or a bool (got {ao!r})")
        for flag, name in ((shadows, "shadows"), (per_vertex, "per_vertex")):
            if not isinstance(flag, (bool, np.bool_)):
                raise ValueError(f"{name}: expected a bool (got {flag!r})")
        self.position = pos.copy()
        self.ambient = _colour(ambient, "ambient")
        self.light_colour = _colour(light_colour, "light_colour")
        self.specular = _colour(specular, "specular")
        self.exponent = _exponent(exponent)
        # the albedos' checks and per-surface lookup are Lighting's
        self._materials = Lighting(albedo=DEFAULT_ALBEDO if albedo is None else albedo, albedos=albedos,
                                   ground_albedo=DEFAULT_GROUND_ALBEDO if ground_albedo is None else ground_albedo)
        self.albedo = self._materials.albedo
        self.albedos = self._materials.albedos
        self.ground_albedo = self._materials.ground_albedo
        self.ao = ao
        self.shadows = bool(shadows)
        self.per_vertex = bool(per_vertex)
        self.straddle = check_straddle(straddle)

    @classmethod
    def no_ao(cls, light, **kwargs) -> "PhongLighting":
        """The thesis's "No Ambient Occlusion" setting: one shadow sample along the normal in AO's
        place, the point light per vertex and unshadowed (other keywords as the constructor's)."""
        kwargs = {"ao": "normal", "per_vertex": True, "shadows": False, **kwargs}
        return cls(light, **kwargs)

    def replace(self, **changes) -> "PhongLighting":
        """A copy with some constructor arguments changed (checked again)."""
        args = dict(ambient=self.ambient, light_colour=self.light_colour, specular=self.specular,
                    exponent=self.exponent, albedo=self.albedo, albedos=dict(self.albedos),
                    ground_albedo=self.ground_albedo, ao=self.ao, shadows=self.shadows,
                    per_vertex=self.per_vertex, straddle=self.straddle)
        light = changes.pop("light", self.position)
        args.update(changes)
        return PhongLighting(light, **args)

    def albedo_of(self, surface_ids, n: int | None = None) -> np.ndarray:
        """``c_r`` of each point's surface, (N, 3) float64 (:meth:`pyshadow.lighting.Lighting.albedo_of`)."""
        return self._materials.albedo_of(surface_ids, n)

    def __repr__(self) -> str:
        return (f"PhongLighting(light={self.position.tolist()}, ambient={self.ambient.tolist()}, "
                f"light_colour={self.light_colour.tolist()}, specular={self.specular.tolist()}, "
                f"exponent={self.exponent:g}, ao={self.ao!r}, shadows={self.shadows}, "
                f"per_vertex={self.per_vertex})")


def _unit(v):
    """Rows of ``v`` scaled to unit length (zero rows stay zero); a row whose squared length leaves
    float64's range (a light or eye beyond about 1e154) is divided by its largest component first."""
    with np.errstate(over="ignore"):
        d = np.linalg.norm(v, axis=-1, keepdims=True)
    far = ~(d < np.inf)
    if far.any():
        v = np.where(far, v / np.abs(v).max(axis=-1, keepdims=True), v)
        d = np.where(far, np.linalg.norm(v, axis=-1, keepdims=True), d)
    return v / np.where(d > 0, d, 1.0)


def light_terms(points, normals, eye, light_position, exponent: float):
    """The light's two scalar factors per point, without colours or shadow.

    Parameters
    ----------
    points : ndarray, shape (N, 3)
        World positions (float64).
    normals : ndarray, shape (N, 3)
        World unit normals facing the viewer.
    eye, light_position : ndarray, shape (3,)
        World positions of the eye and of the light.
    exponent : float
        ``p``.

    Returns
    -------
    diffuse : ndarray, shape (N,), float64
        ``max(0, n . l)``.
    spec : ndarray, shape (N,), float64
        ``max(0, e . r)^p`` where ``n . l > 0``, else 0.
    """
    l = _unit(np.asarray(light_position, np.float64) - points)
    e = _unit(np.asarray(eye, np.float64) - points)
    nl = np.einsum("ij,ij->i", normals, l)
    r = 2.0 * nl[:, None] * normals - l
    er = np.clip(np.einsum("ij,ij->i", e, r), 0.0, 1.0)     # a rounded e . r above 1 would overflow ^p
    spec = np.where(nl > 0, er ** exponent, 0.0)
    return np.maximum(nl, 0.0), spec


def phong_colour(lighting: PhongLighting, albedo, ambient_factor, light_visibility, diffuse, spec) -> np.ndarray:
    """Assemble ``c = c_r (A c_a + V c_l d) + V c_l c_p s``, (N, 3) float64.

    ``albedo`` (N, 3) ``c_r``; ``ambient_factor`` (N,) ``A``;
    ``light_visibility`` (N,) ``V``; ``diffuse``, ``spec`` (N,) as
    :func:`light_terms` returns them (or interpolated from the corners).
    """
    a = np.asarray(ambient_factor, np.float64)[:, None]
    v = np.asarray(light_visibility, np.float64)[:, None]
    cl = lighting.light_colour[None, :]
    return (albedo * (a * lighting.ambient[None, :] + v * cl * np.asarray(diffuse, np.float64)[:, None])
            + v * cl * lighting.specular[None, :] * np.asarray(spec, np.float64)[:, None])


def _rows_and_lengths(v):
    """``(v, |v|)`` of (N, 3) rows; a row whose squared length overflows (a light beyond about 1e154) is
    divided by its largest component and its length taken from that (the shadow rays' direction and
    ``max_distance`` then stay finite)."""
    with np.errstate(over="ignore"):
        d = np.linalg.norm(v, axis=1)
    far = ~(d < np.inf)
    if far.any():
        v = v.copy()
        big = np.abs(v[far]).max(axis=1)
        v[far] /= big[:, None]
        d[far] = big * np.linalg.norm(v[far], axis=1)
    return v, d


def _point_albedo(albedo, n: int) -> np.ndarray:
    """``phong_shade``'s ``albedo=``: a scalar, an RGB triple or (n, 3) values in [0, 1], as (n, 3) float64."""
    a = _floats(albedo, "albedo", f"a scalar, an RGB triple or ({n}, 3) values")
    if a.shape not in ((), (3,), (n, 3)):
        raise ValueError(f"albedo: expected a scalar, an RGB triple or ({n}, 3) values (got shape {a.shape})")
    bad = ~(np.isfinite(a) & (a >= 0) & (a <= 1))
    if bad.any():
        raise ValueError(f"albedo: must be finite and lie in [0, 1] per channel ({int(bad.sum())} value(s) do not, "
                         f"e.g. {float(a[bad][0])!r})" if a.ndim else f"albedo: must be finite and lie in [0, 1] "
                         f"(got {float(a)!r})")
    return np.broadcast_to(a, (n, 3))


def _terms(terms, n: int):
    """``phong_shade``'s ``terms=``: two arrays of n finite values, as (n,) float64."""
    if not isinstance(terms, (tuple, list)) or len(terms) != 2:
        raise ValueError(f"terms: expected a pair (diffuse, spec) of ({n},) arrays (got {type(terms).__name__}"
                         f"{' of ' + str(len(terms)) if isinstance(terms, (tuple, list)) else ''})")
    out = []
    for t, name in zip(terms, ("diffuse", "spec")):
        v = _floats(t, f"terms: {name}", f"({n},) finite values")
        if v.size != n:
            raise ValueError(f"terms: {name}: expected ({n},) values (got shape {v.shape})")
        if not np.isfinite(v).all():
            raise ValueError(f"terms: {name}: {int((~np.isfinite(v)).sum())} value(s) are not finite")
        out.append(v.reshape(n))
    return out


def _check_light_off_surfaces(scene, p, position):
    """Refuse a light at a query point or on the ground plane (its direction is undefined there).

    "At" is within a few float64 spacings of the coordinates involved (``4 eps`` times the larger
    coordinate magnitude of the light and the point, or the ground's height): the rounding of a
    computed surface point, whatever the scene's scale or its distance from the origin.
    """
    eps4 = 4.0 * np.finfo(np.float64).eps
    size = float(np.abs(position).max())
    if len(p):
        with np.errstate(over="ignore"):        # a light beyond about 1e154: inf, far from every point
            d = np.linalg.norm(position - p, axis=1)
        at = d <= eps4 * np.maximum(size, np.abs(p).max(axis=1))
        if at.any():
            i = int(np.argmin(np.where(at, d, np.inf)))
            raise ValueError(f"light lies on a surface: point {i} is at the light (distance {d[i]:.3g}); "
                             f"its direction to the light is undefined")
    if scene is not None and scene.ground is not None \
            and abs(position[1] - scene.ground) <= eps4 * max(size, abs(scene.ground)):
        raise ValueError(f"light lies on a surface: the ground plane y = {scene.ground:g}")


def phong_shade(scene, points, normals, eye, lighting: PhongLighting, ao=None, *, backend="csm",
                surface_ids=None, bias=None, albedo=None, geometric_normals=None, terms=None):
    """Thesis 000's colour ``c`` of surface points (module docstring), with its shadow queries.

    Parameters
    ----------
    scene : pyshadow.Scene
    points : array_like, shape (N, 3)
        World positions.
    normals : array_like, shape (N, 3)
        World normals facing the eye (normalised here; zero rows are an error).
    eye : array_like, shape (3,)
        World position of the eye (``camera.eye``).
    lighting : PhongLighting
    ao : array_like, shape (N,), optional
        AO in [0, 1] (e.g. ``Frame.ao``); needed only with ``ao="ao"`` and
        an ``ambient`` colour other than 0 (with 0, ``A`` weighs nothing: the
        values may be missing or NaN, as ``Frame.ao`` where no AO was asked).
    backend : str or VisibilityBackend
        Answers the light's shadow rays and the "normal" sample
        (``"embree"``: the ground truth on the identical rays).
    surface_ids, bias :
        As for :func:`pyshadow.visibility.visible`.
    albedo : array_like, shape (N, 3), optional
        ``c_r`` per point; default ``lighting.albedo_of(surface_ids)``.
    geometric_normals : array_like, shape (N, 3), optional
        With shading ``normals``: a light (or the normal sample) at or below
        the geometric plane is shadowed (:mod:`pyshadow.shading_normals`; the
        light's only with ``shadows=True``).
    terms : tuple of two (N,) arrays, optional
        ``(diffuse, spec)`` to use instead of :func:`light_terms` at the
        points (the corners' interpolation of :func:`vertex_terms`).

    Returns
    -------
    colour : ndarray, shape (N, 3), float64
        ``c``, display-referred (module docstring).
    ambient_factor : ndarray, shape (N,), float64
        ``A``; NaN where it is not evaluated because ``ambient`` is 0: no AO
        given (``ao="ao"``), no ray traced along the normal (``ao="normal"``).
    light_visibility : ndarray, shape (N,), float64
        ``V``: 1 without shadows (also where the light is below the surface or its
        geometric plane); with them 0 where ``n . l <= 0`` (or ``n_g . l <= 0``):
        nothing is traced there.

    Raises
    ------
    ValueError
        Before any ray is traced: a light at a shaded point or on the ground
        plane (on a surface), a light inside a caster's bounding sphere with
        ``straddle="error"`` (from :func:`pyshadow.visibility.visible`), bad
        points, normals, eye or AO values (missing with ``ao="ao"``), bad
        ``albedo`` or ``terms``, ``surface_ids`` not one int per point
        (complex numbers and text are refused, not read as reals).

    Examples
    --------
    Light and eye straight above a point (``n . l = e . r = 1``), AO 0.5:
    ``c = 0.8 (0.5 * 0.25 + 1) + 0.5``.

    >>> import pyshadow
    >>> lt = PhongLighting([0.0, 2.0, 0.0], ambient=0.25, specular=0.5, exponent=8.0)
    >>> c, a, v = phong_shade(pyshadow.Scene(), [[0.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]], [0.0, 5.0, 0.0], lt,
    ...                       [0.5], albedo=0.8)
    >>> c.round(6).tolist()
    [[1.4, 1.4, 1.4]]
    """
    from .. import visibility as vis
    from .._validate import rows3, unit_normals
    from .shade_checks import check_albedo_ids

    if not isinstance(lighting, PhongLighting):
        raise TypeError(f"lighting: expected a PhongLighting (got {type(lighting).__name__})")
    p = rows3(points, "points")
    n = len(p)
    nrm = unit_normals(normals, n)
    eye = _floats(eye, "eye", "a finite 3-vector")
    if eye.shape != (3,) or not np.isfinite(eye).all():
        raise ValueError(f"eye: expected a finite 3-vector (got {eye!r})")
    _check_light_off_surfaces(scene, p, lighting.position)
    check_albedo_ids(scene, lighting, "phong_shade")
    unlit = not lighting.ambient.any()      # c_a = 0: A weighs nothing, so it is neither needed nor traced
    if lighting.ao == "ao":
        if ao is None and not unlit:
            raise ValueError("ao: the AO values are needed with ao='ao' (and an ambient colour other than 0)")
        a = np.full(n, np.nan) if ao is None else _floats(ao, "ao", f"({n},) values in [0, 1]")
        if a.shape != (n,):
            raise ValueError(f"ao: expected ({n},) values in [0, 1] (got shape {a.shape})")
        bad = ~(np.isfinite(a) & (a >= 0) & (a <= 1) | unlit & np.isnan(a))
        if bad.any():
            raise ValueError(f"ao: expected ({n},) values in [0, 1] ({int(bad.sum())} value(s) are not, e.g. "
                             f"{float(a[bad][0])!r} at point {int(np.argmax(bad))})")
    c_r = lighting.albedo_of(surface_ids, n)         # also checks surface_ids against the points
    if albedo is not None:
        c_r = _point_albedo(albedo, n)
    geo = None if geometric_normals is None else unit_normals(geometric_normals, n, "geometric_normals")
    if terms is None:
        diffuse, spec = light_terms(p, nrm, eye, lighting.position, lighting.exponent)
    else:
        diffuse, spec = _terms(terms, n)
    ids = None if surface_ids is None else np.broadcast_to(np.asarray(surface_ids), (n,))
    to_light, dist = _rows_and_lengths(lighting.position - p)
    facing = np.einsum("ij,ij->i", nrm, to_light) > 0
    if geo is not None:
        facing &= np.einsum("ij,ij->i", geo, to_light) > 0
    v = np.ones(n)
    if lighting.shadows:
        v = np.zeros(n)
        rows = np.flatnonzero(facing)
        if len(rows):
            with straddle_advice("PhongLighting"):    # the visibility's advice: here PhongLighting's keyword
                v[rows] = vis.visible(scene, p[rows], to_light[rows], backend=backend, bias=bias,
                                      surface_ids=None if ids is None else ids[rows], normals=nrm[rows],
                                      max_distance=dist[rows], straddle=lighting.straddle)
    if lighting.ao == "ao":
        amb = a
    elif lighting.ao == "off":
        amb = np.ones(n)
    elif unlit:
        amb = np.full(n, np.nan)
    else:
        amb = np.zeros(n)
        rows = np.arange(n) if geo is None else np.flatnonzero(np.einsum("ij,ij->i", geo, nrm) > 0)
        if len(rows):
            amb[rows] = vis.visible(scene, p[rows], nrm[rows], backend=backend, bias=bias,
                                    surface_ids=None if ids is None else ids[rows], normals=nrm[rows])
    return phong_colour(lighting, c_r, np.nan_to_num(amb, nan=0.0) if unlit else amb, v, diffuse, spec), amb, v


def vertex_terms(items, item, face, bary, normals, eye, lighting: PhongLighting):
    """Gouraud: :func:`light_terms` at each pixel's triangle corners, interpolated, (K,) and (K,).

    Parameters
    ----------
    items : sequence of (mesh, transform)
        The drawn items (:func:`pyshadow.render.draw_items`).
    item, face : ndarray, shape (K,), int
    bary : ndarray, shape (K, 3)
        As :func:`pyshadow.shading_normals.pixel_surface` returns them.
    normals : ndarray, shape (K, 3)
        The pixels' normals facing the eye: a corner normal (the mesh's
        ``vertex_normals``: trimesh's angle-weighted ones, or those loaded
        with it; in the world frame) is flipped with its
        triangle where the interpolated one points away from it.
    eye : array_like, shape (3,)
    lighting : PhongLighting

    Returns
    -------
    diffuse, spec : ndarray, shape (K,), float64
        ``sum_j b_j max(0, n_j . l_j)`` and ``sum_j b_j max(0, e_j . r_j)^p``
        over the corners ``j``.
    """
    from ..gbuffer_items import pixels_by_item

    item = np.asarray(item, np.int64)
    face = np.asarray(face, np.int64)
    bary = np.asarray(bary, np.float64)
    nrm = np.asarray(normals, np.float64)
    k = len(item)
    diffuse, spec = np.zeros(k), np.zeros(k)
    for i, sel in pixels_by_item(item):
        mesh, T = items[i]
        T = np.asarray(T, np.float64)
        corners = np.asarray(mesh.faces)[face[sel]]                            # (S, 3)
        w = (np.asarray(mesh.vertices, np.float64) @ T[:3, :3].T + T[:3, 3])[corners]       # (S, 3, 3)
        vn = np.asarray(mesh.vertex_normals, np.float64) @ np.linalg.inv(T[:3, :3])         # inverse transpose
        vn = vn / np.maximum(np.linalg.norm(vn, axis=1, keepdims=True), 1e-300)
        vn = vn[corners]
        mean = np.einsum("sj,sjc->sc", bary[sel], vn)
        sign = np.where(np.einsum("sc,sc->s", mean, nrm[sel]) < 0, -1.0, 1.0)
        vn = vn * sign[:, None, None]
        dif, spc = light_terms(w.reshape(-1, 3), vn.reshape(-1, 3), eye, lighting.position, lighting.exponent)
        diffuse[sel] = np.einsum("sj,sj->s", bary[sel], dif.reshape(-1, 3))
        spec[sel] = np.einsum("sj,sj->s", bary[sel], spc.reshape(-1, 3))
    return diffuse, spec


def display(colour) -> np.ndarray:
    """The thesis's frame buffer: ``round(255 clip(c, 0, 1))`` as uint8, (H, W, 3).

    ``colour`` (H, W, 3) float: ``Frame.radiance`` of a :class:`PhongLighting`
    (display-referred; written without tone mapping or gamma, as the thesis
    does). NaN is an error, and so are text, bools and complex numbers: no
    display values (``"0.5"`` is not read as 0.5, nor ``1 + 2j`` as 1).
    """
    a = _floats(colour, "colour", "an (H, W, 3) array of display values")
    if a.ndim != 3 or a.shape[2] != 3:
        raise ValueError(f"colour: expected shape (H, W, 3) (got shape {a.shape})")
    if np.isnan(a).any():
        raise ValueError("colour: holds NaN")
    return np.floor(np.clip(a, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)
