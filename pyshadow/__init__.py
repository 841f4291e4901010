"""pyshadow: ambient occlusion and shadows between moving rigid bodies from
Coherent Shadow Maps, as OpenCL kernels (GPU, or CPU cores through PoCL).

Conventions used throughout (DESIGN.md): right-handed, y up; directions from
polar angles ``d(theta, phi) = (sin theta cos phi, cos theta, sin theta sin phi)``;
AO is the unoccluded, cosine-weighted fraction of the hemisphere in [0, 1];
every per-object structure lives in the object's normalised frame (bounding
sphere centre at the origin, radius 1).
"""
from ._version import __version__
from ._cl import (DeviceNotFoundError, DeviceNotSupportedError, KernelBuildError,
                  LaneWidthWarning, device_info)
from .mesh import MeshCleanupWarning, bounding_sphere, load_mesh, stand_on_ground
from .views import ViewSet
from .raster import render_depth
from .camera import Camera
from .csm import CoherentShadowMap, CSMFormatError
from .sampling import STRATEGIES, sample_directions
from .scene import Scene
from .filters import bilateral, edge_aware_box, upsample
from .io import read_image, write_image
from . import data
from .gbuffer import render_gbuffer

__all__ = [
    "__version__",
    "Camera",
    "CoherentShadowMap",
    "CSMFormatError",
    "DeviceNotFoundError",
    "DeviceNotSupportedError",
    "KernelBuildError",
    "LaneWidthWarning",
    "MeshCleanupWarning",
    "ViewSet",
    "bilateral",
    "data",
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
    "STRATEGIES",
    "upsample",
    "write_image",
]
