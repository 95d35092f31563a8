#!/usr/bin/env python3
"""Where a short run's time goes: a whole `pgi integrate` process against the work it does (the exact phase and
the steps, as pgi itself times them in the process), and what every process of pgi pays before main: a process
(/bin/true), the same program linked against pgi's libraries and doing nothing (an empty main), and
`pgi --version`. Each time is the best of --runs whole processes (the page cache warm), and so are pgi's own
timings (its JSON's build_seconds and ns_per_step).
Usage: python3 tools/bench/bench_startup.py [--build build] [--runs 30] [SCENE ...]"""
import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
SCENES = ("rigid_body", "lotka_volterra", "henon_heiles")


def best_of(argv, runs):
    """The shortest wall time of runs whole processes of argv, in ms (each must exit with 0)."""
    best = float("inf")
    for _ in range(runs):
        start = time.perf_counter()
        subprocess.run(argv, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
        best = min(best, time.perf_counter() - start)
    return 1e3 * best


def linked_libraries(program):
    """The shared libraries program names (its DT_NEEDED entries), as linker arguments."""
    out = subprocess.run(["readelf", "-d", program], capture_output=True, text=True, check=True).stdout
    return [":" + m for m in re.findall(r"\(NEEDED\)\s+Shared library: \[(.+?)\]", out)]


def empty_program(libraries, directory):
    """int main() {} linked against the given libraries (none dropped as unneeded), or None without a compiler."""
    compiler = shutil.which("c++")
    if not compiler:
        return None
    source, program = os.path.join(directory, "empty.cpp"), os.path.join(directory, "empty")
    with open(source, "w") as f:
        f.write("int main() {}\n")
    argv = [compiler, "-O2", source, "-o", program, "-Wl,--no-as-needed"] + ["-l" + lib for lib in libraries]
    subprocess.run(argv, check=True)
    return program


def in_process(pgi, scene, runs):
    """pgi's own account of a run, the best of runs: (steps, ns per step, seconds of the exact phase and the build)."""
    best_build, best_step = float("inf"), float("inf")
    for _ in range(runs):
        out = subprocess.run([pgi, "integrate", scene, "--no-jit", "--json"], capture_output=True, text=True, check=True)
        run = json.loads(out.stdout)
        best_build, best_step = min(best_build, run["build_seconds"]), min(best_step, run["ns_per_step"])
    return run["steps"], best_step, best_build


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--runs", type=int, default=30)
    ap.add_argument("scenes", nargs="*", default=[os.path.join(ROOT, "tools", "scenes", s + ".toml") for s in SCENES])
    a = ap.parse_args()
    pgi = os.path.join(a.build, "pgi")
    with tempfile.TemporaryDirectory() as tmp:
        env_cache = dict(os.environ, PGI_JIT_CACHE=tmp)  # (--no-jit reads no cache; this keeps the user's untouched)
        os.environ.update(env_cache)
        empty = empty_program(linked_libraries(pgi), tmp)
        print("| process | best wall time (ms) |")
        print("| --- | --- |")
        print(f"| /bin/true | {best_of(['/bin/true'], a.runs):.2f} |")
        if empty:
            print(f"| an empty main linked against pgi's libraries | {best_of([empty], a.runs):.2f} |")
        print(f"| pgi --version | {best_of([pgi, '--version'], a.runs):.2f} |")
        print()
        print("| scene | whole process (ms) | exact phase and build (ms) | steps x ns per step (ms) | whole / in-process |")
        print("| --- | --- | --- | --- | --- |")
        for scene in a.scenes:
            whole = best_of([pgi, "integrate", scene, "--no-jit", "--quiet"], a.runs)
            steps, per_step, exact = in_process(pgi, scene, a.runs)
            work = 1e3 * exact + steps * per_step * 1e-6
            name = os.path.splitext(os.path.basename(scene))[0]
            print(f"| {name} ({steps} steps) | {whole:.2f} | {1e3 * exact:.2f} | {steps * per_step * 1e-6:.2f} | "
                  f"{whole / work:.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
