"""Pinhole camera: the eye rays of a perspective image."""
from __future__ import annotations

import numpy as np

from ._validate import point3, squared_lengths

__all__ = ["Camera"]


def _vec3(x, name):
    """``x`` as 3 finite float64 numbers (:func:`pyshadow._validate.point3`), naming ``name``."""
    return point3(x, f"Camera: {name}")


def _unit(v):
    """``v / |v|`` (float64), or None for a zero vector. Where ``|v|^2`` leaves float64's range
    (components below about 1e-154 or above 1e154) ``v`` is first divided by its largest component,
    so that any finite non-zero vector gives its direction; elsewhere the plain quotient."""
    n = _norm(v)
    if not 1e-150 < n < 1e150:
        big = np.abs(v).max()
        if not big > 0:
            return None
        v = v / big
        n = _norm(v)
    return v / n


def _norm(v) -> float:
    """``np.linalg.norm(v)``, inf or 0 without a warning where its square leaves float64's range."""
    with np.errstate(over="ignore", under="ignore"):
        return float(np.linalg.norm(v))


def axis_camera(eye, forward, up, resolution: int) -> "Camera":
    """The square 90-degree camera at ``eye`` looking along the axis ``forward`` (a cube map's face).

    Its target lies ``max(1, |eye|)`` along ``forward`` (the largest component of ``eye``), so that
    the target differs from the eye far from the origin too (at 1e17, ``eye + forward`` rounds to
    ``eye``); along an axis the view direction comes out the same either way.
    """
    e = np.asarray(eye, dtype=np.float64)
    s = max(1.0, float(np.abs(e).max()))
    return Camera(e, e + s * np.asarray(forward, np.float64), up=up, fov_y=90.0, width=resolution,
                  height=resolution)


def _check_fov(fov_y) -> float:
    """``fov_y`` as a float in (0, 180) degrees: TypeError for what is not a real number, ValueError outside."""
    if isinstance(fov_y, (str, bytes, bool)) or np.ndim(fov_y) != 0:
        raise TypeError(f"Camera: fov_y must be a number (degrees), got {fov_y!r}")
    try:
        fov = float(fov_y)
    except (TypeError, ValueError):
        raise TypeError(f"Camera: fov_y must be a number (degrees), got {fov_y!r}") from None
    if not 0.0 < fov < 180.0:
        raise ValueError(f"Camera: fov_y must be in (0, 180) degrees, got {fov}")
    return fov


def check_camera(camera) -> None:
    """TypeError unless ``camera`` is a :class:`Camera` (a ``(scene, camera)`` pair, None)."""
    if not isinstance(camera, Camera):
        raise TypeError(f"camera must be a pyshadow.Camera, got {type(camera).__name__}")


def points_on_rays(origin, t, dirs, dtype=np.float64) -> np.ndarray:
    """``origin + t dirs``: the points at distances ``t`` (shape S) along unit ``dirs`` (S + (3,))
    from ``origin`` (3,), computed in float64 by columns (faster than broadcasting over the last
    axis of three) and stored as ``dtype`` (rounded once)."""
    out = np.empty(np.shape(t) + (3,), dtype)
    direct = out.dtype == np.float64
    tmp = None if direct else np.empty(np.shape(t))
    for j in range(3):
        col = out[..., j] if direct else tmp
        np.multiply(t, dirs[..., j], out=col)
        col += origin[j]
        if not direct:
            out[..., j] = tmp
    return out


class Camera:
    """A perspective camera looking from ``eye`` at ``target``.

    Parameters
    ----------
    eye, target : array_like, shape (3,)
        World positions (any unit); they must differ.
    up : array_like, shape (3,), optional
        Approximate up direction; must not be parallel to ``target - eye``.
    fov_y : float, optional
        Vertical field of view in degrees, in (0, 180).
    width, height : int, optional
        Image size in pixels, 1 .. 16384.

    Attributes
    ----------
    forward, right, up : ndarray, shape (3,), float64
        Orthonormal camera frame: ``right = forward x up_hint`` normalised,
        ``up = right x forward`` (``up_hint`` the ``up`` given).

    Notes
    -----
    ``eye``, ``target``, ``up``, ``fov_y``, ``width`` and ``height`` may be
    set anew (``camera.eye = p``): each new value is checked as above, and
    a new ``eye``, ``target`` or ``up`` (the hint) turns the frame, which
    follows ``target - eye`` as at creation (also where ``eye`` or ``target``
    is changed in place: ``camera.eye[1] = 3``). ``forward`` and ``right``
    follow from them and cannot be set; the frame's arrays are read-only.

    Pixel ``(row i, column j)`` (row 0 at the top) is the ray from ``eye``
    through ``forward + x*right + y*up`` with
    ``x = (2(j+0.5)/W - 1) * tan(fov_y/2) * W/H`` and
    ``y = (1 - 2(i+0.5)/H) * tan(fov_y/2)``.
    """

    def __init__(self, eye, target, up=(0.0, 1.0, 0.0), fov_y: float = 45.0,
                 width: int = 640, height: int = 480):
        self._set_frame(eye, target, up)
        self.fov_y = fov_y
        self.width, self.height = width, height

    def _set_frame(self, eye, target, up) -> None:
        """Check ``eye``, ``target`` and the up hint ``up`` and set them and the frame they give (nothing
        changes where one is refused)."""
        eye, target, up = _vec3(eye, "eye"), _vec3(target, "target"), _vec3(up, "up")
        with np.errstate(over="ignore"):
            f = target - eye
        if not np.isfinite(f).all():        # beyond float64's range: the same direction, halved
            f = 0.5 * target - 0.5 * eye
        f = _unit(f)
        if f is None:
            raise ValueError("Camera: eye and target coincide")
        if not 1e-150 < _norm(up) < 1e150:     # any length: only its direction counts
            if _unit(up) is None:
                raise ValueError(f"Camera: up must not be the zero vector, got {up.tolist()}")
            up = _unit(up)
        r = np.cross(f, up)
        rn = np.linalg.norm(r)
        if not rn > 1e-9 * np.linalg.norm(up):
            raise ValueError("Camera: up is parallel to the viewing direction")
        r /= rn
        frame = {"_forward": f, "_right": r, "_up": np.cross(r, f)}
        for v in frame.values():
            v.setflags(write=False)
        self.__dict__.update(eye=eye, target=target, _up_hint=up, _given=(eye.copy(), target.copy()), **frame)

    def _frame(self, name: str) -> np.ndarray:
        """The (read-only) frame vector ``name``, turned anew where ``eye`` or ``target`` was changed in place
        (``camera.eye[1] = 3``: before, the frame kept the old eye's direction and looked past the target)."""
        d = self.__dict__
        if not (np.array_equal(d["eye"], d["_given"][0]) and np.array_equal(d["target"], d["_given"][1])):
            self._set_frame(d["eye"], d["target"], d["_up_hint"])
        return d[name]

    forward = property(lambda self: self._frame("_forward"))
    right = property(lambda self: self._frame("_right"))
    up = property(lambda self: self._frame("_up"))

    def __setattr__(self, name, value):
        """A new ``eye``, ``target`` or ``up`` hint turns the frame; ``fov_y``, ``width`` and ``height`` are
        checked as at creation (a NaN field of view gave an empty image, a width of 0 a ZeroDivisionError)."""
        if name in ("eye", "target", "up"):
            given = {"eye": self.__dict__.get("eye"), "target": self.__dict__.get("target"),
                     "up": self.__dict__.get("_up_hint")}
            given[name] = value
            self._set_frame(given["eye"], given["target"], given["up"])
            return
        if name in ("forward", "right"):
            raise AttributeError(f"Camera.{name} follows from eye, target and up; set those instead")
        if name == "fov_y":
            value = _check_fov(value)
        elif name in ("width", "height"):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not 1 <= value <= 16384:
                raise ValueError(f"Camera: {name} must be an int in 1..16384, got {value!r}")
            value = int(value)
        object.__setattr__(self, name, value)

    @property
    def tan_half(self) -> float:
        return float(np.tan(np.radians(self.fov_y) / 2.0))

    @property
    def aspect(self) -> float:
        return self.width / self.height

    @property
    def rotation(self) -> np.ndarray:
        """World-to-camera rotation, rows (right, up, forward); (3, 3) float64."""
        return np.stack([self.right, self.up, self.forward])

    def ray_directions(self) -> np.ndarray:
        """Unit world directions of every pixel's ray; (H, W, 3) float64."""
        return self._rays().copy()

    def _rays(self) -> np.ndarray:
        """:meth:`ray_directions`, read-only, kept while the camera's frame, field of view and size
        stay the same (a frame's G-buffer and surface points both ask for them)."""
        key = (self.forward.tobytes(), self.right.tobytes(), self.up.tobytes(), self.fov_y, self.width,
               self.height)
        held = self.__dict__.get("_held_rays")
        if held is None or held[0] != key:
            W, H = self.width, self.height
            x = (2.0 * (np.arange(W) + 0.5) / W - 1.0) * self.tan_half * self.aspect
            y = (1.0 - 2.0 * (np.arange(H) + 0.5) / H) * self.tan_half
            d = (self.forward + x[None, :, None] * self.right + y[:, None, None] * self.up)
            d /= np.sqrt(squared_lengths(d))[..., None]
            d.setflags(write=False)
            held = self.__dict__["_held_rays"] = (key, d)
        return held[1]

    def __getstate__(self) -> dict:
        """The camera without its kept rays (copies sent to other processes stay small)."""
        state = dict(self.__dict__)
        state.pop("_held_rays", None)
        return state

    def __repr__(self) -> str:
        return (f"Camera(eye={self.eye.tolist()}, target={self.target.tolist()}, "
                f"fov_y={self.fov_y}, width={self.width}, height={self.height})")
