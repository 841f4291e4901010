"""pyshadow: ambient occlusion and shadows between moving rigid bodies from
Coherent Shadow Maps, as OpenCL kernels (GPU, or CPU cores through PoCL).

Conventions used throughout: right-handed, y up; directions from
polar angles ``d(theta, phi) = (sin theta cos phi, cos theta, sin theta sin phi)``;
AO is the unoccluded, cosine-weighted fraction of the hemisphere in [0, 1];
every per-object structure lives in the object's normalised frame (bounding
sphere centre at the origin, radius 1).

One module (or package) a job: :mod:`~pyshadow.mesh`, :mod:`~pyshadow.views`,
:mod:`~pyshadow.raster`, :mod:`~pyshadow.csm`, :mod:`~pyshadow.scene`
(placement), :mod:`~pyshadow.visibility` (queries, backends by name),
:mod:`~pyshadow.sampling`, :mod:`~pyshadow.gbuffer`, :mod:`~pyshadow.render`
(the render stage), :mod:`~pyshadow.lighting` (skies, lights, shading),
:mod:`~pyshadow.filters`, :mod:`~pyshadow.io`,
:mod:`~pyshadow.cubemap` (cube-map AO, seed 002) and :mod:`~pyshadow.ssao`
(screen-space AO): the compared methods,
:mod:`~pyshadow.cache`, :mod:`~pyshadow.embree` (ground truth),
:mod:`~pyshadow.viz` (pyvista), :mod:`~pyshadow.bench` (``pyshadow-bench``),
:mod:`~pyshadow.bake` (``pyshadow-bake``, batch baking on Dask),
:mod:`~pyshadow.data` (bundled meshes). ``import pyshadow`` reaches each of them
(``embree``, ``viz``, ``bench`` and ``bake`` are imported on first use).
"""
import importlib

from ._version import __version__
from ._cl import (DeviceNotFoundError, DeviceNotSupportedError, KernelBuildError,
                  LaneWidthWarning, device_info)
from .mesh import MeshCleanupWarning, bounding_sphere, load_mesh, stand_on_ground
from .views import ViewSet
from .raster import render_depth
from .camera import Camera
from .csm import CoherentShadowMap, CSMFormatError
from .sampling import STRATEGIES, Sampling, sample_directions
from .scene import Scene
from .filters import bilateral, edge_aware_box, upsample
from .io import read_image, write_image
from .gbuffer import render_gbuffer
from .render import Frame
from .ssao import screen_space_ao
from . import (cache, camera, csm, cubemap, data, filters, gbuffer, io, lighting, mesh, raster, render, sampling, scene,
               ssao, views, visibility)

_LAZY = ("embree", "viz", "bench", "bake")


def __getattr__(name):
    """``pyshadow.embree``, ``pyshadow.viz``, ``pyshadow.bench`` and ``pyshadow.bake`` load on
    first use (they import embreex, pyvista and the command lines' dependencies)."""
    if name in _LAZY:
        return importlib.import_module(f".{name}", __name__)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = [
    "__version__",
    "Camera",
    "CoherentShadowMap",
    "CSMFormatError",
    "DeviceNotFoundError",
    "DeviceNotSupportedError",
    "Frame",
    "KernelBuildError",
    "LaneWidthWarning",
    "MeshCleanupWarning",
    "Sampling",
    "ViewSet",
    "bilateral",
    "bounding_sphere",
    "device_info",
    "edge_aware_box",
    "load_mesh",
    "stand_on_ground",
    "read_image",
    "render_depth",
    "render_gbuffer",
    "sample_directions",
    "Scene",
    "screen_space_ao",
    "STRATEGIES",
    "upsample",
    "write_image",
    # submodules
    "bake", "bench", "cache", "camera", "csm", "cubemap", "data", "embree", "filters", "gbuffer", "io", "lighting",
    "mesh", "raster",
    "render", "sampling", "scene", "ssao", "viz", "views", "visibility",
]
