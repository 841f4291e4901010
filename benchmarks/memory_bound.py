"""How many random table reads a second this device can serve: the bound a CSM lookup is against (issue 25).

A one-texel CSM lookup reads three table entries that depend on one another
(the texel's list offsets, then the list's block summary, then the block:
``kernels/csm_stored.h``). The offsets and summaries are small (the bunny's
64x128 maps at 128^2: 0.13 and 0.6 MiB) and stay in the caches; the blocks
(19.2 MiB there) do not, and a query's block lies at a place no earlier
query predicts. The lookup's speed is therefore bounded by how many random
reads of a table that size the device serves a second, however the
arithmetic is arranged. This script measures that rate with the device's own OpenCL
compiler: every work-item follows ``--chains`` independent chains of
dependent reads (each read gives the index of the chain's next cache line,
a random cycle through a table of ``--mbytes``), so that a chain's reads
wait for one another while the chains of all work-items overlap. One chain
a work-item gives the latency of a read; more chains show how many reads the
cores keep in flight, and the rate they reach.

The answer to "how fast can a lookup be here": at most the highest rate
measured at its blocks' size (one block a lookup), with no arithmetic at
all; benchmarks/README.md compares it with the measured lookups
(``benchmarks/peers.py``) and with 10x embreex.

With ``--lookup`` it also times the one-texel lookup on the rays of
``benchmarks/peers.py``'s bunny workload with CSMs of the bunny whose tables
shrink until they sit in a core's L2 cache: the rate there is what the
lookup's own work allows, whatever the memory.

    python benchmarks/memory_bound.py [--mbytes 1,4,20,128] [--chains 1,16,32,64] [--rounds 5] [--lookup] [--json]
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time

import numpy as np

from _common import emit, environment, parse_ints

SOURCE = r"""
/* CHAINS dependent read chains a work-item: next[16 i] is the cache line after line i on a random cycle */
__kernel void chase(__global const uint *next, __global uint *out, const uint steps, const uint lines,
                    const uint stride)
{
    const uint g = get_global_id(0);
    uint p[CHAINS];
    for (int c = 0; c < CHAINS; ++c)
        p[c] = (uint)(((ulong)(g * CHAINS + c) * stride) % lines);
    for (uint s = 0; s < steps; ++s)
        for (int c = 0; c < CHAINS; ++c)
            p[c] = next[16 * p[c]];
    uint acc = 0;
    for (int c = 0; c < CHAINS; ++c)
        acc += p[c];
    out[g] = acc;
}
"""


def cycle_table(lines: int, seed: int = 0) -> np.ndarray:
    """One uint32 per 4 bytes of ``lines`` cache lines of 64 bytes; line i's first word holds the line after
    it on one random cycle through all of them (so no chain ends early, whatever its start)."""
    order = np.random.default_rng(seed).permutation(lines).astype(np.uint32)
    table = np.zeros((lines, 16), np.uint32)
    table[order, 0] = np.roll(order, -1)
    return table.reshape(-1)


def chase(table, chains: int, items: int, steps: int, rounds: int = 1):
    """Run the chase kernel: ``items`` work-items of ``chains`` chains, ``steps`` reads each.

    ``table``: :func:`cycle_table`'s array, or a device buffer of it (so that one upload serves every
    chain count).

    Returns ``(out, seconds)``: each work-item's sum of its chains' last lines (uint32; wraps), and the
    median time of ``rounds`` timed launches after one untimed one (compile, page in the table).
    """
    import pyopencl as cl

    from pyshadow import _cl

    ctx, queue = _cl.context(), _cl.queue()
    buf = table if isinstance(table, cl.Buffer) else _cl.to_device(table)
    lines = buf.size // 64
    knl = cl.Kernel(_cl.build_source(SOURCE, "memory_bound", {"CHAINS": chains}), "chase")
    out = cl.Buffer(ctx, cl.mem_flags.WRITE_ONLY, 4 * items)
    knl.set_args(buf, out, np.uint32(steps), np.uint32(lines), np.uint32(starts_stride(lines, items * chains)))
    cl.enqueue_nd_range_kernel(queue, knl, (items,), (1,)).wait()
    times = []
    for _ in range(rounds):
        t0 = time.perf_counter()
        cl.enqueue_nd_range_kernel(queue, knl, (items,), (1,)).wait()
        times.append(time.perf_counter() - t0)
    res = np.empty(items, np.uint32)
    cl.enqueue_copy(queue, res, out).wait()
    return res, statistics.median(times)


def starts_stride(lines: int, chains: int) -> int:
    """The chains' first lines lie this far apart (chain i starts at line i * stride mod lines)."""
    return max(1, lines // chains)


def measure(mbytes: int, chains: list, rounds: int, reads: int) -> list:
    from pyshadow import _cl

    lines = max(1024, mbytes * (1 << 20) // 64)
    table = _cl.to_device(cycle_table(lines))                 # uploaded once for every chain count
    cores = int(_cl.device().max_compute_units)
    rows = []
    for c in chains:
        items = 8 * cores                               # work-items: each core takes several, one at a time
        steps = max(16, reads // (items * c))
        _, t = chase(table, c, items, steps, rounds)
        n = items * c * steps
        rows.append({"mbytes": mbytes, "chains": c, "reads": n, "seconds": t, "m_reads_per_s": n / t / 1e6,
                     # every core follows `c` chains at a time: a read of one chain waits this long
                     "ns_per_read_per_chain": t / (n / (cores * c)) * 1e9})
    return rows


#: CSMs of the bunny for --lookup: (maps, resolution), from the peers workload's own (tables of 20 MiB) down to
#: tables that sit in a core's L2 cache
LOOKUP_CSMS = (((64, 128), 128), ((16, 32), 128), ((16, 32), 32))


def lookup_rates(rays: int, rounds: int) -> list:
    """The one-texel lookup (``Scene.visible``) on the peers bunny workload's rays, with CSMs of the bunny whose
    tables shrink from 20 MiB to cache-resident: what the lookup costs beyond its table reads."""
    import pyshadow
    from pyshadow.cache import CSMCache, default_cache_dir
    from pyshadow.csm.device import search_arrays

    from _common import load_mesh
    from peers import bunny_workload

    cache = CSMCache(default_cache_dir())
    _, P, D, ids = bunny_workload(rays, cache)
    mesh = load_mesh("stanford-bunny.obj")
    rows = []
    for maps, res in LOOKUP_CSMS:
        views = pyshadow.ViewSet.zigzag(*maps)
        scene = pyshadow.Scene(ground=float(mesh.bounds[0, 1]), views=views, resolution=res)
        csm, _ = cache.csm("bunny", mesh, views, res, 16)
        scene.add(csm, mesh=mesh)
        arrays = search_arrays(csm, padded=True)
        scene.visible(P[:1024], D[:1024], surface_ids=ids[:1024])           # compile outside the timing
        times = []
        for _ in range(rounds):
            t0 = time.perf_counter()
            scene.visible(P, D, surface_ids=ids)
            times.append(time.perf_counter() - t0)
        t = statistics.median(times)
        rows.append({"maps": list(maps), "resolution": res, "queries": len(P), "seconds": t,
                     "m_queries_per_s": len(P) / t / 1e6,
                     "table_mib": {k: arrays[k].nbytes / 2 ** 20 for k in ("offsets", "soff", "summary", "pairs")}})
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--mbytes", default="1,4,20,128", help="table sizes in MiB (comma-separated; default %(default)s)")
    ap.add_argument("--chains", default="1,16,32,64", help="chains a work-item (default %(default)s)")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--reads", type=int, default=8_000_000, help="reads a timed launch (default %(default)s)")
    ap.add_argument("--lookup", action="store_true",
                    help="also time the one-texel lookup on the peers bunny rays with CSMs of shrinking tables")
    ap.add_argument("--rays", type=int, default=3_600_000, help="--lookup's queries (default %(default)s)")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    sizes = parse_ints(ap, args.mbytes, "--mbytes")
    chains = parse_ints(ap, args.chains, "--chains")
    if args.rounds < 1 or args.reads < 1 or args.rays < 1:
        ap.error(f"--rounds, --reads and --rays must be >= 1, got {args.rounds}, {args.reads} and {args.rays}")
    if max(chains) > 256:
        ap.error(f"--chains: at most 256 a work-item, got {max(chains)}")
    rows = [r for m in sizes for r in measure(m, chains, args.rounds, args.reads)]
    best = {m: max(r["m_reads_per_s"] for r in rows if r["mbytes"] == m) for m in sizes}
    result = {"benchmark": "memory_bound", **environment(), "rows": rows, "best_m_reads_per_s": best}
    if args.lookup:
        result["lookup"] = lookup_rates(args.rays, args.rounds)
    if args.json:
        emit(result, True)
        return 0
    print(f"{'MiB':>5} {'chains':>6} {'M reads/s':>10} {'ns a read (latency)':>20}")
    for r in rows:
        print(f"{r['mbytes']:>5} {r['chains']:>6} {r['m_reads_per_s']:>10.1f} {r['ns_per_read_per_chain']:>20.1f}")
    for m, b in best.items():
        print(f"{m} MiB: at most {b:.0f} M random reads/s (the most lookups a second whose block is a miss)")
    for r in result.get("lookup", []):
        mib = sum(r["table_mib"].values())
        print(f"one-texel lookup, bunny {r['maps'][0]}x{r['maps'][1]} @ {r['resolution']}^2 (tables {mib:.2f} MiB, "
              f"blocks {r['table_mib']['pairs']:.2f}): {r['m_queries_per_s']:.1f} M queries/s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
