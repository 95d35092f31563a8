#!/usr/bin/env python3
"""Runs the examples of README.md and docs/*.md and compares the output they show (ctest docs_examples).

Conventions (docs/contributing.md, "Examples in the docs"):
- ```python blocks run with this interpreter from the repository root, each on its own; a ```text block right
  after one (only blank lines between) is what it prints, compared as below;
- in ```console / ```sh blocks (and unlabelled ones), each line `$ pgi ...` runs through bash with the built
  pgi first on PATH; the lines after it, up to the next `$` line or the block's end, are its expected output;
- output is compared line by line: words equal, or numbers equal to the digits shown; `~NUMBER` (a timing)
  matches any number; a line ending in `...` matches a line beginning with the text before it; a line `...`
  alone matches any number of lines;
- ```toml blocks are scenes: `pgi check` must accept each;
- `<!-- docs-test: skip -->` before a block skips it; `<!-- docs-test: excerpt examples/F.cpp -->` before a
  block requires the block to appear verbatim in that file (which ctest install_consumer builds and runs).

Usage: run_examples.py --pgi PATH/pgi --pythonpath DIR [--root DIR] [FILE.md ...]
"""
import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

FENCE = re.compile(r"^```(\S*)\s*$")
MARK = re.compile(r"<!--\s*docs-test:\s*(\w+)\s*(\S*)\s*-->")
NUMBER = re.compile(r"^[-+]?(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$")
TOKEN = re.compile(r"~?[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?|\s+|[^\s\d~+-]+|.")


def blocks(path):
    """(language, first line number, lines, marker, closing line number) of every fenced block of a Markdown file."""
    lines = path.read_text().split("\n")
    i, out, marker = 0, [], None
    while i < len(lines):
        m = MARK.search(lines[i])
        if m:
            marker = (m.group(1), m.group(2))
            i += 1
            continue
        f = FENCE.match(lines[i].lstrip())
        if f:  # a fence may be indented (a block inside a list item): its body loses that indentation
            indent = len(lines[i]) - len(lines[i].lstrip())
            lang, start, body = f.group(1), i + 1, []
            i += 1
            while i < len(lines) and not lines[i].lstrip().startswith("```"):
                body.append(lines[i] if not indent else lines[i][indent:] if lines[i][:indent].isspace()
                            else lines[i].lstrip())
                i += 1
            out.append((lang, start + 1, body, marker, i + 1))
            marker = None
        elif lines[i].strip():
            marker = None
        i += 1
    return out


def number_matches(shown, actual):
    """Whether actual, printed to the digits of shown, is shown."""
    try:
        value = float(actual)
        float(shown)
    except ValueError:
        return False
    m = re.match(r"^[-+]?(\d*)\.?(\d*)([eE]([-+]?\d+))?$", shown)
    if not m:
        return False
    decimals = len(m.group(2))
    if m.group(3):
        text = f"{value:.{decimals}e}"
        a, b = text.split("e")
        s_mant, s_exp = shown.lower().split("e")
        return float(a) == float(s_mant) and int(b) == int(s_exp)
    return f"{value:.{decimals}f}" == shown.lstrip("+") or float(f"{value:.{decimals}f}") == float(shown)


def tokens(line):
    return [t for t in TOKEN.findall(line.strip()) if not t.isspace()]


def line_matches(shown, actual):
    if shown.rstrip().endswith("...") and shown.strip() != "...":
        prefix = shown.rstrip()[:-3].rstrip()
        a = tokens(actual)
        s = tokens(prefix)
        return len(a) >= len(s) and all(tok_matches(x, y) for x, y in zip(s, a[:len(s)]))
    s, a = tokens(shown), tokens(actual)
    return len(s) == len(a) and all(tok_matches(x, y) for x, y in zip(s, a))


def tok_matches(shown, actual):
    if shown == actual:
        return True
    if shown.startswith("~") and NUMBER.match(shown[1:]):
        return bool(NUMBER.match(actual.lstrip("~")))
    if NUMBER.match(shown) and NUMBER.match(actual):
        return number_matches(shown, actual)
    return False


def output_matches(expected, actual):
    """Line-by-line match with `...` lines as wildcards (any number of lines)."""
    expected = [e for e in expected]
    actual = [a for a in actual if a.strip() or True]
    while actual and not actual[-1].strip():
        actual.pop()

    def match(i, j):
        if i == len(expected):
            return j == len(actual)
        if expected[i].strip() == "...":
            return any(match(i + 1, k) for k in range(j, len(actual) + 1))
        return j < len(actual) and line_matches(expected[i], actual[j]) and match(i + 1, j + 1)

    return match(0, 0)


def run_console(body, env, root):
    """Runs the `$ pgi` lines of a block; returns a list of failure messages."""
    failures, i = [], 0
    while i < len(body):
        line = body[i]
        if not line.startswith("$ "):
            i += 1
            continue
        command = line[2:]
        expected = []
        i += 1
        while i < len(body) and not body[i].startswith("$ "):
            expected.append(body[i])
            i += 1
        if not command.startswith("pgi "):
            continue
        r = subprocess.run(["bash", "-o", "pipefail", "-c", command], cwd=root, env=env, capture_output=True,
                           text=True, timeout=300)
        if r.returncode != 0 and "| head" not in command:
            failures.append(f"`{command}` exited {r.returncode}: {r.stderr.strip()[-2000:]}")
            continue
        while expected and not expected[-1].strip():
            expected.pop()
        if expected and not output_matches(expected, r.stdout.split("\n")):
            failures.append(f"`{command}`: the output differs from the doc\n--- shown:\n" + "\n".join(expected)
                            + "\n--- printed:\n" + r.stdout.rstrip())
    return failures


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--pgi", required=True, help="the built pgi program")
    ap.add_argument("--pythonpath", required=True, help="the directory holding the built package pgi")
    ap.add_argument("--root", default=str(Path(__file__).resolve().parents[2]))
    ap.add_argument("files", nargs="*")
    args = ap.parse_args()
    root = Path(args.root)
    files = [Path(f) for f in args.files] or [root / "README.md"] + sorted((root / "docs").glob("*.md"))
    env = dict(os.environ)
    env["PATH"] = str(Path(args.pgi).resolve().parent) + os.pathsep + env.get("PATH", "")
    env["PYTHONPATH"] = str(Path(args.pythonpath).resolve()) + os.pathsep + env.get("PYTHONPATH", "")
    env["PGI_JIT_CACHE"] = env.get("PGI_JIT_CACHE", "")  # unchanged; listed for clarity
    if not env["PGI_JIT_CACHE"]:
        del env["PGI_JIT_CACHE"]
    failures, ran = [], 0
    start = time.monotonic()
    for f in files:
        rel = f.resolve().relative_to(root.resolve()) if f.resolve().is_relative_to(root.resolve()) else f
        found = blocks(f)
        text_lines = f.read_text().split("\n")
        for index, (lang, line, body, marker, end) in enumerate(found):
            where = f"{rel}:{line}"
            if marker and marker[0] == "skip":
                continue
            if marker and marker[0] == "excerpt":
                source = (root / marker[1]).read_text()
                if "\n".join(body) not in source:
                    failures.append(f"{where}: the block is not an excerpt of {marker[1]} (copy it from there)")
                ran += 1
                continue
            if lang == "python":
                t0 = time.monotonic()
                r = subprocess.run([sys.executable, "-c", "\n".join(body)], cwd=root, env=env, capture_output=True,
                                   text=True, timeout=300)
                ran += 1
                if r.returncode != 0:
                    failures.append(f"{where}: the Python block failed:\n{r.stderr.strip()[-3000:]}")
                # a ```text block right after (blank lines between) shows what the block prints
                if index + 1 < len(found) and found[index + 1][0] == "text" and found[index + 1][3] is None and \
                        not any(s.strip() for s in text_lines[end:found[index + 1][1] - 2]):
                    expected = found[index + 1][2]
                    if r.returncode == 0 and not output_matches(expected, r.stdout.split("\n")):
                        failures.append(f"{where}: the Python block's output differs from the doc\n--- shown:\n"
                                        + "\n".join(expected) + "\n--- printed:\n" + r.stdout.rstrip())
                print(f"{where}: python, {time.monotonic() - t0:.1f} s", flush=True)
            elif lang == "toml":  # a scene shown in the docs is a valid scene
                with tempfile.TemporaryDirectory() as d:
                    scene = Path(d) / "scene.toml"
                    scene.write_text("\n".join(body) + "\n")
                    r = subprocess.run([str(Path(args.pgi).resolve()), "check", str(scene)], cwd=root, env=env,
                                       capture_output=True, text=True, timeout=300)
                ran += 1
                if r.returncode != 0:
                    failures.append(f"{where}: the scene is refused by pgi check: {r.stderr.strip()[-2000:]}")
            elif lang in ("console", "sh", "") and any(l.startswith("$ pgi ") for l in body):
                t0 = time.monotonic()
                msgs = run_console(body, env, root)
                ran += 1
                failures += [f"{where}: {m}" for m in msgs]
                print(f"{where}: console, {time.monotonic() - t0:.1f} s", flush=True)
    # no commit hashes in the user's documents (the history is CHANGELOG.md's)
    hashes = re.compile(r"\b(?=[0-9a-f]*[a-f])(?=[0-9a-f]*[0-9])[0-9a-f]{7,40}\b")
    for f in files:
        for n, text in enumerate(f.read_text().split("\n"), 1):
            for h in hashes.findall(text):
                failures.append(f"{f.name}:{n}: '{h}' looks like a commit hash: history goes to CHANGELOG.md")
    print(f"{ran} examples run in {time.monotonic() - start:.1f} s")
    for msg in failures:
        print("FAIL " + msg, file=sys.stderr)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
