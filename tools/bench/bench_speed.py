#!/usr/bin/python3
"""Speed against rk8pd and the other peers, and on large lattices (issues 13 and 33): the tables, ratios from one run.

Usage: /usr/bin/python3 tools/bench/bench_speed.py [--build build] [--json FILE] [--timeout 120] [--passes 3]
                                                  [--sizes 50,100,200,500,1000] [--skip-wp] [--skip-lattice] [--skip-dmv]

Every child runs with an empty JIT cache of its own (PGI_JIT_CACHE): pgi's default configuration then runs as in a
first run, machine code until native code pays for its build (these runs never reach that), and no run sees a library
an earlier one kept.
(a) Work-precision, T = 100, stepping only, on the rigid body, the cyclic Lotka-Volterra system and Henon-Heiles:
    pgi_peers (tools/peers) runs pgi at k = 4, 6, 8, 10, 12 on a dt ladder through its C++ API in its default
    configuration (a Scheme of the scene at order k, scheme.stepper(dt, x0) built outside the clock, then
    integrate_steps: stepper.step and Kahan summation), and again with native code from the start (jit = always:
    what the default runs once its native code is built or kept; the same errors bit for bit); GSL's rk8pd and
    msbdf, Boost.Odeint's dopri5, Fehlberg 7(8) and Bulirsch-Stoer on a tolerance ladder and GSL's rk4imp on the dt
    ladder, every peer on its own right-hand side: C generated from the scene's exact polynomials and compiled by the
    system C compiler (cc -O3 -march=native), loaded before any run, called by GSL directly
    (tools/peers/compiled_rhs.hpp). rk8pd also runs fed pgi's compiled field through pgi's interpreter
    (rk8pd-pgifield), the comparison before issue 33, for the last column. Every time is the best of up to 25 runs
    that watch nothing (warm: a first, monitored run gives the errors of H and the Casimirs), each method's step (pgi's
    exact phase) built once before them, and of --passes runs of the whole child minutes apart (the machine is
    shared: a busy neighbour slows every repetition of one pass). Errors against a long double Fehlberg 7(8) reference.
    Odd k are not scanned: the step is symmetric and S_2j = 0, so k = 2j-1 and 2j are the same method.
    For a target error each method's time is interpolated log-log between the first two runs of its
    ladder (ordered by step count) whose errors straddle it (or it is the cheapest run, where that one
    already reaches it); pgi's time is the best over k (a user picks the order). The exact phase (setup) is excluded
    from the times and printed apart. Ratio = peer time / pgi time: above 1, pgi is faster.
(b) Periodic Volterra lattice ({x_i, x_i+1} = x_i x_i+1, H = sum x_i, no Casimirs declared), k = 4,
    dt = 1/20, n = 50..1000: `pgi_peers --suite --peers rk8pd` per n, --passes times (the fastest kept) (scene checks, exact phase,
    200 pgi steps and an rk8pd run at tolerance 1e-10 over the same interval, rk8pd on its C right-hand side,
    compiled in the child: its compile time is printed apart) under a wall-clock timeout
    and an address-space limit; its peak RSS (wait4's ru_maxrss) is the peak memory of checks + exact
    phase + steps; then `pgi step` on the same scene (checks, exact phase, one step): its peak RSS is the
    exact phase's memory, also printed per site relative to the first n (1.00 everywhere = linear in n).
    Then the whole `pgi integrate` at n = 1000 (checks, exact phase, 1000 steps), timed.
(c) The rigid body against the discrete Moser-Veselov peer (tools/bench/dmv_bench): pgi at k = 10..16 (its
    best order) against DMV of orders 2..10 and rk8pd; see that program.

Every row goes into the JSON file; the tables are printed in Markdown on stdout.
"""
import argparse
import json
import math
import os
import resource
import signal
import subprocess
import sys
import tempfile
import time

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
WP_SCENES = ["rigid_body", "lotka_volterra", "henon_heiles"]
ORDERS = [4, 6, 8, 10, 12]
# the peers of (a), each on its compiled C right-hand side; rk8pd also fed pgi's field (rk8pd-pgifield)
PEERS = ["rk8pd", "rk4imp", "msbdf", "odeint-dopri5", "odeint-rkf78", "odeint-bs"]
OTHER_PEERS = PEERS[1:]
TOLS = [10.0 ** -e for e in range(6, 17)]
TARGETS = [1e-10, 1e-12]
MEMORY_LIMIT = 4 << 30  # address space of each lattice child: the machine is shared


def dt_ladder(dt, t_end=100):
    """From 8 dt down to dt/64, by factors of sqrt(2) above dt (where pgi's best orders reach the targets: a ladder
    stopping at 4 dt left the rigid body's k = 12 at 3.6e-12 for a 1e-10 target) and of 2 below (down to where the
    fixed-step peer rk4imp, order 4, reaches 1e-10 or nearly); each dt divides t_end exactly (dt = t_end / N), so
    every run ends at t_end."""
    return [t_end / round(t_end / (dt * 2 ** e)) for e in (3, 2.5, 2, 1.5, 1, 0.5, 0, -1, -2, -3, -4, -5, -6)]


JIT_CACHES = None  # a private directory holding each child's own, empty JIT cache (main() makes it)


def run_child(argv, timeout, memory_limit=None):
    """Runs argv with an empty JIT cache of its own (PGI_JIT_CACHE: pgi's default configuration sees no library an
    earlier run kept, so the runs are those of a first run: machine code until native code pays for itself); returns
    (exit code or None on timeout, stdout, stderr, wall seconds, peak RSS in MiB)."""
    env = dict(os.environ)
    if JIT_CACHES:
        env["PGI_JIT_CACHE"] = tempfile.mkdtemp(prefix="jit-", dir=JIT_CACHES)
    def limit():
        if memory_limit:
            resource.setrlimit(resource.RLIMIT_AS, (memory_limit, memory_limit))
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        start = time.monotonic()
        proc = subprocess.Popen(argv, stdout=out, stderr=err, preexec_fn=limit, start_new_session=True, env=env)
        code, rss = None, 0.0
        while True:
            pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
            if pid == proc.pid:
                code, rss = os.waitstatus_to_exitcode(status), usage.ru_maxrss / 1024.0
                break
            if time.monotonic() - start > timeout:
                os.killpg(proc.pid, signal.SIGKILL)
                _, _, usage = os.wait4(proc.pid, 0)
                rss = usage.ru_maxrss / 1024.0
                break
            time.sleep(0.05)
        proc.returncode = code if code is not None else -9  # reaped by wait4: keep Popen from waiting again
        wall = time.monotonic() - start
        out.seek(0)
        err.seek(0)
        return code, out.read().decode(), err.read().decode(), wall, rss


# ---------------------------------------------------------------- (a) work-precision

def time_at_error(points, target):
    """points: (steps, error, seconds) of one method's ladder, ordered here by steps (cost). Log-log
    interpolation between the first two consecutive runs whose errors straddle the target; else the
    cheapest run reaching it (if the cheapest run does); else None. Returns (seconds, how, steps), steps interpolated
    the same way."""
    pts = sorted(p for p in points if p[1] > 0)
    if pts and pts[0][1] <= target:
        return pts[0][2], "cheapest reaching", pts[0][0]
    for (n0, e0, s0), (n1, e1, s1) in zip(pts, pts[1:]):
        if e0 > target >= e1:
            w = (math.log(target) - math.log(e0)) / (math.log(e1) - math.log(e0))
            steps = math.exp(math.log(max(n0, 1)) + w * (math.log(max(n1, 1)) - math.log(max(n0, 1))))
            return math.exp(math.log(s0) + w * (math.log(s1) - math.log(s0))), "interpolated", steps
    return None, "not reached", None


def merge_passes(passes, parameter):
    """The rows of several passes of the same runs, each run's time the fastest of its passes (min over repetitions,
    the repetitions spread over minutes: on a shared 2-core machine a busy neighbour slows every repetition of a pass
    alike). Each run's outcome must be the same in every pass (the same steps, the same error: the runs are
    deterministic)."""
    merged, order = {}, []
    for rows in passes:
        for r in rows:
            key = (r["method"], parameter(r))
            if key not in merged:
                merged[key] = dict(r, passes_seconds=[r["seconds"]])
                order.append(key)
                continue
            m = merged[key]
            if m["steps"] != r["steps"] or m.get("error") != r.get("error"):
                raise RuntimeError(f"{key}: passes disagree ({m['steps']} steps, error {m.get('error')} and "
                                   f"{r['steps']}, {r.get('error')})")
            m["passes_seconds"].append(r["seconds"])
            m["seconds"] = min(m["seconds"], r["seconds"])
            if "setup_seconds" in r:
                m["setup_seconds"] = min(m["setup_seconds"], r["setup_seconds"])
    return [merged[k] for k in order]


def work_precision(build, scene, timeout, passes):
    path = os.path.join(ROOT, "tools", "scenes", scene + ".toml")
    dt = {"rigid_body": 0.1, "lotka_volterra": 0.05, "henon_heiles": 0.1}[scene]
    argv = [os.path.join(build, "pgi_peers"), path, "--orders", ",".join(map(str, ORDERS)), "--peers", ",".join(PEERS),
            "--pgi-field", "rk8pd", "--jit", "--dts", ",".join(repr(v) for v in dt_ladder(dt)),
            "--tols", ",".join(repr(v) for v in TOLS), "--t-end", "100"]
    outputs = []
    for p in range(passes):
        print(f"  pass {p + 1} of {passes}", file=sys.stderr, flush=True)
        code, out, err, wall, _ = run_child(argv, timeout)
        if code != 0:
            raise RuntimeError(f"{' '.join(argv)}: exit {code}\n{err[-2000:]}")
        outputs.append(json.loads(out))
    summary = outputs[0]
    wp = summary["work_precision"]
    rows = merge_passes([o["work_precision"]["rows"] for o in outputs], lambda r: r["parameter"])
    result = {"scene": scene, "reference_accuracy": wp["reference"]["accuracy"], "peer_rhs": summary.get("peer_rhs"),
              "command": " ".join(os.path.relpath(a, ROOT) if a.startswith(ROOT) else a for a in argv),
              "passes": passes, "rows": rows, "targets": []}

    def at(method, target):
        pts = [(r["steps"], r["error"], r["seconds"]) for r in rows if r["method"] == method and r["usable"]]
        return time_at_error(pts, target)

    for target in TARGETS:
        entry = {"error": target}

        def best_over_orders(suffix):
            best = None
            for k in ORDERS:
                s, how, steps = at(f"pgi-k{k}{suffix}", target)
                entry[f"pgi-k{k}{suffix}"] = s
                if s is not None and (best is None or s < best[0]):
                    best = (s, k, how, steps)
            return best
        best = best_over_orders("")
        jit = best_over_orders("-jit")  # the same steps with native code (jit = true): the same errors, bit for bit
        setups = [r["setup_seconds"] for r in rows if best and r["method"] == f"pgi-k{best[1]}"]
        # how many of the step's maps ran native code in the default configuration's timed runs (0: machine code)
        natives = [r.get("native_maps", 0) for r in rows if best and r["method"] == f"pgi-k{best[1]}"]
        entry.update({"pgi_seconds": best[0] if best else None, "pgi_k": best[1] if best else None,
                      "pgi_how": best[2] if best else "not reached", "pgi_steps": best[3] if best else None,
                      "pgi_exact_phase_seconds": min(setups) if setups else None,
                      "pgi_native_maps_max": max(natives) if natives else None,
                      "pgi_jit_seconds": jit[0] if jit else None, "pgi_jit_k": jit[1] if jit else None,
                      "pgi_jit_steps": jit[3] if jit else None, "peers": {}})
        for peer in PEERS + ["rk8pd-pgifield"]:
            s, how, steps = at(peer, target)
            entry["peers"][peer] = {"seconds": s, "how": how, "steps": steps,
                                    "over_pgi": s / best[0] if (s and best) else None,
                                    "over_pgi_jit": s / jit[0] if (s and jit) else None}
        rk = entry["peers"]["rk8pd"]
        # the keys of the tables before issue 33, kept: rk8pd (now on its C right-hand side) over pgi
        entry.update({"rk8pd_seconds": rk["seconds"], "rk8pd_how": rk["how"], "rk8pd_steps": rk["steps"],
                      "ratio_rk8pd_over_pgi": rk["over_pgi"], "ratio_rk8pd_over_pgi_jit": rk["over_pgi_jit"]})
        result["targets"].append(entry)
    return result


def fmt_ms(s):
    return "-" if s is None else f"{1e3 * s:.3f}"


def fmt_ratio(r):
    return "-" if r is None else f"{r:.2f}"


def ns_per_step(seconds, steps):
    return "-" if (seconds is None or not steps) else f"{1e9 * seconds / steps:.0f}"


def wp_table(results):
    lines = ["| scene | error | pgi default: best k | ms (stepping) | steps, ns/step | exact phase s | rk8pd ms "
             "| rk8pd steps, ns/step | **rk8pd / pgi default** | pgi native (jit always): best k | ms "
             "| **rk8pd / pgi native** | old harness: rk8pd fed pgi's field, ms | its / pgi native |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in results:
        for e in r["targets"]:
            rk = e["peers"]["rk8pd"]
            old = e["peers"]["rk8pd-pgifield"]
            setup = "-" if e["pgi_exact_phase_seconds"] is None else f"{e['pgi_exact_phase_seconds']:.3f}"
            how = "" if e["pgi_how"] == "interpolated" else f" ({e['pgi_how']})"
            rhow = "" if rk["how"] == "interpolated" else f" ({rk['how']})"
            psteps = "-" if not e["pgi_steps"] else f"{e['pgi_steps']:.0f}, {ns_per_step(e['pgi_seconds'], e['pgi_steps'])}"
            rsteps = "-" if not rk["steps"] else f"{rk['steps']:.0f}, {ns_per_step(rk['seconds'], rk['steps'])}"
            lines.append(f"| {r['scene']} | {e['error']:.0e} | {e['pgi_k'] or '-'} | {fmt_ms(e['pgi_seconds'])}{how} | {psteps} "
                         f"| {setup} | {fmt_ms(rk['seconds'])}{rhow} | {rsteps} | **{fmt_ratio(rk['over_pgi'])}** "
                         f"| {e['pgi_jit_k'] or '-'} | {fmt_ms(e['pgi_jit_seconds'])} | {fmt_ratio(rk['over_pgi_jit'])} "
                         f"| {fmt_ms(old['seconds'])} | {fmt_ratio(old['over_pgi_jit'])} |")
    return "\n".join(lines)


def peers_table(results):
    names = [p for p in OTHER_PEERS if any(p in e.get("peers", {}) for r in results for e in r["targets"])]
    lines = ["| scene | error | pgi ms | " + " | ".join(names) + " |", "| --- | --- | --- |" + " --- |" * len(names)]
    for r in results:
        for e in r["targets"]:
            cells = []
            for p in names:
                q = e["peers"].get(p, {})
                cells.append("not reached" if q.get("seconds") is None
                             else f"{fmt_ms(q['seconds'])} ms ({fmt_ratio(q['over_pgi'])})")
            lines.append(f"| {r['scene']} | {e['error']:.0e} | {fmt_ms(e['pgi_seconds'])} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


# ---------------------------------------------------------------- (b) lattice scaling

def lattice_scene(n):
    xs = [f"x{i}" for i in range(1, n + 1)]
    brackets = "\n".join(f'"{xs[i]},{xs[(i + 1) % n]}" = "{xs[i]}*{xs[(i + 1) % n]}"' for i in range(n))
    # a smooth, non-uniform initial state (positive: the lattice's domain)
    x0 = ", ".join(repr(1.0 + 0.5 * math.sin(2 * math.pi * i / n) + 0.1 * math.cos(6 * math.pi * i / n)) for i in range(n))
    return (f'name = "periodic Volterra lattice, n = {n}"\ncoordinates = [{", ".join(chr(34) + x + chr(34) for x in xs)}]\n\n'
            f"[brackets]\n{brackets}\n\n[hamiltonian]\nH = \"{' + '.join(xs)}\"\n\n"
            f'[integrator]\norder = 4\ndt = "1/20"\n\n[run]\nx0 = [{x0}]\nt_end = 50\n')


def lattice(build, sizes, timeout, workdir, passes=1):
    rows = []
    for n in sizes:
        path = os.path.join(workdir, f"volterra_{n}.toml")
        with open(path, "w") as f:
            f.write(lattice_scene(n))
        steps = 200  # the same count at every n: one step at n = 1000 is well under a millisecond now
        t_end = steps / 20
        argv = [os.path.join(build, "pgi_peers"), path, "--suite", "--peers", "rk8pd", "--tol", "1e-10", "--t-end", repr(t_end)]
        # each of pgi's and rk8pd's runs is one run of a few milliseconds: the fastest of the passes
        runs = [run_child(argv, timeout, MEMORY_LIMIT) for _ in range(max(passes, 1))]
        code, out, err, wall, rss = runs[0]
        row = {"n": n, "pgi_steps_asked": steps, "wall_seconds": wall, "peak_rss_mib": rss, "exit": code,
               "passes": len(runs)}
        if code is None:
            row["status"] = f"timeout ({timeout:g} s)"
        elif code != 0:
            row["status"] = f"exit {code}: " + (err.strip().splitlines() or [""])[-1][:200]
        else:
            summary = json.loads(out)
            suite = {r["method"]: r for r in summary["suite"]["rows"]}
            p, q = suite["pgi-k4"], suite["rk8pd"]
            for c, o, _, _, _ in runs[1:]:
                if c == 0:
                    other = {r["method"]: r for r in json.loads(o)["suite"]["rows"]}
                    p = dict(p, seconds=min(p["seconds"], other["pgi-k4"]["seconds"]))
                    q = dict(q, seconds=min(q["seconds"], other["rk8pd"]["seconds"]))
            row.update({"status": "ok" if p["ok"] else "pgi failed: " + p["failure"],
                        "peer_rhs_build_seconds": summary["peer_rhs"]["build_seconds"],
                        "exact_phase_seconds": p["setup_seconds"], "pgi_steps": p["steps"], "pgi_seconds": p["seconds"],
                        "pgi_ns_per_step_site": 1e9 * p["seconds"] / max(p["steps"], 1) / n,
                        "rk8pd_steps": q["steps"], "rk8pd_seconds": q["seconds"],
                        "rk8pd_ns_per_step_site": 1e9 * q["seconds"] / max(q["steps"], 1) / n})
        # the exact phase's memory: `pgi step` is the checks, the exact phase and one step
        code, out, err, wall_step, rss_step = run_child([os.path.join(build, "pgi"), "step", path, "--json"], timeout, MEMORY_LIMIT)
        row.update({"exact_phase_rss_mib": rss_step if code == 0 else None, "step_command_seconds": wall_step})
        print(f"lattice n = {n}: {row['status']}, {wall:.1f} s, {rss:.0f} MiB; pgi step {wall_step:.1f} s, {rss_step:.0f} MiB",
              file=sys.stderr, flush=True)
        rows.append(row)
    return rows


def integrate_whole(build, n, timeout, workdir):
    path = os.path.join(workdir, f"volterra_{n}.toml")
    with open(path, "w") as f:
        f.write(lattice_scene(n))
    argv = [os.path.join(build, "pgi"), "integrate", path, "--t-end", "50", "--json"]
    code, out, err, wall, rss = run_child(argv, timeout, MEMORY_LIMIT)
    row = {"n": n, "command": "pgi integrate (checks, exact phase, 1000 steps of 1/20)", "wall_seconds": wall,
           "peak_rss_mib": rss, "exit": code}
    row["status"] = (f"timeout ({timeout:g} s)" if code is None else "ok" if code == 0
                     else f"exit {code}: " + (err.strip().splitlines() or [""])[-1][:200])
    return row


def lattice_table(rows, whole):
    def f(v, spec):
        return "-" if v is None else format(v, spec)
    base = next((r.get("pgi_ns_per_step_site") for r in rows if r.get("pgi_ns_per_step_site")), None)
    lines = [f"| n | status | exact phase s | rk8pd's C right-hand side, compiled s | rest of child s | pgi ns/step/site | vs n = {rows[0]['n'] if rows else '-'} "
             "| rk8pd ns/step/site | pgi / rk8pd per step | peak RSS MiB | exact-phase RSS MiB (pgi step) | its KiB per site added since the row before | child wall s |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    previous = None
    for r in rows:
        p, q = r.get("pgi_ns_per_step_site"), r.get("rk8pd_ns_per_step_site")
        # the child's wall time less the exact phase, the peer's compilation and both runs: scene checks (Jacobi),
        # pgi's compiled maps, start-up
        cc = r.get("peer_rhs_build_seconds")
        rest = (r["wall_seconds"] - r["exact_phase_seconds"] - (cc or 0) - r["pgi_seconds"] - r["rk8pd_seconds"]) if "pgi_seconds" in r else None
        m = r.get("exact_phase_rss_mib")
        # linear memory is a constant slope (the first rows are mostly the program's fixed memory, which a ratio
        # per site would count as the sites')
        slope = 1024 * (m - previous["exact_phase_rss_mib"]) / (r["n"] - previous["n"]) if (m and previous) else None
        lines.append(f"| {r['n']} | {r['status']} | {f(r.get('exact_phase_seconds'), '.2f')} | {f(cc, '.2f')} | {f(rest, '.1f')} | {f(p, '.0f')} | "
                     f"{f(p / base if (p and base) else None, '.2f')} | {f(q, '.1f')} | {f(p / q if (p and q) else None, '.1f')} | "
                     f"{r['peak_rss_mib']:.0f} | {f(m, '.0f')} | {f(slope, '.0f')} | {r['wall_seconds']:.1f} |")
        previous = r if m else previous
    measured = [r for r in rows if r.get("exact_phase_rss_mib")]
    if len(measured) >= 2:
        a, b = measured[-2], measured[-1]
        lines.append("")
        lines.append(f"Exact-phase RSS from n = {a['n']} to {b['n']}: x{b['exact_phase_rss_mib'] / a['exact_phase_rss_mib']:.2f} "
                     f"for x{b['n'] / a['n']:.2f} the sites.")
    if whole:
        lines.append("")
        lines.append(f"Whole `pgi integrate` at n = {whole['n']} (checks, exact phase, 1000 steps): {whole['status']}, "
                     f"{whole['wall_seconds']:.1f} s wall, peak RSS {whole['peak_rss_mib']:.0f} MiB (targets: 60 s, 1024 MiB).")
    return "\n".join(lines)


# ---------------------------------------------------------------- (c) DMV

def dmv_at_target(name, rows, target):
    """dmv_bench's at_target on merged rows: time, steps and ns per step at the target (log-log between the first two
    runs by step count that straddle it, else the cheapest run reaching it)."""
    pts = sorted((r["steps"], r["error"], r["seconds"]) for r in rows if r["method"] == name and r["usable"])
    out = {"method": name, "ns_per_step": None, "seconds": None, "how": "not reached", "steps": None}
    ns = lambda p: 1e9 * p[2] / max(p[0], 1)
    if pts and pts[0][1] <= target:
        return dict(out, seconds=pts[0][2], how="cheapest reaching", steps=pts[0][0], ns_per_step=ns(pts[0]))
    for a, b in zip(pts, pts[1:]):
        if a[1] > target >= b[1]:
            w = math.log(target / a[1]) / math.log(b[1] / a[1])
            return dict(out, seconds=math.exp(math.log(a[2]) + w * math.log(b[2] / a[2])), how="interpolated",
                        steps=round(math.exp(math.log(a[0]) + w * math.log(b[0] / a[0]))),
                        ns_per_step=0.5 * (ns(a) + ns(b)))
    return out


def dmv(build, timeout, passes):
    exe = os.path.join(build, "dmv_bench")
    if not os.path.exists(exe):
        return None
    outputs = []
    for p in range(passes):
        code, out, err, wall, _ = run_child([exe, os.path.join(ROOT, "tools", "scenes", "rigid_body.toml")], timeout)
        if code != 0:
            raise RuntimeError(f"dmv_bench: exit {code}\n{err[-2000:]}")
        outputs.append(json.loads(out))
    d = outputs[0]
    if passes > 1:  # each run's fastest pass, and the times at the target again from them
        d["rows"] = merge_passes([o["rows"] for o in outputs], lambda r: r.get("dt", r.get("tol")))
        d["at_target"] = [dmv_at_target(t["method"], d["rows"], d["target"]) for t in d["at_target"]]
        secs = {t["method"]: t["seconds"] for t in d["at_target"]}

        def best(suffix):
            names = [f"pgi-k{k}{suffix}" for k in (10, 12, 14, 16) if secs.get(f"pgi-k{k}{suffix}")]
            return min(names, key=lambda n: secs[n]) if names else ""
        d["pgi_best"], d["pgi_best_jit"] = best(""), best("-jit")
        d["ratio"] = secs["dmv10"] / secs[d["pgi_best"]] if (d["pgi_best"] and secs.get("dmv10")) else None
        d["ratio_jit"] = secs["dmv10"] / secs[d["pgi_best_jit"]] if (d["pgi_best_jit"] and secs.get("dmv10")) else None
    d["passes"] = passes
    return d


def dmv_table(d):
    lines = ["| method | time to 1e-11 (ms, stepping) | how | ns per step at that point | steps |", "| --- | --- | --- | --- | --- |"]
    for r in d["at_target"]:
        lines.append(f"| {r['method']} | {fmt_ms(r['seconds'])} | {r['how']} | {'-' if r['ns_per_step'] is None else format(r['ns_per_step'], '.0f')} "
                     f"| {r['steps'] or '-'} |")
    lines.append("")
    lines.append(f"Ratio DMV-10 / pgi time at 1e-11 (pgi's best order, {d.get('pgi_best') or '-'}): "
                 f"{'-' if d['ratio'] is None else format(d['ratio'], '.2f')} "
                 f"(issue target for pgi: within 1.5x of the order-10 preprocessed DMV, a ratio of at least 0.67); "
                 f"with native code (--jit, {d.get('pgi_best_jit') or '-'}): "
                 f"{'-' if d.get('ratio_jit') is None else format(d['ratio_jit'], '.2f')}.")
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--json", default="bench_speed.json")
    ap.add_argument("--timeout", type=float, default=120.0, help="per lattice child (s)")
    ap.add_argument("--sizes", default="50,100,200,500,1000")
    ap.add_argument("--skip-wp", action="store_true")
    ap.add_argument("--skip-lattice", action="store_true")
    ap.add_argument("--skip-dmv", action="store_true")
    ap.add_argument("--passes", type=int, default=3,
                    help="runs of each work-precision, DMV and lattice child; each run's time is its fastest pass "
                         "(default 3)")
    ap.add_argument("--tables-from", help="print the tables of an earlier run's JSON file, without running anything")
    a = ap.parse_args()
    if a.tables_from:
        with open(a.tables_from) as f:
            print_tables(json.load(f))
        return
    global JIT_CACHES
    with tempfile.TemporaryDirectory(prefix="pgi-bench-speed-") as caches:
        JIT_CACHES = caches
        run(a)


def run(a):
    report = {"machine": os.uname().nodename, "started_utc": time.strftime("%Y-%m-%d %H:%M:%S", time.gmtime()),
              "load_average_at_start": os.getloadavg()}
    if not a.skip_wp:
        report["work_precision"] = []
        for scene in WP_SCENES:
            print(f"work-precision: {scene}", file=sys.stderr, flush=True)
            report["work_precision"].append(work_precision(a.build, scene, 1800, a.passes))
    if not a.skip_lattice:
        with tempfile.TemporaryDirectory() as work:
            sizes = [int(s) for s in a.sizes.split(",")]
            report["lattice"] = lattice(a.build, sizes, a.timeout, work, a.passes)
            report["lattice_whole"] = integrate_whole(a.build, max(sizes), a.timeout, work)
    if not a.skip_dmv:
        d = dmv(a.build, 600, a.passes)
        if d is not None:
            report["dmv"] = d
    report["load_average_at_end"] = os.getloadavg()
    with open(a.json, "w") as f:
        json.dump(report, f, indent=1)
    print_tables(report)
    print(f"rows: {a.json}")


def print_tables(report):
    if "work_precision" in report:
        wp = report["work_precision"]
        print("### Time to final error at T = 100 (stepping only), pgi best k against rk8pd\n")
        print(wp_table(wp) + "\n")
        print("### The other peers: time to the same error, ms (peer time / pgi default's time)\n")
        print(peers_table(wp) + "\n")
        rhs = [r["peer_rhs"] for r in wp if r.get("peer_rhs")]
        if rhs:
            print(f"The peers' right-hand sides: {rhs[0]['language']}, compiled by `{rhs[0]['compiler']}` in "
                  + ", ".join(f"{r['build_seconds']:.2f}" for r in rhs) + " s.\n")
    if "lattice" in report:
        print("### Periodic Volterra lattice, k = 4, dt = 1/20\n")
        print(lattice_table(report["lattice"], report.get("lattice_whole")) + "\n")
    if "dmv" in report:
        print("### Rigid body: pgi (k = 10..16) against the discrete Moser-Veselov peer, error 1e-11\n")
        print(dmv_table(report["dmv"]) + "\n")
    print(f"load average {report['load_average_at_start']} at start, {report['load_average_at_end']} at end "
          f"(on {report['machine']}, {report['started_utc']} UTC; a shared machine: other builds ran alongside)")


if __name__ == "__main__":
    main()
