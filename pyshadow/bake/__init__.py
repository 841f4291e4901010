"""Batch baking: many assets, many frames, on one machine or a Dask cluster.

``pyshadow-bake assets`` (:func:`bake_assets`) turns a folder of meshes into
a CSM and an AO-baked mesh per asset plus a manifest; ``pyshadow-bake
frames`` (:func:`bake_frames`) renders every frame of a scene's rigid
motion to EXR and PNG. Tasks run on Dask (``dask.distributed``: a
``LocalCluster`` of one single-threaded worker per core by default, or an
existing cluster by scheduler address), or without Dask in a local process
pool or serially. Workers receive bytes and plain parameters and return
bytes; only the driver writes files, each atomically, and a rerun skips
what is already done.
"""
from .params import AssetParams, asset_key, code_digest
from .library import MANIFEST_SCHEMA, bake_assets, find_assets
from .runner import EXECUTORS, open_executor
from .frames import bake_frames
from .assets import read_baked_mesh
from .motion import read_motion, write_motion

__all__ = ["AssetParams", "EXECUTORS", "MANIFEST_SCHEMA", "asset_key", "bake_assets", "bake_frames", "code_digest",
           "find_assets", "open_executor", "read_baked_mesh", "read_motion", "write_motion"]
