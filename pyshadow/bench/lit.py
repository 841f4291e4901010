"""``pyshadow-bench --sky``: the bundled scene lit, pyshadow against Embree in every shading mode.

The sky (:func:`sky_lighting`):

``clear``
    :meth:`pyshadow.lighting.Lighting.clear_sky`: the Preetham sky of
    turbidity :data:`CLEAR_TURBIDITY` as SH and its sun (real angular
    radius) as a directional light, the sun at :data:`CLEAR_SUN` (latitude
    45 deg N, 21 June, 10:00 local solar time: 57.5 deg above the
    horizon, south-east, so the bodies' shadows fall back and to the left
    of the default camera).
``overcast``
    :func:`pyshadow.lighting.overcast_sky` (CIE overcast, 10 000 lux on the
    ground) as SH, no sun.
any other value
    An HDR environment map OpenImageIO reads
    (:meth:`pyshadow.lighting.EnvironmentMap.from_file`), split into a sun
    and the sky without it (:meth:`Lighting.from_environment`,
    ``extract=True``); no sun when the sun found has no irradiance (nothing
    stands out of the sky).

The lit pass (:func:`lit_pass`) renders :func:`pyshadow.render.render` with
``lighting=`` in each shading mode (:data:`LIT_MODES`: "bent", "transfer",
"sampled"; "sampled" needs the sky as a map, which every ``--sky`` has) twice
on the same camera, G-buffer and sampling: with the run's CSM backend
(``"csm"``, or ``"csm-vote"`` with ``--filtered-lookup``) and with
``"embree"``; the sky term uses the identical AO directions, the sun term
the identical shadow rays. ``radiance.exr`` and ``lit.png`` are the "bent"
frame's. The error is the relative RMSE of
radiance over the covered pixels::

    sqrt(mean_p |L_csm(p) - L_embree(p)|^2) / sqrt(mean_p |L_embree(p)|^2)

(``|.|`` the RGB vector's length): a pure visibility error, since both
renders shade alike. The lit frame is timed beside the AO frame alone
(interleaved rounds, medians); Embree's lit frame once per mode, after an
untimed warm-up frame.

Exposure of ``lit.png`` (:func:`auto_exposure`), unless ``--exposure``
gives one: the 99th percentile of the Rec. 709 luminance of the covered
pixels maps to :data:`EXPOSURE_TARGET` (0.8) before the sRGB curve, so
about 1 % of the pixels can clip (highlights) and the image does not
depend on the sky's absolute units (cd/m^2 for the built-in skies).
"""
from __future__ import annotations

import statistics
import time
from pathlib import Path

import numpy as np

from ..lighting.tonemap import EXPOSURE_PERCENTILE, EXPOSURE_TARGET, auto_exposure  # noqa: F401 (lit.py names)
from .common import _bar, _fig, _num

#: Shading modes the lit pass measures, in order ("bent" first: its frame is written).
LIT_MODES = ("bent", "transfer", "sampled")
#: Names ``--sky`` takes besides a file.
SKY_NAMES = ("clear", "overcast")
#: The clear sky's sun: :func:`pyshadow.lighting.sun_position` arguments.
CLEAR_SUN = {"latitude": 45.0, "day_of_year": 172.0, "hour": 10.0}
#: The clear sky's turbidity (Preetham et al.: 2 very clear, 3 clear, 6 hazy).
CLEAR_TURBIDITY = 3.0
#: The overcast sky's horizontal illuminance, lux.
OVERCAST_ILLUMINANCE = 10_000.0


def sky_lighting(sky: str):
    """The :class:`pyshadow.lighting.Lighting` of ``--sky`` and a JSON record of what it is.

    Raises
    ------
    FileNotFoundError, OSError, ValueError
        ``sky`` names no readable HDR environment map (the message names the file).
    """
    from ..lighting import EnvironmentMap, Lighting, overcast_sky, sun_position

    if sky == "clear":
        d = sun_position(**CLEAR_SUN)
        light = Lighting.clear_sky(d, CLEAR_TURBIDITY)
        rec = {"sky": "clear", "model": "Preetham et al. 1999", "turbidity": CLEAR_TURBIDITY,
               "sun_position": dict(CLEAR_SUN)}
    elif sky == "overcast":
        light = Lighting(overcast_sky(OVERCAST_ILLUMINANCE, height=64))
        rec = {"sky": "overcast", "model": "CIE overcast", "horizontal_illuminance": OVERCAST_ILLUMINANCE}
    else:
        env = EnvironmentMap.from_file(sky)
        light = Lighting.from_environment(env, extract=True)       # no sun where none stands out (overcast)
        rec = {"sky": "file", "file": str(Path(sky).absolute()), "layout": env.layout,     # from any folder
               "grid_shape": list(env.grid_shape)}
    if light.sun is not None:
        rec["sun"] = {"direction": [float(x) for x in light.sun.direction],
                      "irradiance": [float(x) for x in light.sun.irradiance],
                      "angular_radius": float(light.sun.angular_radius)}
    else:
        rec["sun"] = None
    return light, rec


def relative_rmse(a, b) -> float:
    """RMS of ``|a - b|`` over RMS of ``|b|`` (rows of RGB vectors); nan when empty or ``b`` is 0."""
    a = np.asarray(a, np.float64)
    b = np.asarray(b, np.float64)
    den = float(np.sqrt(np.mean(np.sum(b * b, axis=-1)))) if b.size else 0.0
    if den == 0.0:
        return float("nan")
    return float(np.sqrt(np.mean(np.sum((a - b) ** 2, axis=-1)))) / den


def lit_pass(args, cfg, scene, camera, sampling, lighting, sky_record, out_dir: Path, log) -> tuple:
    """Render the lit frame with the CSM backend and with Embree; time, compare, write the images.

    Returns
    -------
    record : dict
        The ``"lighting"`` entry of ``results.json``.
    files : dict
        ``radiance.exr`` and ``lit.png`` and their paths.
    """
    import pyshadow
    from .. import render as render_stage
    from ..lighting import tonemap, write_radiance

    backend = "csm" if cfg.lookup == "nearest" else "csm-vote"
    kw = dict(sampling=sampling, denoise=cfg.filter, normals=args.normals)
    modes = [m for m in LIT_MODES if m != "sampled" or lighting.env is not None]
    log(f"lighting: {sky_record['sky']} sky, modes {', '.join(modes)}, backend {backend!r} and 'embree'")

    def lit(light, vis="csm"):
        return render_stage.render(scene, camera, visibility=backend if vis == "csm" else vis,
                                   lighting=light, **kw)

    def ao_only():
        return render_stage.render(scene, camera, visibility=backend, **kw)

    lights = {m: lighting.with_mode(m) for m in modes}
    frames = {m: lit(lights[m]) for m in modes}       # also the warm-up
    times = {"ao": [], **{m: [] for m in modes}}
    bar = _bar(args.repeats, "timing lit frames", "round")
    try:
        for _ in range(args.repeats):
            t0 = time.perf_counter()
            ao_only()
            times["ao"].append(time.perf_counter() - t0)
            for m in modes:
                t0 = time.perf_counter()
                lit(lights[m])
                times[m].append(time.perf_counter() - t0)
            bar.update(1)
    finally:
        bar.close()
    ao_time = statistics.median(times["ao"])
    from ..lighting.sky import LUMINANCE_WEIGHTS

    frame = frames["bent"]
    covered = frame.object_id != -1
    n, S = int(covered.sum()), cfg.samples
    given = getattr(args, "exposure", None)
    exposure = given if given is not None else auto_exposure(frame.radiance, covered)
    files = {}
    write_radiance(out_dir / "radiance.exr", frame.radiance)
    files["radiance.exr"] = str(out_dir / "radiance.exr")
    pyshadow.write_image(out_dir / "lit.png", tonemap(frame.radiance, exposure))
    files["lit.png"] = str(out_dir / "lit.png")

    records = {}
    lit(lights[modes[0]], "embree")         # Embree's warm-up (its first frame builds kernels), untimed
    for m in modes:
        t0 = time.perf_counter()
        ref = lit(lights[m], "embree")
        embree_time = time.perf_counter() - t0
        lit_time = statistics.median(times[m])
        L, R = frames[m].radiance[covered], ref.radiance[covered]
        rel = relative_rmse(L, R)
        rel_ao = relative_rmse(frames[m].ao[covered][:, None], ref.ao[covered][:, None])
        lum, lum_ref = (np.asarray(x, np.float64) @ LUMINANCE_WEIGHTS for x in (L, R))
        bias = float(lum.mean() / lum_ref.mean() - 1.0) if lum_ref.size and lum_ref.mean() > 0 else None
        records[m] = {
            "radiance_rmse_relative": _fig(rel, "1", f"relative RMSE of radiance vs Embree '{m}' on the same "
                                                     f"{S} AO directions and sun rays (RMS |diff| / RMS |Embree|)"),
            "luminance_bias": _fig(bias, "1", "mean luminance pyshadow / Embree - 1"),
            "ao_rmse_relative": _fig(rel_ao, "1", "relative RMSE of the lit frames' AO vs Embree's"),
            "lit_frame_time": _fig(lit_time, "s", "render(lighting=) frame time (median)"),
            "ao_frame_time": _fig(ao_time, "s", "render() frame time, AO alone (median, interleaved)"),
            "lighting_overhead": _fig(lit_time - ao_time, "s", "lit frame time - AO frame time"),
            "lit_throughput": _fig(n * S / lit_time / 1e6 if lit_time else None, "Msamples/s",
                                   "AO samples per second of whole lit frames"),
            "ao_throughput": _fig(n * S / ao_time / 1e6 if ao_time else None, "Msamples/s",
                                  "AO samples per second of whole AO frames"),
            "embree_lit_frame_time": _fig(embree_time, "s", f"render(visibility='embree', lighting=) frame "
                                                            f"time in mode '{m}' (one run)"),
        }
    lum = np.asarray(frame.radiance[covered], np.float64) @ LUMINANCE_WEIGHTS
    record = {
        **sky_record,
        "backend": backend,
        "normals": args.normals,
        "exposure": _fig(float(exposure), "1", "tone-mapping exposure of lit.png"),
        "exposure_rule": ("--exposure" if given is not None else
                          f"{EXPOSURE_TARGET} / {EXPOSURE_PERCENTILE:g}th percentile of covered "
                          f"pixels' luminance"),
        "mean_luminance": _fig(float(lum.mean()) if lum.size else None, "radiance",
                               "mean Rec. 709 luminance of the covered pixels ('bent', sky units)"),
        "modes": records,
    }
    return record, files


def format_lighting(rec: dict) -> list:
    """Rows (label, text) of the result table for a ``results.json`` ``"lighting"`` record.

    A missing figure (``null``) prints as "n/a".
    """
    num = _num
    rows = []
    sky = rec["sky"] if rec["sky"] != "file" else f"file {rec['file']}"
    sun = rec.get("sun")
    rows.append(("lighting", f"{sky} sky, " + ("no sun" if sun is None else
                 "sun dir (" + ", ".join(f"{x:.3f}" for x in sun["direction"]) + ")")
                 + f"; exposure {num(rec['exposure']['value'], '.3g')}"))
    for mode, figs in rec["modes"].items():
        f = {k: v["value"] for k, v in figs.items()}
        rows.append((f"  {mode} vs Embree {mode}", f"rel. RMSE {num(f['radiance_rmse_relative'], '.4f')} (same "
                     f"dirs); lit frame {num(f['lit_frame_time'], '.0f', 1e3)} ms "
                     f"({num(f['lit_throughput'], '.1f')} Msamples/s) vs AO alone "
                     f"{num(f['ao_frame_time'], '.0f', 1e3)} ms ({num(f['ao_throughput'], '.1f')}); "
                     f"Embree lit {num(f['embree_lit_frame_time'], '.0f', 1e3)} ms"))
    return rows
