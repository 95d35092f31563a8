#!/usr/bin/env python3
"""The README's claims about the stiff and extreme suite, checked by running pgi_peers --suite (issue 5).
Deterministic: no timing is asserted. Usage: suite_claims.py PGI_PEERS SCENES_DIR"""
import json
import os
import subprocess
import sys
import tempfile


def suite(peers, scene, *extra):
    out = subprocess.run([peers, scene, "--suite", *extra], check=True, capture_output=True, text=True).stdout
    return {r["method"]: r for r in json.loads(out)["suite"]["rows"]}


def main():
    peers, scenes = sys.argv[1], sys.argv[2]
    failures = []

    def claim(ok, text):
        print(("ok    " if ok else "FAIL  ") + text)
        if not ok:
            failures.append(text)

    # every peer of the comparison is present and ran
    expected = {"rk2imp", "rk4imp", "rk8pd", "rkf45", "msbdf", "odeint-rk4", "odeint-dopri5", "odeint-bs"}
    stiff = suite(peers, f"{scenes}/stiff_oscillators.toml", "--watch", "(p1^2 + 1000000*q1^2)/2")
    claim(expected <= set(stiff), "all eight peers run")
    claim("odeint-rkf78" in stiff, "and odeint's Fehlberg 7(8)")
    # stiff pair at omega dt = 10: pgi keeps the stiff mode's energy, BDF damps it, explicit RK4 blows up
    pgi = stiff["pgi-k2"]
    claim(pgi["ok"] and abs(pgi["watched_final_over_initial"][0] - 1) < 1e-4, "pgi keeps the stiff mode's energy to 1e-4")
    claim(stiff["msbdf"]["ok"] and stiff["msbdf"]["watched_final_over_initial"][0] < 0.9, "msbdf at tol 1e-6 damps the stiff mode by > 10%")
    claim(not stiff["odeint-rk4"]["ok"] and "non-finite" in stiff["odeint-rk4"]["failure"], "explicit RK4 at omega dt = 10 fails, named")
    # near the singular set: the Casimir x1 x2 x3 = 1e-6 kept to round-off by pgi, not by the implicit RK peers
    near = suite(peers, f"{scenes}/lotka_volterra.toml", "--x0", "1e-6,2,0.5")
    claim(near["pgi-k4"]["casimir_error_max"] <= 1e-13, "pgi keeps the Casimir near the singular set to 1e-13")
    claim(near["rk4imp"]["casimir_error_max"] > 1e-10, "rk4imp does not keep the cubic Casimir")
    # scale invariance of the rigid body: |x| = 1e6 with dt = 1e-7 gives the errors of |x| = 1 with dt = 0.1
    base = suite(peers, f"{scenes}/rigid_body.toml", "--t-end", "10")
    big = suite(peers, f"{scenes}/rigid_body.toml", "--x0", "453596.1214255773,0,891207.3600614354", "--dt", "1e-7", "--t-end", "1e-5")
    e0, e1 = base["pgi-k4"]["energy_error_max"], big["pgi-k4"]["energy_error_max"]
    claim(e0 > 0 and abs(e1 - e0) <= 1e-3 * e0, f"pgi's energy error is scale invariant ({e0:.6e} vs {e1:.6e})")
    # order 8
    k8 = suite(peers, f"{scenes}/rigid_body.toml", "--order", "8", "--dt", "0.2", "--t-end", "10")
    claim(k8["pgi-k8"]["ok"] and k8["pgi-k8"]["energy_error_max"] < 1e-11, "k = 8 at dt = 0.2: energy error below 1e-11")
    # the peers run on a right-hand side of their own, C compiled by the system compiler (issue 33); fed pgi's field
    # (the comparison before), rk8pd takes the same steps to the same error
    out = subprocess.run([peers, f"{scenes}/lotka_volterra.toml", "--orders", "4", "--peers", "rk8pd", "--pgi-field",
                          "rk8pd", "--tols", "1e-8", "--dts", "0.1"], check=True, capture_output=True, text=True).stdout
    wp = json.loads(out)
    rhs = wp["peer_rhs"]
    claim(rhs["compiler"].endswith("-O3 -march=native -fPIC -shared") and rhs["build_seconds"] > 0,
          f"the peers' right-hand side is compiled C ({rhs['compiler']})")
    rows = {r["method"]: r for r in wp["work_precision"]["rows"]}
    own, fed = rows["rk8pd"], rows["rk8pd-pgifield"]
    # (FMA in the C code may move an accepted step by round-off: the counts may differ by a step or two)
    claim(own["ok"] and fed["ok"] and abs(own["steps"] - fed["steps"]) <= 2 and abs(own["error"] - fed["error"]) <= 1e-2 * fed["error"],
          f"rk8pd on its C right-hand side and fed pgi's field agree ({own['steps']} and {fed['steps']} steps, errors "
          f"{own['error']:.6e} and {fed['error']:.6e})")
    # no C compiler for the peers' right-hand side: exit 7 (as pgi's native code), naming the command
    r = subprocess.run([peers, f"{scenes}/rigid_body.toml", "--suite"], capture_output=True, text=True,
                       env=dict(os.environ, CC="false"))
    claim(r.returncode == 7 and "the compiler `false -O3 -march=native -fPIC -shared` exited with status 1" in r.stderr
          and not r.stdout, "CC=false: exit 7, names the compiler")
    # no directory to compile in (TMPDIR a file, or missing): exit 7 too, naming TMPDIR, never an internal error
    with tempfile.TemporaryDirectory() as d:
        a_file = os.path.join(d, "a-file")
        open(a_file, "w").close()
        for tmpdir in (a_file, os.path.join(d, "missing")):
            r = subprocess.run([peers, f"{scenes}/rigid_body.toml", "--suite"], capture_output=True, text=True,
                               env=dict(os.environ, TMPDIR=tmpdir))
            claim(r.returncode == 7 and f"cannot make a directory like {tmpdir}/pgi-peers-" in r.stderr and "TMPDIR" in r.stderr
                  and not r.stdout, f"TMPDIR={os.path.basename(tmpdir)}: exit 7, names the directory")
        claim(os.listdir(d) == ["a-file"], "a failed TMPDIR leaves nothing behind")
    # bad input: exit 2 and a message naming the problem, before any run
    for args, message in ((["--peers", "bogus"], "unknown peer 'bogus'"), (["--orders", "0"], "--orders"),
                          (["--pgi-field", "rk8pd-pgifield"], "--pgi-field: unknown peer 'rk8pd-pgifield'"),
                          (["--tols", "0"], "--tols"), (["--plot", "x.svg"], "--plot draws from the --csv file"),
                          (["--x0", "1,2"], "x0"), (["--csv", "/nonexistent/x.csv"], "directory '/nonexistent' does not exist"),
                          (["--dts", "0.1414", "--t-end", "100"], "--dts: dt = 0.1414 does not divide the final time 100")):
        r = subprocess.run([peers, f"{scenes}/rigid_body.toml", *args], capture_output=True, text=True)
        claim(r.returncode == 2 and message in r.stderr and not r.stdout, f"pgi_peers {' '.join(args)}: exit 2, says {message!r}")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
