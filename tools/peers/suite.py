#!/usr/bin/env python3
"""The stiff and extreme suite (issue 5): every method once per case, with its outcome, as a Markdown table.
Each case is a bundled scene with overrides; adaptive peers run at tolerance 1e-6 unless the case says.
Usage: python3 tools/peers/suite.py [--build build] [--json FILE] [--md FILE]
Cells: max relative energy error / max relative Casimir error over the run (or the watched quantity's
final/initial ratio where the case watches one), or FAILED with the reason."""
import argparse
import json
import os
import subprocess
import sys

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
RB_X0 = [0.4535961214255773, 0.0, 0.8912073600614354]


def scaled(x, s):
    return ",".join(repr(v * s) for v in x)


CASES = [
    ("stiff pair, omega dt = 10 (stiff-mode energy, final/initial)", "stiff_oscillators",
     ["--watch", "(p1^2 + 1000000*q1^2)/2"]),
    ("LV near the singular set, x1(0) = 1e-6", "lotka_volterra", ["--x0", "1e-6,2,0.5", "--t-end", "100"]),
    ("rigid body, x0 scaled by 1e6, dt = 1e-7", "rigid_body", ["--x0", scaled(RB_X0, 1e6), "--dt", "1e-7", "--t-end", "1e-4"]),
    ("rigid body, x0 scaled by 1e-6, dt = 1e5", "rigid_body", ["--x0", scaled(RB_X0, 1e-6), "--dt", "1e5", "--t-end", "1e8"]),
    ("rigid body, dt = 1e-6 (1e5 steps)", "rigid_body", ["--dt", "1e-6", "--t-end", "0.1"]),
    ("rigid body, k = 8, dt = 0.2", "rigid_body", ["--order", "8", "--dt", "0.2", "--t-end", "100"]),
    ("LV, k = 8, dt = 0.1", "lotka_volterra", ["--order", "8", "--dt", "0.1", "--t-end", "100"]),
]


def cell(row, watched):
    if not row["ok"]:
        return "FAILED: " + row["failure"]
    if watched:
        return f"x{row['watched_final_over_initial'][0]:.4f}"
    return f"{row['energy_error_max']:.1e} / {row['casimir_error_max']:.1e}"


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--json", help="also write every outcome to this file")
    ap.add_argument("--md", help="also write the table to this file")
    args = ap.parse_args()
    results = []
    for label, scene, extra in CASES:
        out = subprocess.run([os.path.join(args.build, "pgi_peers"), os.path.join(ROOT, "tools", "scenes", scene + ".toml"),
                              "--suite"] + extra, check=True, capture_output=True, text=True).stdout
        results.append({"case": label, "scene": scene, "arguments": extra, **json.loads(out)})
        print(f"done: {label}", file=sys.stderr, flush=True)
    methods = [r["method"] for r in results[0]["suite"]["rows"]]
    methods = ["pgi"] + [m for m in methods if not m.startswith("pgi-")]
    lines = ["| method | " + " | ".join(r["case"] for r in results) + " |", "|---" * (len(results) + 1) + "|"]
    for m in methods:
        cells = []
        for r in results:
            row = next(x for x in r["suite"]["rows"] if x["method"] == m or (m == "pgi" and x["method"].startswith("pgi-")))
            cells.append(cell(row, bool(r["watched"])) + f" ({row['seconds']:.2g} s)")
        lines.append(f"| {m} | " + " | ".join(cells) + " |")
    table = "\n".join(lines) + "\n"
    print(table)
    for path, text in ((args.json, json.dumps(results, indent=2)), (args.md, table)):
        if path:
            with open(path + ".tmp", "w") as f:
                f.write(text)
            os.replace(path + ".tmp", path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
