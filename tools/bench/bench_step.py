#!/usr/bin/env python3
"""Speed of the compiled step (tools/bench/bench_step.cpp) on the rigid body, the cyclic Lotka-Volterra
system and the Volterra lattice (n = 6) at their default dt, k = 1..6, as a table.
Usage: python3 tools/bench/bench_step.py [--build build] [--steps 20000] [--json FILE]"""
import argparse
import json
import os
import subprocess
import sys

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--steps", default="20000")
    ap.add_argument("--json", help="also write the rows to this file")
    args = ap.parse_args()
    rows = []
    print(f"{'scene':26s} {'k':>2s} {'m.ord':>5s} {'D':>3s} {'ns/step':>9s} {'Newton it':>9s} {'F+J ns':>8s}"
          f" {'step/(F+J)':>10s} {'step/field':>10s}")
    for scene in ("rigid_body", "lotka_volterra", "volterra_chain"):
        out = subprocess.run([os.path.join(args.build, "pgi_bench_step"), os.path.join(ROOT, "tools", "scenes", scene + ".toml"),
                              "6", args.steps], check=True, capture_output=True, text=True).stdout
        for line in out.splitlines():
            r = json.loads(line)
            rows.append(r)
            print(f"{r['scene'][:26]:26s} {r['k']:2d} {r['method_order']:5d} {r['degree']:3d} {r['ns_per_step']:9.0f}"
                  f" {r['newton_iterations_mean']:9.2f} {r['newton_system_ns']:8.0f} {r['step_over_newton_system']:10.2f}"
                  f" {r['step_over_vector_field']:10.0f}", flush=True)
    if args.json:
        with open(args.json + ".tmp", "w") as f:
            json.dump(rows, f, indent=2)
        os.replace(args.json + ".tmp", args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
