"""Where a sun disc lands on an environment map (``add_sun_disc``), near the poles and the horizon.

For lat-long maps of height H and cube maps of side H / 2, suns of the
default angular radius at 0, 1e-4 and 1e-3 rad and 0.5, 1 and 3 texel
pitches from the zenith, the nadir and a horizon direction (each tilted
towards azimuth 0.3 rad). For each: the map's irradiance (its order-3 SH,
``EnvironmentMap.irradiance``) on five planes (walls facing +x, -x, +z, -z
and the floor) against

- the exact disc (order-3 SH of a uniform cap, in closed form): what a
  user expects;
- the exact shares: 2,000,000 points of equal solid angle over the cap
  (a sunflower pattern), each into its texel -- the best a map of whole
  texels can hold, so its distance to the exact disc is a floor no
  placement can pass;

errors over ``E_n``, the disc's irradiance on a plane facing it (a plain
relative error divides by near zero on walls the sun grazes). Also the
direction ``extract_sun`` recovers from the map (in texel pitches), and
the energy (``integral`` against the disc's solid angle).

    python benchmarks/sun_disc.py [--heights 16,32,64,128,256,512] [--json]
"""
from __future__ import annotations

import argparse
import math

import numpy as np

from _common import emit, environment, parse_ints

NORMALS = np.array([[1.0, 0, 0], [-1, 0, 0], [0, 0, 1], [0, 0, -1], [0, 1, 0]])
GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0


def _frame(d):
    a = np.array([1.0, 0, 0]) if abs(d[0]) < 0.9 else np.array([0, 0, 1.0])
    e1 = np.cross(d, a)
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(d, e1)


def disc_irradiance(d, r):
    """Order-3 SH irradiance on NORMALS of a uniform cap (centre d, radius r, radiance 1): Funk-Hecke."""
    from pyshadow.lighting import disc_solid_angle
    from pyshadow.lighting.sh import _irradiance, sh_basis

    c, s2 = math.cos(r), math.sin(r) ** 2
    band = np.array([disc_solid_angle(r)] + [math.pi * s2] * 3 + [math.pi * c * s2] * 5)
    return _irradiance((sh_basis(d[None])[0] * band)[:, None] * np.ones(3), NORMALS)[:, 0]


def exact_shares(env, d, r, n=2_000_000):
    """The cap as n equal-solid-angle points, each into its texel (radiance 1 over the cap)."""
    from pyshadow.lighting import disc_solid_angle

    e1, e2 = _frame(d)
    j = np.arange(n)
    u = (j + 0.5) / n * (2.0 * math.sin(r / 2.0) ** 2)          # 1 - cos(rho), even: equal solid angle
    sr, ph = np.sqrt(u * (2.0 - u)), 2.0 * math.pi * np.mod(j * GOLDEN, 1.0)
    p = (1.0 - u)[:, None] * d + (sr * np.cos(ph))[:, None] * e1 + (sr * np.sin(ph))[:, None] * e2
    idx = env.texel_index(p / np.linalg.norm(p, axis=1, keepdims=True))
    cnt = np.bincount(idx, minlength=int(np.prod(env.grid_shape))).astype(np.float64)
    val = cnt * (disc_solid_angle(r) / n) / env.solid_angles().reshape(-1)
    return env.with_radiance(np.repeat(val[:, None], 3, axis=1).reshape(env.radiance.shape))


def run(heights):
    from pyshadow.lighting import SUN_ANGULAR_RADIUS as R
    from pyshadow.lighting import EnvironmentMap, add_sun_disc, disc_solid_angle, extract_sun

    bases = {"zenith": np.array([0, 1.0, 0]), "nadir": np.array([0, -1.0, 0]),
             "horizon": np.array([math.cos(0.7), 0, math.sin(0.7)])}
    en, rows = disc_solid_angle(R), []
    for h in heights:
        for layout, env0 in (("latlong", EnvironmentMap(np.zeros((h, 2 * h, 3)))),
                             ("cube", EnvironmentMap(np.zeros((6, h // 2, h // 2, 3))))):
            one, p = env0.with_radiance(np.ones(env0.radiance.shape)), env0.pitch
            for bname, base in bases.items():
                for aname, a in (("0", 0.0), ("1e-4", 1e-4), ("1e-3", 1e-3), ("0.5p", 0.5 * p), ("1p", p),
                                 ("3p", 3.0 * p)):
                    e1, e2 = _frame(base)
                    d = math.cos(a) * base + math.sin(a) * (math.cos(0.3) * e1 + math.sin(0.3) * e2)
                    d /= np.linalg.norm(d)
                    E = add_sun_disc(env0, d, np.ones(3))
                    irr = E.irradiance(NORMALS)[:, 0]
                    shares = exact_shares(env0, d, R).irradiance(NORMALS)[:, 0]
                    sun, _ = extract_sun(add_sun_disc(one, d, np.full(3, 4000.0)))
                    rows.append({"map": f"{layout} {h if layout == 'latlong' else h // 2}", "sun": bname,
                                 "angle": aname, "vs_disc": float(np.abs(irr - disc_irradiance(d, R)).max() / en),
                                 "vs_shares": float(np.abs(irr - shares).max() / en),
                                 "floor": float(np.abs(shares - disc_irradiance(d, R)).max() / en),
                                 "direction_pitches": math.acos(min(1.0, float(sun.direction @ d))) / p,
                                 "energy": abs(E.integral()[0] / en - 1.0)})
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--heights", default="16,32,64,128,256,512", help="lat-long heights (cubes: half)")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    rows = run(parse_ints(ap, args.heights, "--heights", least=2, even=True))
    if args.json:
        emit({"benchmark": "sun_disc", **environment(), "rows": rows}, True)
        return
    print("worst over the 18 suns of each map (errors over E_n; direction in texel pitches)")
    print("| map | vs exact disc | vs exact shares | floor (shares vs disc) | suns at a pole, vs shares | "
          "extract_sun direction | energy |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for m in dict.fromkeys(r["map"] for r in rows):
        rs = [r for r in rows if r["map"] == m]
        pole = [r["vs_shares"] for r in rs if r["sun"] != "horizon" and r["angle"] in ("1e-4", "1e-3")]
        print(f"| {m} | {max(r['vs_disc'] for r in rs):.3g} | {max(r['vs_shares'] for r in rs):.2g} | "
              f"{max(r['floor'] for r in rs):.3g} | {max(pole):.2g} | "
              f"{max(r['direction_pitches'] for r in rs):.3g} | {max(r['energy'] for r in rs):.1e} |")


if __name__ == "__main__":
    main()
