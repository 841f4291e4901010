"""How much of a low sun ``extract_sun`` finds on a clear sky (``clear_sky`` with its disc).

For suns 0.5 to 30 degrees above the horizon on lat-long maps of height H:
the extracted sun's luminance over ``sun_irradiance``'s (the disc drawn),
its direction's error in texel pitches, and that luminance error as a
fraction of the sky's whole horizontal illuminance (what a floor sees).

    python benchmarks/sun_horizon.py [--heights 64,128,256] [--json]
"""
from __future__ import annotations

import argparse
import math

import numpy as np

from _common import emit, environment, parse_ints

ELEVATIONS = (30.0, 10.0, 5.0, 3.0, 2.0, 1.0, 0.5)


def run(heights):
    from pyshadow.lighting import clear_sky, extract_sun, sun_irradiance
    from pyshadow.lighting.sky import LUMINANCE_WEIGHTS as W

    rows = []
    for el in ELEVATIONS:
        e = math.radians(el)
        d = np.array([math.cos(e), math.sin(e), 0.0])
        want = W @ sun_irradiance(d, 3.0)
        for h in heights:
            env = clear_sky(d, 3.0, height=h)
            sun, _ = extract_sun(env)
            got = W @ sun.irradiance
            floor = env.irradiance(np.array([[0.0, 1.0, 0.0]]))[0] @ W
            rows.append({"elevation_deg": el, "height": h, "luminance_ratio": float(got / want),
                         "direction_pitches": math.acos(min(1.0, float(sun.direction @ d))) / env.pitch,
                         "of_floor": float(abs(got - want) * d[1] / floor)})
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--heights", default="64,128,256", help="lat-long heights")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    rows = run(parse_ints(ap, args.heights, "--heights", least=2))
    if args.json:
        emit({"benchmark": "sun_horizon", **environment(), "rows": rows}, True)
        return
    print("| elevation | height | extracted / drawn luminance | direction (pitches) | error / floor's |")
    print("| --- | --- | --- | --- | --- |")
    for r in rows:
        print(f"| {r['elevation_deg']:g} deg | {r['height']} | {r['luminance_ratio']:.4f} | "
              f"{r['direction_pitches']:.2f} | {r['of_floor']:.1e} |")


if __name__ == "__main__":
    main()
