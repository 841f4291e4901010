"""What the machine's memory lets a choice of CSM build: candidates predicted to need more are not tried.

A choice (:func:`pyshadow.csm.choose.choose_csm`, :func:`~pyshadow.csm.choose.choose_within`) builds the
candidate its error model predicts to meet the target, whatever its size; on a body the CSM compresses
badly that was 8.6 GB predicted for a mesh of 2,053 faces (benchmarks/README.md, "Meshes the error model
never saw"), and the build was stopped by the system's out-of-memory kill, with nothing said. Here each
candidate's peak memory is estimated from its predicted bytes (:func:`pyshadow.csm.choose.size_model`)
and compared with the memory free when the choice starts
(:func:`pyshadow.csm.build.available_memory`); the candidates that do not fit are left out, and named.
"""
from __future__ import annotations

#: memory held at the peak per byte of the CSM: its build (the maps of a block, the segments, the
#: assembled arrays), and its build then its check against Embree (the build's arrays held, the device
#: tables set up: :func:`pyshadow.csm.device.search_arrays`). Measured (peak RSS over the process's before):
#: build 2.3-3.1x, check 2.0-2.2x more beside the CSM held, on CSMs of 74-574 MB
HOLD = {False: 3.0, True: 5.0}

#: memory held whatever the size: the renderer's and the device's buffers, the rays (measured: 0.2-0.25 GB
#: on CSMs of 22-74 MB)
FIXED = 1 << 28


def need(nbytes: float, verify: bool) -> float:
    """Bytes of memory a candidate predicted at ``nbytes`` is estimated to hold at its peak."""
    return FIXED + HOLD[bool(verify)] * nbytes


def within_memory(candidates, size, verify: bool, where: str, layout):
    """``candidates`` whose :func:`need` fits the memory free, and a record of those left out.

    Parameters
    ----------
    candidates : sequence of (theta, phi, resolution)
    size : callable
        ``size(theta, phi, resolution) -> bytes`` predicted.
    verify : bool
        Whether the choice checks what it builds (it then holds more).
    where : str
        The caller's name, for the error.
    layout : callable
        A candidate's name (``'64x128 r256'``).

    Returns
    -------
    kept : list
        The candidates that fit, in their order; all of them where the memory free is unknown.
    left_out : dict or None
        ``memory_free`` (bytes) and ``candidates`` (their names) where any was left out, else None.

    Raises
    ------
    MemoryError
        Where not even the smallest candidate fits: its name, predicted size and estimated need.
    """
    from .build import available_memory

    free = available_memory()
    if free is None:
        return list(candidates), None
    kept = [c for c in candidates if need(size(*c), verify) <= free]
    if not kept:
        small = min(candidates, key=lambda c: size(*c))
        raise MemoryError(f"{where}: no candidate CSM can be built{' and checked' if verify else ''} in the "
                          f"{free / 2 ** 30:.2f} GiB of memory free: the smallest, {layout(small)}, is predicted at "
                          f"{size(*small) / 1e6:.0f} MB and to need about {need(size(*small), verify) / 2 ** 30:.2f} "
                          "GiB while built")
    if len(kept) == len(candidates):
        return kept, None
    return kept, {"memory_free": int(free), "candidates": [layout(c) for c in candidates if c not in kept]}


def left_out_note(left_out) -> str:
    """'; N candidates predicted to need more than the X GiB of memory free were not tried (the largest, ...)'
    for a warning, or '' where none was left out."""
    if not left_out:
        return ""
    names = left_out["candidates"]
    return (f"; {len(names)} candidate{'s' if len(names) > 1 else ''} predicted to need more than the "
            f"{left_out['memory_free'] / 2 ** 30:.1f} GiB of memory free {'were' if len(names) > 1 else 'was'} "
            f"not tried ({', '.join(names[:3])}{', ...' if len(names) > 3 else ''})")
