"""An asset's CSM parameters from the accuracy asked for: :mod:`pyshadow.csm.choose` for a bake.

The error model predicts every candidate's disagreement with Embree without
building it, the smallest predicted to meet ``max_error`` is built and
checked against Embree on independent rays, and the walk goes on where the
check misses (:func:`pyshadow.csm.choose.choose_csm`). Deterministic (fixed
seeds), so every worker chooses alike; the record goes to the manifest.
"""
from __future__ import annotations

__all__ = ["choose_csm"]


def choose_csm(mesh, params):
    """The CSM of ``mesh`` chosen for ``params.max_error``, and its JSON-ready record.

    Parameters
    ----------
    mesh : trimesh.Trimesh
    params : pyshadow.bake.AssetParams
        ``max_error`` (fraction), ``depth_bits``, ``lookup``.

    Returns
    -------
    csm : CoherentShadowMap
    choice : dict
        :func:`pyshadow.csm.choose.choose_csm`'s record (``target``, ``met``,
        ``maps``, ``resolution``, ``predicted``, ``measured``, ``tried``, ...).
    """
    import warnings

    from ..csm.choose import choose_csm as choose

    if params.max_error is None:
        raise ValueError("choose_csm: params.max_error is None; set the accuracy to choose the CSM for")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)      # a miss is in the record ("met": false)
        return choose(mesh, params.max_error, lookup=params.lookup, depth_bits=params.depth_bits)
