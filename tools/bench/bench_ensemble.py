#!/usr/bin/env python3
"""Throughput of ensembles on the rigid body, k = 4 (or --order K): m trajectories x 1000 steps of dt = 0.01, integrated by
Scheme.integrate_ensemble with 1 thread one trajectory at a time (batch=1), with 1 and 2 threads in batches
(the default, 16 trajectories stepped together), and by pgi.dask.integrate_ensemble on a LocalCluster of 1
and 2 worker processes (one thread each; each cluster warmed by a first run, so the exact phase is not timed).
Prints the times and the ratios of one run; checks that the four runs give the same numbers bit for bit.
Usage: /usr/bin/python3 tools/bench/bench_ensemble.py [--build build] [--m 2000] [--steps 1000] [--order K] [--json FILE]
(the issue's targets: batches >= 2x one trajectory at a time, per core; 2 threads >= 1.8x one thread; Dask 2 workers >= 1.6x one worker on a job of 30 s or
more: give --m 20000 for that)."""
import argparse
import json
import os
import resource
import sys
import time

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))


def timed(f):
    t = time.perf_counter()
    r = f()
    return time.perf_counter() - t, r


def cpu_seconds():
    u = resource.getrusage(resource.RUSAGE_SELF)
    return u.ru_utime + u.ru_stime


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--m", type=int, default=2000)
    ap.add_argument("--steps", type=int, default=1000)
    ap.add_argument("--json", help="also write the figures to this file")
    ap.add_argument("--order", type=int, help="the scene's order k instead of its 4 (the same rigid body otherwise)")
    args = ap.parse_args()
    sys.path.insert(0, os.path.join(args.build, "python"))
    os.environ["PYTHONPATH"] = os.path.join(args.build, "python") + os.pathsep + os.environ.get("PYTHONPATH", "")
    import numpy as np
    import distributed
    import pgi
    import pgi.dask

    s = pgi.Scheme.from_toml(os.path.join(ROOT, "tools", "scenes", "rigid_body.toml"))
    if args.order:  # the scene's own values, another order
        s = pgi.Scheme(coordinates=["x1", "x2", "x3"], brackets={"x1,x2": "-x3", "x2,x3": "-x1", "x3,x1": "-x2"},
                       hamiltonian="1/4*x1^2 + 1/2*x2^2 + 3/4*x3^2", casimirs=["x1^2 + x2^2 + x3^2"], order=args.order)
    dt, t_end = 0.01, 0.01 * args.steps
    X0 = np.random.default_rng(0).uniform(-1, 1, size=(args.m, 3))
    s.integrate_ensemble(X0[:2], dt=dt, t_end=dt, x_typical=s.typical_state(X0))  # the exact phase, untimed
    runs, cpu = {}, {}
    c = cpu_seconds()
    runs["single_1"] = timed(lambda: s.integrate_ensemble(X0, dt=dt, t_end=t_end, threads=1, batch=1))
    cpu["single_1"] = cpu_seconds() - c
    for threads in (1, 2):
        c = cpu_seconds()
        runs[f"threads_{threads}"] = timed(lambda: s.integrate_ensemble(X0, dt=dt, t_end=t_end, threads=threads))
        cpu[f"threads_{threads}"] = cpu_seconds() - c
    for workers in (1, 2):
        cluster = distributed.LocalCluster(n_workers=workers, processes=True, threads_per_worker=1, dashboard_address=None,
                                           silence_logs=50)
        with distributed.Client(cluster) as client:
            pgi.dask.integrate_ensemble(client, s, X0[:4 * workers], dt=dt, t_end=dt, chunks=1)  # warm: schemes built
            runs[f"dask_{workers}"] = timed(lambda: pgi.dask.integrate_ensemble(client, s, X0, dt=dt, t_end=t_end))
        cluster.close()
    ref = runs["threads_1"][1]
    for name, (_, r) in runs.items():
        assert np.array_equal(r.x, ref.x) and np.array_equal(r.energy_error, ref.energy_error), name
    steps = args.m * args.steps
    seconds = {name: t for name, (t, _) in runs.items()}
    figures = dict(m=args.m, steps=args.steps, order=args.order or 4, cores=os.cpu_count(), seconds=seconds, cpu_seconds=cpu,
                   load_average=os.getloadavg(),
                   steps_per_second={k: steps / v for k, v in seconds.items()},
                   batch_over_single=seconds["single_1"] / seconds["threads_1"],
                   threads_2_over_1=seconds["threads_1"] / seconds["threads_2"],
                   dask_2_over_1=seconds["dask_1"] / seconds["dask_2"],
                   dask_1_over_threads_1=seconds["threads_1"] / seconds["dask_1"])
    print(f"rigid body, k = {args.order or 4}, {args.m} trajectories x {args.steps} steps, {os.cpu_count()} cores (same numbers bit for bit in all five runs)")
    for k, v in seconds.items():
        busy = f"  (this process's CPU time {cpu[k]:.2f} s: {cpu[k] / v:.2f} cores busy)" if k in cpu else ""
        print(f"  {k:10s} {v:7.2f} s  {steps / v:10.3g} steps/s{busy}")
    print(f"  load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores: below {os.cpu_count()} busy cores the "
          "machine is shared and the ratios measure the sharing, not pgi")
    print(f"  batches / one at a time (1 thread): {figures['batch_over_single']:.2f}x")
    print(f"  2 threads / 1 thread: {figures['threads_2_over_1']:.2f}x   Dask 2 workers / 1 worker: {figures['dask_2_over_1']:.2f}x"
          f"   Dask 1 worker / local 1 thread: {figures['dask_1_over_threads_1']:.2f}x")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(figures, f, indent=2)


if __name__ == "__main__":
    main()
