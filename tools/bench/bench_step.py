#!/usr/bin/env python3
"""Speed of the compiled step (tools/bench/bench_step.cpp) on the rigid body, the cyclic Lotka-Volterra
system and the Volterra lattice (n = 6) at their default dt, k = 1..6, as a table; then, at the orders and steps
where the work-precision benchmark (bench_speed.py) finds pgi's best times to 1e-10, the two cheaper starts of
Newton that issue 13 asks to measure against the Taylor predictor: extrapolation from the last base points, and
the Jacobian kept across steps (simplified Newton from one step to the next).
Usage: python3 tools/bench/bench_step.py [--build build] [--steps 20000] [--json FILE]"""
import argparse
import json
import os
import subprocess
import sys

# (scene, k, dt): about where bench_speed.py's best pgi order reaches 1e-10 at T = 100
OPERATING_POINTS = (("rigid_body", 12, 0.43), ("lotka_volterra", 12, 0.12), ("henon_heiles", 16, 0.3))
U = 2.0 ** -53


def newton_iterations(e):
    """Full Newton corrections from a start of relative error e until it is below 64 u (each squares it)."""
    it = 0
    while e > 64 * U and it < 8:
        e, it = e * e, it + 1
    return it

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
    print()
    print("Cheaper starts of Newton at the work-precision operating points (interpreted; errors relative to |x|,")
    print("maxima over 2000 steps; 'full it.' = iterations a start of that error needs, 'kept-J it.' = residual")
    print("evaluations simplified Newton with the last step's Jacobian needs from the Taylor predictor's error):")
    print(f"{'scene':24s} {'k':>2s} {'dt':>5s} {'P':>2s} {'Taylor err':>10s} {'extrap err':>10s} {'pts':>3s} {'full it.':>8s}"
          f" {'J drift':>7s} {'kept-J it.':>10s} {'F+J ns':>7s} {'resid ns':>8s} {'step ns':>7s}")
    for scene, k, dt in OPERATING_POINTS:
        out = subprocess.run([os.path.join(args.build, "pgi_bench_step"), os.path.join(ROOT, "tools", "scenes", scene + ".toml"),
                              f"{k}:{k}", args.steps, "--dt", repr(dt)], check=True, capture_output=True, text=True).stdout
        r = json.loads(out.splitlines()[-1])
        r["operating_point"] = True
        r["extrapolation_newton_iterations"] = newton_iterations(r["extrapolation_error"])
        rows.append(r)
        print(f"{r['scene'][:24]:24s} {k:2d} {dt:5.2f} {r['predictor_order']:2d} {r['predictor_error']:10.1e}"
              f" {r['extrapolation_error']:10.1e} {r['extrapolation_points']:3d} {r['extrapolation_newton_iterations']:8d}"
              f" {r['jacobian_drift']:7.3f} {r['kept_jacobian_iterations']:10.0f} {r['newton_system_ns']:7.0f}"
              f" {r['residual_ns']:8.0f} {r['ns_per_step']:7.0f}", flush=True)
    if args.json:
        with open(args.json + ".tmp", "w") as f:
            json.dump(rows, f, indent=2)
        os.replace(args.json + ".tmp", args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
