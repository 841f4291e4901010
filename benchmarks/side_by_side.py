"""Time one benchmark command on two source trees side by side, in alternating rounds.

Machine noise on a shared 2-core machine moves every timing by 10-30 %;
running the old and the new tree in alternation, round after round, lets that
noise fall on both alike, so the ratio of their medians is what the change
did. Each tree runs with ``PYTHONPATH`` set to it, from its own root (so its
own ``benchmarks/`` scripts and ``kernels/`` are used); the command must
print one JSON object on stdout (``--json`` of the benchmark scripts and of
``pyshadow-bench``). A first untimed round warms caches and kernel builds.

    python benchmarks/side_by_side.py --old ../base --new . --rounds 5 \\
        --key visible_s --key ambient_occlusion_s -- python benchmarks/visibility.py --json

A tree that is not an installed checkout needs ``pyshadow/kernels`` to point
at its ``kernels/`` (``ln -s ../kernels pyshadow/kernels``).
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path


class CommandError(Exception):
    """The command failed, printed no JSON object, or lacks a --key: the message says which (exit status 1)."""


def _get(obj, key: str):
    try:
        for part in key.split("."):
            obj = obj[part]
        return float(obj)
    except (KeyError, IndexError, TypeError, ValueError):
        raise CommandError(f"--key {key}: no number under that key in the command's JSON output") from None


def run(tree: Path, cmd: list[str]) -> dict:
    env = dict(os.environ, PYTHONPATH=str(tree.resolve()))
    try:
        out = subprocess.run(cmd, cwd=tree, env=env, capture_output=True, text=True)
    except OSError as e:
        raise CommandError(f"{' '.join(cmd)} in {tree}: cannot run it ({e.strerror or e})") from None
    if out.returncode:
        raise CommandError(f"{' '.join(cmd)} in {tree} failed ({out.returncode}):\n{out.stderr[-2000:]}")
    try:
        return json.loads(out.stdout[out.stdout.index("{"):])
    except ValueError:
        raise CommandError(f"{' '.join(cmd)} in {tree} printed no JSON object on stdout (give the benchmark "
                           "--json)") from None


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--old", type=Path, required=True, help="the old source tree")
    ap.add_argument("--new", type=Path, required=True, help="the new source tree")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--key", action="append", required=True,
                    help="a timing in the JSON output (dots for nesting, e.g. figures.frame_ms.value)")
    ap.add_argument("--json", action="store_true")
    ap.add_argument("cmd", nargs=argparse.REMAINDER, help="-- the command")
    args = ap.parse_args(argv)
    cmd = args.cmd[1:] if args.cmd[:1] == ["--"] else args.cmd
    if not cmd:
        ap.error("give the command after --")
    if args.rounds < 1:
        ap.error(f"--rounds must be >= 1, got {args.rounds}")
    for option, tree in (("--old", args.old), ("--new", args.new)):
        if not tree.is_dir():
            ap.error(f"{option}: no folder {str(tree)!r}")
    try:
        return _measure(args, cmd)
    except CommandError as e:
        print(f"side_by_side.py: {e}", file=sys.stderr)
        return 1


def _measure(args, cmd) -> int:
    """The alternating rounds and their report (stdout)."""
    cmd = [sys.executable if c == "python" else c for c in cmd]
    trees = {"old": args.old, "new": args.new}
    for tree in trees.values():              # warm-up: builds, caches
        run(tree, cmd)
    times = {name: {k: [] for k in args.key} for name in trees}
    for r in range(args.rounds):
        order = ("old", "new") if r % 2 == 0 else ("new", "old")
        for name in order:
            res = run(trees[name], cmd)
            for k in args.key:
                times[name][k].append(_get(res, k))
    summary = {}
    for k in args.key:
        old, new = statistics.median(times["old"][k]), statistics.median(times["new"][k])
        summary[k] = {"old_median": old, "new_median": new, "new_over_old": new / old,
                      "old": times["old"][k], "new": times["new"][k]}
    if args.json:
        print(json.dumps({"command": cmd, "rounds": args.rounds, "keys": summary}, indent=2))
        return 0
    print(f"{' '.join(cmd)}: {args.rounds} alternating rounds")
    for k, s in summary.items():
        print(f"  {k:40s} old {s['old_median']:.4g}  new {s['new_median']:.4g}  new/old {s['new_over_old']:.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
