#!/usr/bin/env python3
"""Speed of pgi's exact phase against three sympy implementations of the same recursion, in one run.

Usage: python3 tools/bench/bench_exact.py [--build build] [--skip-expr-above SECONDS]
For each workload it times pgi (tools/bench/bench_exact.cpp, median of repeated runs), the sympy
sparse-ring version recomposing every order (the benchmark's reference since it was written), the sympy
sparse-ring version composing order by order (pgi's own algorithm, H o alpha first since d9d26d8: the like-for-like
ratio) and the sympy expression version (tools/bench/hj_sympy.py, median of repeated runs, one run if it
takes longer than a few seconds), checks that all give the same polynomials, and prints the times and the
ratios sympy / pgi."""
import argparse
import json
import multiprocessing
import queue as queue_module
import os
import statistics
import subprocess
import sys
import time

import sympy as sp

sys.path.insert(0, os.path.dirname(__file__))
from hj_sympy import ExprImpl, RingByOrderImpl, RingImpl  # noqa: E402

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
SCENES = os.path.join(ROOT, "tools", "scenes")

RIGID = (["x1", "x2", "x3"], {(0, 1): "-x3", (1, 2): "-x1", (2, 0): "-x2"}, "1/4*x1**2 + 1/2*x2**2 + 3/4*x3**2")
NAMBU = (["x1", "x2", "x3"], {(0, 1): "x3**2", (1, 2): "x1**2", (2, 0): "x2**2"}, "(x1**2 + x2**2 + x3**2)/2")
PLANE = (["x", "y"], {(0, 1): "x**2 + y**2"}, "x**2/2 + y**2")

# name, scene file, pgi workload, n, sympy system, sympy realisation
WORKLOADS = [
    ("rigid body S_1..S_7 (Lie-Poisson)", "rigid_body", "terms", 7, RIGID, "lie_poisson"),
    ("Nambu radial realisation, degree 6", "nambu", "radial", 6, NAMBU, "radial"),
    ("Nambu S_1..S_6 (radial)", "nambu", "terms", 6, NAMBU, "radial"),
    ("(x^2+y^2) dx^dy radial realisation, degree 8", "plane_quadratic", "radial", 8, PLANE, "radial"),
]


def sympy_run(cls, system, realisation, kind, n):
    coords, brackets, H = system
    impl = cls(coords, brackets)
    if kind == "radial":
        return [sum(c) for c in impl.radial(n)]
    alpha = getattr(impl, realisation)(n - 1)
    return impl.hamilton_jacobi(alpha, H, n)


def timed(fn, budget):
    times, result = [], None
    start = time.perf_counter()
    while not times or (len(times) < 5 and time.perf_counter() - start < budget):
        t0 = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), result


def _child(fn, queue):
    queue.put(timed(fn, 5.0))


def timed_with_limit(fn, limit):
    """timed(fn) in a child process; (limit, None) if it has not finished after limit seconds."""
    queue = multiprocessing.Queue()
    proc = multiprocessing.Process(target=_child, args=(fn, queue))
    proc.start()
    try:
        return queue.get(timeout=limit)
    except queue_module.Empty:
        proc.kill()
        return limit, None
    finally:
        proc.join()


def same(polys_a, polys_b):
    return all(sp.expand(sp.sympify(str(a).replace("^", "**")) - sp.sympify(str(b).replace("^", "**"))) == 0
               for a, b in zip(polys_a, polys_b)) and len(polys_a) == len(polys_b)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--json", help="also write the results to this file")
    ap.add_argument("--expr-limit", type=float, default=120.0,
                    help="seconds after which the sympy expression version is stopped (its ratio is then a lower bound)")
    args = ap.parse_args()
    rows = []
    for name, scene, kind, n, system, realisation in WORKLOADS:
        out = subprocess.run([os.path.join(args.build, "pgi_bench_exact"), os.path.join(SCENES, scene + ".toml"), kind, str(n)],
                             check=True, capture_output=True, text=True).stdout
        pgi = json.loads(out)
        t_ring, r_ring = timed(lambda: sympy_run(RingImpl, system, realisation, kind, n), 5.0)
        t_order, r_order = timed(lambda: sympy_run(RingByOrderImpl, system, realisation, kind, n), 5.0)
        t_expr, r_expr = timed_with_limit(lambda: sympy_run(ExprImpl, system, realisation, kind, n), args.expr_limit)
        agree = same(pgi["result"], r_ring) and same(pgi["result"], r_order) and (r_expr is None or same(pgi["result"], r_expr))
        bound = ">" if r_expr is None else " "
        rows.append({"workload": name, "pgi_allocator": pgi["allocator"], "pgi_s": pgi["seconds"], "sympy_ring_s": t_ring, "sympy_ring_by_order_s": t_order,
                     "sympy_expr_s": t_expr, "sympy_expr_finished": r_expr is not None, "ring_over_pgi": t_ring / pgi["seconds"],
                     "ring_by_order_over_pgi": t_order / pgi["seconds"], "expr_over_pgi": t_expr / pgi["seconds"], "agree": agree})
        r = rows[-1]
        if len(rows) == 1:
            print(f"pgi_bench_exact allocates with {pgi['allocator']}", flush=True)
        print(f"{name:46s} pgi {r['pgi_s'] * 1e3:9.3f} ms | sympy ring {t_ring * 1e3:10.1f} ms ({r['ring_over_pgi']:7.0f}x)"
              f" | ring by order {t_order * 1e3:10.1f} ms ({r['ring_by_order_over_pgi']:7.0f}x)"
              f" | sympy expr {bound}{t_expr * 1e3:10.1f} ms ({bound}{r['expr_over_pgi']:8.0f}x) | results agree: {agree}", flush=True)
    if args.json:
        with open(args.json + ".tmp", "w") as f:
            json.dump(rows, f, indent=2)
        os.replace(args.json + ".tmp", args.json)
    return 0 if all(r["agree"] for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
