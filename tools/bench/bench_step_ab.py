#!/usr/bin/env python3
"""The step's cost in two builds, side by side: pgi_bench_step of BASE and of HEAD at each scene's own k and dt,
interleaved (the order alternating round by round) so that both see the same machine, the best of --rounds kept.
What issue 32's "the step's cost does not grow by more than 10%" is measured with: build the earlier tree in a
worktree, then
    /usr/bin/python3 tools/bench/bench_step_ab.py --base ../old/build --head build
Usage: bench_step_ab.py --base BUILD --head BUILD [--rounds 7] [--steps 40000] [--scenes rigid_body,...]"""
import argparse
import json
import os
import re
import subprocess

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
SCENES = "rigid_body,lotka_volterra,volterra_chain,henon_heiles,nambu"


def scene_order(path):
    """The scene's [integrator] order (k), 2 when it names none."""
    m = re.search(r"^order\s*=\s*(\d+)", open(path).read(), re.M)
    return int(m.group(1)) if m else 2


def ns_per_step(build, scene, k, steps):
    out = subprocess.run([os.path.join(build, "pgi_bench_step"), scene, f"{k}:{k}", str(steps)],
                         check=True, capture_output=True, text=True).stdout
    return json.loads(out.splitlines()[-1])["ns_per_step"]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--base", required=True)
    ap.add_argument("--head", required=True)
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--steps", type=int, default=40000)
    ap.add_argument("--scenes", default=SCENES)
    args = ap.parse_args()
    builds = {"base": args.base, "head": args.head}
    best = {}
    for r in range(args.rounds):
        for name in args.scenes.split(","):
            path = os.path.join(ROOT, "tools", "scenes", name + ".toml")
            for which in (("base", "head") if r % 2 == 0 else ("head", "base")):
                t = ns_per_step(builds[which], path, scene_order(path), args.steps)
                best[name, which] = min(best.get((name, which), float("inf")), t)
    print(f"{'scene':22s} {'k':>2s} {'base ns':>8s} {'head ns':>8s} {'head/base':>9s}")
    for name in args.scenes.split(","):
        k = scene_order(os.path.join(ROOT, "tools", "scenes", name + ".toml"))
        b, h = best[name, "base"], best[name, "head"]
        print(f"{name:22s} {k:2d} {b:8.0f} {h:8.0f} {h / b:9.3f}")


if __name__ == "__main__":
    main()
