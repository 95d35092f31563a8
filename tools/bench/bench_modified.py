#!/usr/bin/env python3
"""Speed of pgi's modified Hamiltonians (Htilde through dt^6) against the same computation on sympy's
sparse polynomial rings (tools/bench/hj_sympy.py, RingImpl.modified), in one run, results checked equal.
Workloads: the rigid body with k = 1..4, the Volterra lattice (n = 6) with k = 2.
Usage: python3 tools/bench/bench_modified.py [--build build] [--upto 6]"""
import argparse
import json
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(__file__))
from bench_exact import ROOT, SCENES, same, timed  # noqa: E402
from hj_sympy import RingImpl  # noqa: E402

RIGID = (["x1", "x2", "x3"], {(0, 1): "-x3", (1, 2): "-x1", (2, 0): "-x2"}, "1/4*x1**2 + 1/2*x2**2 + 3/4*x3**2", "lie_poisson")
CHAIN = ([f"x{i}" for i in range(1, 7)], {(i, (i + 1) % 6): f"x{i + 1}*x{(i + 1) % 6 + 1}" for i in range(6)},
         "x1 + x2 + x3 + x4 + x5 + x6", "log_canonical")


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--upto", type=int, default=6)
    args = ap.parse_args()
    m = args.upto
    ok = True
    for scene, system, ks in (("rigid_body", RIGID, (1, 2, 3, 4)), ("volterra_chain", CHAIN, (2,))):
        coords, brackets, H, realisation = system
        for k in ks:
            out = subprocess.run([os.path.join(args.build, "pgi_bench_exact"), os.path.join(SCENES, scene + ".toml"), "modified",
                                  str(m), str(k)], check=True, capture_output=True, text=True).stdout
            pgi = json.loads(out)

            def sympy_modified():
                impl = RingImpl(coords, brackets)
                return impl.modified(getattr(impl, realisation)(max(m, k - 1)), H, k, m)

            t_ring, r_ring = timed(sympy_modified, 5.0)
            agree = same(pgi["result"], r_ring)
            ok = ok and agree
            print(f"{scene:15s} k={k} Htilde through dt^{m}: pgi {pgi['seconds'] * 1e3:9.2f} ms | sympy ring {t_ring * 1e3:10.1f} ms"
                  f" ({t_ring / pgi['seconds']:6.0f}x) | results agree: {agree}", flush=True)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
