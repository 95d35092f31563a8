"""A parameter sweep against the same ensemble without parameters (issue 34): the rigid body with its three inverse
moments of inertia as parameters (tools/scenes/rigid_body_parameters.toml), 10^4 trajectories each with its own
values (one ensemble call), against tools/scenes/rigid_body.toml's ensemble of the same 10^4 states; and the same
sweep with realisation = "radial" (the compiled polynomial realisation) against the radial ensemble without parameters. The parameters are extra
coordinates with zero rows of pi: the sweep keeps the so(3) closed form and Newton on the three coordinates
(LaneStep<3> on lanes, the parameters inputs of its maps), as the ensemble without them. The exact phase and the
step's build are done before the clock starts (a first small call); the four ensembles are timed in turn, `repeats`
rounds, and each one's best is kept. Prints and writes the times and their ratio (target: within 1.3x).

Then the same comparison for two other classes of structure, each with three parameters: Henon-Heiles with
H = (p1^2 + p2^2)/2 + a (q1^2 + q2^2)/2 + b q1^2 q2 - c q2^3/3 (canonical: the compiled polynomial realisation) and the
cyclic Lotka-Volterra system with H = a x1 + b x2 + c x3 (log-canonical), against the same scenes with a = b = c = 1
written in.

    PYTHONPATH=build/python /usr/bin/python3 tools/bench/bench_parameters.py [--m 10000] [--t-end 10] [--out FILE]
"""
import argparse
import json
import pathlib
import platform
import time

import numpy as np

import pgi

ROOT = pathlib.Path(__file__).resolve().parents[2]


def best_times(runs, repeats):
    """The best of `repeats` timings of each run, the runs interleaved: a load that comes and goes on the shared
    machine falls on all of them alike."""
    best = [float("inf")] * len(runs)
    for _ in range(repeats):
        for i, run in enumerate(runs):
            start = time.perf_counter()
            run()
            best[i] = min(best[i], time.perf_counter() - start)
    return best


OTHER_CLASSES = {
    "henon_heiles": dict(coordinates=["q1", "q2", "p1", "p2"], brackets={"q1,p1": "1", "q2,p2": "1"},
                         hamiltonian="(p1^2 + p2^2)/2 + a*(q1^2 + q2^2)/2 + b*q1^2*q2 - c*q2^3/3", casimirs=[],
                         dt=0.1, low=-0.2, high=0.2),
    "lotka_volterra": dict(coordinates=["x1", "x2", "x3"], brackets={"x1,x2": "x1*x2", "x2,x3": "x2*x3", "x3,x1": "x3*x1"},
                           hamiltonian="a*x1 + b*x2 + c*x3", casimirs=["x1*x2*x3"], dt=0.05, low=0.5, high=2.0),
}


def other_class(rng, a, coordinates, brackets, hamiltonian, casimirs, dt, low, high):
    """A sweep of a, b, c (each within 10% of 1) against the scheme with a = b = c = 1 written in, as main's."""
    X0 = rng.uniform(low, high, size=(a.m, len(coordinates)))
    defaults = {"a": "1", "b": "1", "c": "1"}
    swept = pgi.Scheme(coordinates, brackets, hamiltonian, casimirs, order=4, dt=dt, parameters=defaults)
    plain = pgi.Scheme(coordinates, brackets, hamiltonian.replace("a*", "").replace("b*", "").replace("c*", ""),
                       casimirs, order=4, dt=dt)
    sweep = {k: rng.uniform(0.9, 1.1, a.m) for k in defaults}
    kw = dict(t_end=a.t_end, threads=a.threads)
    plain.integrate_ensemble(X0[:16], **kw)
    swept.integrate_ensemble(X0[:16], parameters={k: v[:16] for k, v in sweep.items()}, **kw)
    t_plain, t_sweep = best_times([lambda: plain.integrate_ensemble(X0, **kw),
                                   lambda: swept.integrate_ensemble(X0, parameters=sweep, **kw)], a.repeats)
    r = swept.integrate_ensemble(X0, parameters=sweep, **kw)
    return {"seconds_without_parameters": t_plain, "seconds_sweep": t_sweep, "ratio_sweep_to_without": t_sweep / t_plain,
            "all_ok": bool(np.all(r.status == "ok"))}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--m", type=int, default=10_000, help="trajectories (parameter values) of the sweep")
    ap.add_argument("--t-end", type=float, default=10.0, help="the run's length (dt = 1/10: 100 steps)")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--threads", type=int, default=None)
    ap.add_argument("--out", default=str(pathlib.Path(__file__).with_name("bench_parameters_results.json")))
    a = ap.parse_args()
    rng = np.random.default_rng(34)
    X0 = rng.normal(size=(a.m, 3))
    X0 /= np.linalg.norm(X0, axis=1)[:, None]  # on the unit sphere, the rigid body's Casimir level 1
    sweep = {"w1": rng.uniform(0.45, 0.55, a.m), "w2": rng.uniform(0.9, 1.1, a.m), "w3": rng.uniform(1.4, 1.6, a.m)}
    plain = pgi.Scheme.from_toml(ROOT / "tools/scenes/rigid_body.toml")
    swept = pgi.Scheme.from_toml(ROOT / "tools/scenes/rigid_body_parameters.toml")
    kw = dict(t_end=a.t_end, threads=a.threads)
    # the exact phase and the step's build, off the clock
    plain.integrate_ensemble(X0[:16], **kw)
    swept.integrate_ensemble(X0[:16], parameters={k: v[:16] for k, v in sweep.items()}, **kw)
    radial = pgi.Scheme(swept.coordinates, {"x1,x2": "-x3", "x2,x3": "-x1", "x3,x1": "-x2"}, swept.hamiltonian,
                        swept.casimirs, order=swept.order, dt=swept.dt, realisation="radial", parameters=swept.parameters)
    radial.integrate_ensemble(X0[:16], parameters={k: v[:16] for k, v in sweep.items()}, **kw)
    radial_plain = pgi.Scheme(plain.coordinates, {"x1,x2": "-x3", "x2,x3": "-x1", "x3,x1": "-x2"}, plain.hamiltonian,
                              plain.casimirs, order=plain.order, dt=plain.dt, realisation="radial")
    radial_plain.integrate_ensemble(X0[:16], **kw)
    t_plain, t_defaults, t_sweep, t_radial_plain, t_radial = best_times([
        lambda: plain.integrate_ensemble(X0, **kw),
        lambda: swept.integrate_ensemble(X0, **kw),
        lambda: swept.integrate_ensemble(X0, parameters=sweep, **kw),
        lambda: radial_plain.integrate_ensemble(X0, **kw),
        lambda: radial.integrate_ensemble(X0, parameters=sweep, **kw),
    ], a.repeats)
    r = swept.integrate_ensemble(X0, parameters=sweep, **kw)
    others = {name: other_class(rng, a, **make) for name, make in OTHER_CLASSES.items()}
    result = {
        "m": a.m, "t_end": a.t_end, "steps": int(round(a.t_end / 0.1)), "repeats": a.repeats, "threads": a.threads,
        "seconds_without_parameters": t_plain, "seconds_parameters_at_defaults": t_defaults,
        "seconds_sweep": t_sweep, "ratio_sweep_to_without": t_sweep / t_plain,
        "seconds_radial_without_parameters": t_radial_plain, "seconds_sweep_radial": t_radial,
        "ratio_sweep_radial_to_radial_without": t_radial / t_radial_plain,
        "realisation_without": "lie-poisson (closed form, so(3))",
        "terms_builds": swept.stats()["terms_builds"], "all_ok": bool(np.all(r.status == "ok")),
        "max_casimir_error": float(np.max(r.casimir_error)), "machine": platform.machine(),
        "other_classes": others,
    }
    print(json.dumps(result, indent=2))
    pathlib.Path(a.out).write_text(json.dumps(result, indent=2) + "\n")


if __name__ == "__main__":
    main()
