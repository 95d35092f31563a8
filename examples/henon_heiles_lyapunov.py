"""Hénon-Heiles at E = 1/6: a Poincaré section (q1 = 0, p1 > 0) of many orbits, each crossing coloured by its
orbit's maximal Lyapunov exponent, drawn by gnuplot (the project's plotting tool).

    /usr/bin/python3 examples/henon_heiles_lyapunov.py OUT.png [--orbits 200] [--t-end 1000] [--csv OUT.csv]

The orbits start on the section at seeded random (q2, p2) inside the energy's boundary, p1 > 0 from H = 1/6. One
recording ensemble (Scheme.integrate_ensemble with a rising event q1) gives every orbit's crossings, each a true
partial step of the method onto q1 = 0; Scheme.lyapunov gives each orbit's spectrum (Benettin's QR method on the
step's exact tangent maps). Prints how many orbits are chaotic (maximal exponent above a tenth of the largest) and
the two groups' median exponents. OUT.png and OUT.csv must not exist: nothing is overwritten.
"""
import argparse
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile

import numpy as np

import pgi

SCENE = pathlib.Path(__file__).resolve().parents[1] / "tools" / "scenes" / "henon_heiles.toml"
ENERGY, DT = 1 / 6, 0.1

PLOT = """set terminal pngcairo size 900,800 font "sans,11"
set output "section.png"
set datafile separator ","
set title "Hénon-Heiles, E = 1/6: section q1 = 0, p1 > 0, coloured by the orbit's maximal Lyapunov exponent"
set xlabel "q2"
set ylabel "p2"
set cblabel "maximal Lyapunov exponent"
set size ratio -1
set key off
set palette defined (0 "#1f4e99", 0.35 "#4dac26", 0.7 "#f0c040", 1 "#b2182b")
set cbrange [0:*]
plot "crossings.csv" every ::1 using 1:2:3 with points pt 7 ps 0.2 lc palette
"""


def starts(orbits, seed=1):
    """orbits states (0, q2, p1, p2) with H = 1/6 and p1 > 0, (q2, p2) uniform inside the section's boundary."""
    rng = np.random.default_rng(seed)
    out = []
    while len(out) < orbits:
        q2, p2 = rng.uniform(-0.5, 1.0), rng.uniform(-0.58, 0.58)
        p1_squared = 2 * (ENERGY - q2 ** 2 / 2 + q2 ** 3 / 3) - p2 ** 2
        if p1_squared > 1e-6:
            out.append([0.0, q2, np.sqrt(p1_squared), p2])
    return np.array(out)


def section(s, X0, t_end):
    """Every orbit's rising crossings of q1 = 0: (orbit, q2, p2) arrays, from one recording ensemble."""
    e = s.integrate_ensemble(X0, dt=DT, t_end=t_end, events=[("q1", 1, False)])
    if not e.ok.all():
        raise SystemExit(f"henon_heiles_lyapunov: {int((~e.ok).sum())} orbits did not reach t_end")
    return e.event_row, e.event_x[:, 1], e.event_x[:, 3]


def write_new(source, target):
    """source's bytes as target, which must not exist (a link: no other file is replaced, none half-written)."""
    partial = target.with_name(f".{target.name}.partial-{os.getpid()}")
    shutil.copyfile(source, partial)
    try:
        os.link(partial, target)
    finally:
        partial.unlink()


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("png", type=pathlib.Path, help="the figure to write (must not exist)")
    parser.add_argument("--orbits", type=int, default=200)
    parser.add_argument("--t-end", type=float, default=1000.0)
    parser.add_argument("--csv", type=pathlib.Path, help="also write the crossings: q2, p2, exponent, orbit")
    a = parser.parse_args(argv)
    if not 1 <= a.orbits <= 100_000 or not 0 < a.t_end <= 1e6:
        parser.error("--orbits must be in 1..100000 and --t-end in (0, 1e6]")
    if a.csv is not None and a.csv.resolve() == a.png.resolve():
        parser.error(f"{a.csv}: the figure and the crossings cannot be one file: nothing written")
    for target in (a.png, a.csv):
        if target is not None and (target.exists() or not target.parent.is_dir()):
            parser.error(f"{target}: exists already, or its directory does not: nothing written")
    s = pgi.Scheme.from_toml(SCENE)
    X0 = starts(a.orbits)
    orbit, q2, p2 = section(s, X0, a.t_end)
    exponent = np.array([s.lyapunov(x, dt=DT, t_end=a.t_end, every=10 ** 9).spectrum[0] for x in X0])
    chaotic = exponent > 0.1 * exponent.max()
    print(f"{a.orbits} orbits to t = {a.t_end:g}, {len(orbit)} crossings: {int(chaotic.sum())} chaotic "
          f"(median exponent {np.median(exponent[chaotic]):.3f}), {int((~chaotic).sum())} regular "
          f"(median {np.median(exponent[~chaotic]) if (~chaotic).any() else float('nan'):.4f})")
    with tempfile.TemporaryDirectory(prefix="pgi-lyapunov-") as tmp:
        tmp = pathlib.Path(tmp)
        order = np.argsort(exponent[orbit], kind="stable")  # the chaotic sea drawn over the islands
        rows = np.column_stack([q2, p2, exponent[orbit], orbit])[order]
        np.savetxt(tmp / "crossings.csv", rows, delimiter=",", header="q2,p2,exponent,orbit", comments="",
                   fmt=["%.17g", "%.17g", "%.17g", "%d"])
        (tmp / "plot.gp").write_text(PLOT)
        run = subprocess.run(["gnuplot", "plot.gp"], cwd=tmp, capture_output=True, text=True, timeout=300)
        if run.returncode != 0 or not (tmp / "section.png").is_file():
            raise SystemExit(f"henon_heiles_lyapunov: gnuplot failed: {run.stderr.strip()}")
        write_new(tmp / "section.png", a.png)
        if a.csv is not None:
            write_new(tmp / "crossings.csv", a.csv)
    return 0


if __name__ == "__main__":
    sys.exit(main())
