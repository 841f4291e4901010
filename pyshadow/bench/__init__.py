"""pyshadow-bench: ambient occlusion on a bundled scene, timed and measured against Embree.

The main job of pyshadow, end to end, on the bundled default scene (Stanford
bunny and a torus on a ground plane, two walls) or on the user's own meshes:

1. build the casters' Coherent Shadow Maps, or load them from the on-disk
   cache (``platformdirs.user_cache_dir("pyshadow")``, ``$PYSHADOW_CACHE`` or
   ``--cache-dir``; keyed by the mesh hash, every build parameter and the
   compression code; a corrupt cache file is rebuilt);
2. render AO (:meth:`pyshadow.Scene.render`, 36 cosine-weighted Hammersley
   samples per pixel by default) and time it;
3. trace the *identical* rays -- the same G-buffer points, the same sample
   directions -- with Embree (embreex, one thread per core) and time them;
   per-ray agreement of the two isolates the CSM's discretisation error
   (benchmarks/README.md);
4. trace a converged Embree reference (1024 samples per pixel by default,
   cached like the CSMs) and measure the AO error against both references;
5. print one table and write ``ao.png``, ``reference.png``,
   ``difference.png``, ``ao.exr``, ``reference.exr``, ``converged.exr`` and
   ``results.json`` into ``--out``.

``--sky clear|overcast|FILE`` also renders the scene lit ("bent" mode) with
the CSMs and with Embree on the same directions, prints the relative RMSE
of radiance and the lit frame time beside AO alone, and writes
``radiance.exr``, ``lit.png`` and a ``"lighting"`` entry
(:mod:`~pyshadow.bench.lit`).

``--sweep`` runs the speed/accuracy trade study instead (maps, resolution,
samples, filter, depth bits) and writes ``sweep.json``, ``sweep.md`` and
``pareto.png``; with ``--sweep``, ``--max-error E`` names the fastest row of
the sweep whose AO RMSE (against the converged reference) is at most ``E``.
``--max-error E`` alone answers without a sweep: a model of AO noise, bias
and frame time fitted to a few renders of the base CSMs chooses the sample
count and filter, and a render of the choice verifies it
(:mod:`~pyshadow.bench.answer`, ``max_error.json``).

Every figure of ``results.json`` is an object ``{"value": ..., "unit": ...,
"label": ...}``; see ``benchmarks/README.md`` for the schema and the
commands that reproduce every published figure.

Usage::

    pyshadow-bench                       # default scene, 640x480, 36 samples
    pyshadow-bench --quick               # smaller settings
    pyshadow-bench --quick --sky clear   # also the lit frame: radiance.exr, lit.png
    pyshadow-bench --sweep --max-error 0.02
    pyshadow-bench --max-error 0.02      # from a model, verified: no sweep
    pyshadow-bench --mesh a.obj --mesh b.ply --json
    python -m pyshadow.bench ...         # the same

Modules: :mod:`~pyshadow.bench.cli` (options, ``main``, output files),
:mod:`~pyshadow.bench.config` (:class:`Config`, presets, sweep grids),
:mod:`~pyshadow.bench.scenes` (the scenes and their CSMs),
:mod:`~pyshadow.bench.measure` (G-buffer, Embree and pyshadow passes,
errors, converged reference), :mod:`~pyshadow.bench.single` (the single
benchmark), :mod:`~pyshadow.bench.lit` (``--sky``: the lit frame),
:mod:`~pyshadow.bench.sweep` (the sweep, Pareto front,
``--sweep --max-error``), :mod:`~pyshadow.bench.answer` (``--max-error``
alone: the model and its verification), :mod:`~pyshadow.bench.report` (table, markdown, plots,
difference image), :mod:`~pyshadow.bench.common` (progress, figure
records). The CSM cache is :mod:`pyshadow.cache`; the threaded Embree
tracer is :class:`pyshadow.embree.EmbreeTracer`.
"""

from ..cache import CSMCache, default_cache_dir
from ..embree import EmbreeTracer
from .answer import MAX_ERROR_SCHEMA, FilterModel, run_max_error
from .cli import build_parser, main
from .common import environment
from .config import PRESETS, SWEEP_GRIDS, Config
from .measure import (GBuffer, by_surface, converged_reference, embree_pass, time_rays,
                      visibility_pass)
from .report import difference_rgb, format_table, pareto_plot, sweep_markdown
from .scenes import SceneFactory, mesh_scene
from .single import SCHEMA, TIMED_SAMPLES, run_main
from .sweep import SWEEP_SCHEMA, best_under, pareto_front, run_sweep, sweep_configs

__all__ = ["main", "PRESETS", "SWEEP_GRIDS", "Config", "CSMCache", "EmbreeTracer", "mesh_scene",
           "pareto_front",
           # as importable from pyshadow.bench before its split into modules
           "build_parser", "by_surface", "converged_reference", "default_cache_dir", "difference_rgb",
           "embree_pass", "environment", "format_table", "GBuffer", "pareto_plot", "run_main",
           "run_sweep", "SceneFactory", "SCHEMA", "SWEEP_SCHEMA", "best_under", "sweep_configs",
           "sweep_markdown", "time_rays", "TIMED_SAMPLES", "visibility_pass",
           # --max-error without --sweep
           "FilterModel", "MAX_ERROR_SCHEMA", "run_max_error"]
