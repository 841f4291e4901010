"""What a person reads: the result table, the sweep's markdown, the Pareto plot, the difference image."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..lighting._checks import positive
from .common import _num
from .config import _config_of
from .sweep import _answer_text


def difference_rgb(diff, covered, vmax=None):
    """Diverging colour image of ``diff`` (RdBu centred at 0, symmetric range), uint8 RGB.

    Red: pyshadow darker (more occluded) than the reference; blue: lighter.
    The range is ``vmax`` or the 99.5th percentile of ``|diff|`` over the
    covered pixels (at least 0.01). Returns ``(rgb, vmax)``.

    Raises
    ------
    ValueError
        ``vmax`` given and not a finite number > 0 (0 divided by zero, a
        negative one swapped red and blue).
    """
    import matplotlib

    d = np.asarray(diff, np.float64)
    if vmax is None:
        a = np.abs(d[covered])
        vmax = max(0.01, float(np.percentile(a, 99.5)) if a.size else 0.0)
    else:
        vmax = positive(vmax, "vmax")
    cmap = matplotlib.colormaps["RdBu"]
    rgb = cmap(np.clip(0.5 + 0.5 * d / vmax, 0.0, 1.0), bytes=True)[..., :3]
    return np.ascontiguousarray(rgb, dtype=np.uint8), vmax


def format_table(r: dict) -> str:
    """The table of a single benchmark's ``results.json`` record, as printed (no final newline).

    A figure whose value is missing (``null`` in results.json: it was not
    finite, or not measured) prints as "n/a". The AO time names the pixels
    it was measured on when they are fewer than the covered ones
    (``timed_pixels``). The rows by surface measure the unfiltered AO; with
    a filter their heading says so.
    """
    f = {k: v["value"] for k, v in r["figures"].items()}
    c, env = r["config"], r["environment"]
    num = _num

    if r["csm"]["source"] == "cached":
        build = "cached (loaded in %s s%s)" % (
            num(f["csm_time"], ".2f"),
            "" if f["csm_build_time"] is None else f"; built in {num(f['csm_build_time'], '.1f')} s")
    else:
        build = f"{num(f['csm_time'], '.1f')} s ({r['csm']['source']})"
    rs = c["reference_samples"]
    n, k = f["covered_pixels"], f.get("timed_pixels")      # AO timed on the first k pixels when k < n
    px = (f"; {num(n, 'd')} px" if n is None or k is None or k >= n else
          f" on the first {num(k, 'd')} of {num(n, 'd')} px")
    conv_t = "cached" if r["converged_source"] == "cached" else f"{num(f['converged_time'], '.1f')} s"
    rows = [
        ("device", f"{env['device']} ({env['platform']}, {env['device_type']}, "
                   f"{env['compute_units']} compute units)"),
        ("CSM build", build),
        ("CSM size, ratio", f"{num(f['csm_size'], '.2f')} MB, {num(f['csm_ratio'], '.1f')}:1"),
        ("AO", f"{num(f['ao_throughput'], '.2f')} Msamples/s; frame {num(f['frame_time'], '.0f', 1e3)} ms "
               f"(AO {num(f['ao_time'], '.0f', 1e3)} ms{px})"
               + ("" if f.get("frame_time_interleaved") is None else
                  f"; {num(f['frame_time_interleaved'], '.0f', 1e3)} ms a frame between Embree's timings")),
        (f"Embree, same rays ({env['embree_threads']} thr)",
         f"{num(f['embree_ray_rate'], '.2f')} Mrays/s ({num(f['embree_throughput'], '.2f')} Msamples/s)"),
        ("pyshadow / Embree", f"{num(f['speedup'], '.2f')}x"),
        ("visibility agreement", f"{num(f['visibility_agreement'], '.3f', 100)} % "
                                 f"({num(f['false_visible'], '.3f', 100)} % too open, "
                                 f"{num(f['false_occluded'], '.3f', 100)} % too shadowed)"),
        (f"AO vs Embree, same {c['samples']} dirs", f"RMSE {num(f['ao_rmse_identical'], '.4f')}  "
                                                    f"MAE {num(f['ao_mae_identical'], '.4f')}"),
        (f"AO vs Embree {rs} spp", f"RMSE {num(f['ao_rmse_converged'], '.4f')}  "
                                   f"MAE {num(f['ao_mae_converged'], '.4f')}"
                                   f"  (Embree {c['samples']} spp itself: RMSE "
                                   f"{num(f['reference_noise_rmse'], '.4f')})"),
        ("converged reference", conv_t),
        ("total", f"{num(f['total_time'], '.1f')} s"),
        # the unfiltered AO (by_surface): with a filter, not the image the converged RMSE above measures
        ("by surface", "pixels, ray agreement, AO bias and RMSE (pyshadow - Embree)"
                       + (f"; the AO before the {c['filter']} filter" if c["filter"] else "")),
    ]
    for srf in r.get("surfaces", []):
        g = {k: v["value"] for k, v in srf.items() if isinstance(v, dict)}
        rows.append((f"  {srf['surface']}", f"{num(g['pixels'], '>7')} px  agreement "
                     f"{num(g['visibility_agreement'], '7.3f', 100)} %  "
                     f"bias {num(g['ao_bias_identical'], '+.4f')}  "
                     f"RMSE {num(g['ao_rmse_identical'], '.4f')} (same dirs) "
                     f"{num(g['ao_rmse_converged'], '.4f')} (converged)"))
    if "lighting" in r:
        from .lit import format_lighting

        rows += format_lighting(r["lighting"])
    if "light" in r:
        from .light import format_light

        rows += format_light(r["light"])
    w = max(len(k) for k, _ in rows)
    head = (f"pyshadow-bench ({r['mode']}): {r['scene']}\n"
            f"  {c['width']}x{c['height']}, {c['samples']} samples ({c['strategy']}), maps zigzag "
            f"{c['maps']} at {c['resolution']}^2, {c['depth_bits']}-bit depth"
            + (f", filter {c['filter']}" if c["filter"] else "")
            + (", filtered lookups" if c.get("filtered_lookup") else ""))
    return head + "\n" + "\n".join(f"  {k:<{w}}  {v}" for k, v in rows)


def sweep_markdown(sw: dict) -> str:
    """``sweep.md``: a sweep's setting, its rows as a markdown table, the ``--max-error`` answer.

    A figure whose value is missing (``null`` in sweep.json) prints as "n/a".
    """
    env = sw["environment"]
    lines = [
        f"# pyshadow-bench sweep ({sw['grid']} grid)", "",
        f"- scene: {sw['scene']}; {sw['image']['width']}x{sw['image']['height']} pixels",
        f"- device: {env['device']} ({env['platform']}); pyshadow {env['pyshadow']}",
        f"- base: {_config_of(sw['base']).label}"
        f"; strategy {sw['strategy']}; converged reference {sw['reference_samples']} spp (Embree)",
        f"- runtime: {_num(sw['runtime']['value'], '.0f')} s; frame and AO times are medians of "
        f"{sw['repeats']} runs after a warm-up, taken in rounds interleaved over all rows", "",
        "| configuration | varies | build s | CSM MB | ratio | frame ms | AO Msamples/s "
        "| agreement % | RMSE | MAE | RMSE same rays | Pareto |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|:---:|",
    ]
    num = _num          # a missing figure (null) prints as "n/a"
    for r in sw["rows"]:
        f = {k: v["value"] for k, v in r["figures"].items()}
        mb = None if f["csm_bytes"] is None else f["csm_bytes"] / 1e6
        lines.append(
            f"| {r['label']} | {r['varies']} | {num(f['build_time'], '.1f')} | {num(mb, '.2f')} "
            f"| {num(f['csm_ratio'], '.1f')} | {num(f['frame_time'], '.0f', 1e3)} "
            f"| {num(f['ao_throughput'], '.2f')} | "
            f"{num(f['visibility_agreement'], '.3f', 100)} | {num(f['ao_rmse_converged'], '.4f')} | "
            f"{num(f['ao_mae_converged'], '.4f')} | {num(f['ao_rmse_identical'], '.4f')} | "
            f"{'**yes**' if r['pareto'] else ''} |")
    lines += ["", "RMSE/MAE: AO against the converged reference over covered pixels (filtered "
              "rows: the filtered image). RMSE same rays: unfiltered AO against Embree on the "
              "identical rays (discretisation only). Build s: the original build time of the "
              "CSMs (also for cached ones).", ""]
    if sw.get("max_error"):
        lines += [_answer_text(sw["max_error"]), ""]
    if sw.get("methods"):
        from .method_sweep import points_markdown, winners_text

        m = sw["methods"]
        lines += [f"## Methods (D = {_num(m['distance']['value'], '.4g')} for the distance-limited definition; "
                  "frame time: G-buffer raster + AO, vtk-ssao its own render)", "",
                  points_markdown(m["points"]), "",
                  winners_text(m["winners_limited"], "limited"), "",
                  winners_text(m["winners_unlimited"], "unlimited")
                  + "\n  (the sweep's CSM rows included; their frame time is Scene.render's)", ""]
    return "\n".join(lines)


def _log_axes(points, hline=None) -> tuple:
    """Whether x and y of a panel can be log-scaled: a drawn point ((x, y), both finite; None is missing)
    has x > 0, and one has y > 0 or the horizontal line ``hline`` is > 0."""
    v = np.array([[np.nan if c is None else c for c in xy] for xy in points], float).reshape(-1, 2)
    v = v[np.isfinite(v).all(axis=1)]
    return bool((v[:, 0] > 0).any()), bool((v[:, 1] > 0).any() or (hline is not None and hline > 0))


def _place_labels(fig, ax, items):
    """Annotate points without overlapping labels: try a few offsets per label.

    ``items``: (text, x, y, style dict, required) in priority order; a label
    that is not required is left out when no offset is free.
    """
    renderer = fig.canvas.get_renderer()
    frame = ax.get_window_extent(renderer)
    placed = []
    offsets = [(6, 4), (6, -11), (-6, 4), (-6, -11), (6, 15), (6, -22), (-6, 15), (-6, -22),
               (6, 26), (6, -33)]
    for text, x, y, style, required in items:
        # required labels may move further away; the others stay next to their point
        for k, (dx, dy) in enumerate(offsets + [offsets[0]] if required else offsets[:4]):
            ann = ax.annotate(text, (x, y), textcoords="offset points", xytext=(dx, dy),
                              ha="left" if dx > 0 else "right", **style)
            bb = ann.get_window_extent(renderer)
            last = required and k == len(offsets)
            inside = (bb.x0 >= frame.x0 and bb.x1 <= frame.x1 and bb.y0 >= frame.y0
                      and bb.y1 <= frame.y1)
            if last or (inside and not any(bb.overlaps(o) for o in placed)):
                placed.append(bb)
                break
            ann.remove()


def pareto_plot(sw: dict, path: Path, max_error: float | None = None):
    """AO RMSE against frame time (log-log); the non-dominated configurations marked and labelled.

    Every Pareto configuration is labelled; dominated ones are labelled where
    there is room.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FormatStrFormatter, LogLocator

    rows = sw["rows"]
    # a missing figure (None: not finite) is NaN here, not drawn
    t = np.array([r["figures"]["frame_time"]["value"] for r in rows], float) * 1e3
    e = np.array([r["figures"]["ao_rmse_converged"]["value"] for r in rows], float)
    on = np.array([r["pareto"] for r in rows])
    methods = sw.get("methods")
    if methods:         # the methods on the same axes, and their distance-limited panel beside
        fig, (ax, ax_d) = plt.subplots(1, 2, figsize=(16, 6.5), dpi=110)
    else:
        fig, ax = plt.subplots(figsize=(10, 6.5), dpi=110)
    ax.scatter(t[~on], e[~on], c="0.6", s=28, label="dominated")
    order = np.argsort(t[on])
    ax.step(t[on][order], e[on][order], where="post", c="C3", lw=1, alpha=0.6)
    ax.scatter(t[on], e[on], c="C3", s=46, marker="D", label="Pareto front", zorder=3)
    if max_error is not None:
        ax.axhline(max_error, c="C0", ls="--", lw=1, label=f"RMSE = {max_error:g}")
    if methods:
        from .method_sweep import plot_points

        plot_points(ax, methods["points"], "rmse_unlimited")
        plot_points(ax_d, methods["points"], "rmse_limited")
        ax_d.set_xlabel("frame time (ms, G-buffer raster + AO; vtk-ssao: its render; median)")
        ax_d.set_ylabel(f"AO RMSE vs converged distance-limited Embree (D = {methods['distance']['value']:.3g})")
        ax_d.set_title("methods, distance-limited AO", fontsize=9)
        ax_d.legend(fontsize=7)
    drawn = {ax: list(zip(t, e))}        # each panel's points (a missing figure: NaN, not drawn)
    if methods:
        for a, key in ((ax, "rmse_unlimited"), (ax_d, "rmse_limited")):
            drawn[a] = drawn.get(a, []) + [(p["frame_time"], p[key]) for p in methods["points"]]
    for a in ([ax, ax_d] if methods else [ax]):
        # log axes, but linear along one with no positive value (every figure missing, or 0):
        # matplotlib cannot place log ticks there
        logs = _log_axes(drawn[a], max_error if a is ax else None)
        a.set_xscale("log" if logs[0] else "linear")
        a.set_yscale("log" if logs[1] else "linear")
        for axis in (x for x, lg in zip((a.xaxis, a.yaxis), logs) if lg):   # after set_*scale, which resets them
            axis.set_major_formatter(FormatStrFormatter("%g"))
            axis.set_minor_locator(LogLocator(subs=(2.0, 5.0)))
            axis.set_minor_formatter(FormatStrFormatter("%g"))
        a.tick_params(which="minor", labelsize=7)
        a.margins(x=0.12, y=0.08)
        a.grid(True, which="both", alpha=0.3)
    ax.set_xlabel("frame time (ms, Scene.render, median)" if not methods else
                  "frame time (ms, median; sweep rows: Scene.render; methods: G-buffer raster + AO)")
    ax.set_ylabel("AO RMSE vs converged Embree reference")
    ax.set_title(f"pyshadow speed/accuracy: {sw['scene']}\n"
                 f"{sw['image']['width']}x{sw['image']['height']}, {sw['environment']['device']}",
                 fontsize=9)
    ax.legend(fontsize=8 if not methods else 7, loc="upper right")
    fig.tight_layout()
    fig.canvas.draw()
    front = sorted(np.flatnonzero(on), key=lambda i: t[i])
    rest = sorted(np.flatnonzero(~on), key=lambda i: t[i])
    _place_labels(fig, ax, [(rows[i]["label"], t[i], e[i], {"fontsize": 7.5, "color": "C3"}, True)
                            for i in front]
                  + [(rows[i]["label"], t[i], e[i], {"fontsize": 6.5, "color": "0.45"}, False)
                     for i in rest])
    from pyshadow._files import atomic_path

    try:
        with atomic_path(path) as tmp:
            fig.savefig(tmp)
    finally:
        plt.close(fig)
