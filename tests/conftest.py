"""Shared fixtures: the test meshes of ../shared/meshes and small helpers."""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]


def shared_dir() -> Path:
    env = os.environ.get("PYSHADOW_SHARED")
    return Path(env) if env else REPO.parent / "shared"


MESH_DIR = shared_dir() / "meshes"


def mesh_path(name: str) -> Path:
    """Path of a test mesh; pyvista's bundled meshes are named 'pyvista:airplane'."""
    if name.startswith("pyvista:"):
        from pyvista import examples

        return Path(examples.__file__).parent / (name.split(":", 1)[1] + ".ply")
    path = MESH_DIR / name
    if not path.is_file():
        raise FileNotFoundError(
            f"test mesh {path} is missing: the tests need ../shared/meshes beside the "
            "repository (or PYSHADOW_SHARED pointing at a folder holding meshes/)"
        )
    return path


_cache: dict = {}


def load(name: str, fill_holes: bool = False):
    """Load (and cache) a test mesh through pyshadow.load_mesh."""
    import pyshadow

    key = (name, fill_holes)
    if key not in _cache:
        _cache[key] = pyshadow.load_mesh(mesh_path(name), fill_holes=fill_holes)
    return _cache[key]


@pytest.fixture
def rng():
    return np.random.default_rng(12345)
