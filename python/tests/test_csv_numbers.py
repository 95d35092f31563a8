"""Every CSV pgi writes (a run's trajectory, a section's crossings, an ensemble's table) prints its numbers in the
shortest form that reads back to the same double, as the JSON does: each field equals the library's double bit for
bit and is no longer than Python's repr of it."""
import csv

import numpy as np

import pgi
from conftest import SCENES, cli, cli_json

RB = SCENES / "rigid_body.toml"


def read_csv(path):
    with open(path, encoding="utf-8") as f:
        rows = list(csv.reader(line for line in f if not line.startswith("#")))
    return rows[0], rows[1:]


def values(rows, columns):
    """The fields of the given columns as doubles, each checked to be in the shortest form that reads back."""
    out = []
    for row in rows:
        out.append([])
        for c in columns:
            v = float(row[c])
            assert len(row[c]) <= len(repr(v)), row[c]
            out[-1].append(v)
    return np.array(out)


def test_the_trajectory_csv_holds_the_library_s_doubles_in_the_shortest_form(tmp_path):
    cli("integrate", RB, "--t-end", 5, "--csv", tmp_path / "run.csv")
    header, rows = read_csv(tmp_path / "run.csv")
    assert header == ["t", "x1", "x2", "x3", "H", "C1"]
    table = values(rows, range(len(header)))
    r = pgi.Scheme.from_toml(RB).integrate(t_end=5)
    assert np.array_equal(table[:, 0], r.t) and np.array_equal(table[:, 1:4], r.x)
    assert rows[0][1:4] == ["0.4535961214255773", "0", "0.8912073600614354"]  # x0 as the scene writes it
    assert max(len(f) for row in rows for f in row) < 24


def test_the_section_csv_holds_the_crossings_of_the_json_in_the_shortest_form(tmp_path):
    j = cli_json("section", RB, "--event", "x1", "--t-end", 30, "--csv", tmp_path / "section.csv")
    header, rows = read_csv(tmp_path / "section.csv")
    assert header == ["t", "x1", "x2", "x3"] and len(rows) == j["count"] > 0
    table = values(rows, range(4))
    assert np.array_equal(table[:, 0], [c["t"] for c in j["crossings"]])
    assert np.array_equal(table[:, 1:], [c["x"] for c in j["crossings"]])


def test_the_ensemble_csv_holds_the_npy_doubles_in_the_shortest_form(tmp_path):
    X0 = np.random.default_rng(11).uniform(-1, 1, size=(7, 3))
    np.save(tmp_path / "X0.npy", X0)
    cli("ensemble", RB, "--states", tmp_path / "X0.npy", "--t-end", 2, "--out", tmp_path / "e")
    header, rows = read_csv(tmp_path / "e.csv")
    numeric = [c for c, name in enumerate(header) if name not in ("status",)]
    table = dict(zip((header[c] for c in numeric), values(rows, numeric).T))
    assert np.array_equal(np.column_stack([table[f"x{i}_0"] for i in (1, 2, 3)]), X0)
    assert np.array_equal(np.column_stack([table[f"x{i}"] for i in (1, 2, 3)]), np.load(tmp_path / "e.x.npy"))
    errors = np.load(tmp_path / "e.errors.npy")
    assert np.array_equal(table["energy_error"], errors[:, 0])
    assert np.array_equal(table["casimir_error_1"], errors[:, 1])
