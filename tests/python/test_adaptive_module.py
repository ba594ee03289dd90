# The Python module on an adaptive table (docs/adaptive.md): eval and batch
# eval against `brdftab query` (the CLI's own reader, a separate code path
# through the same patch interpolation) to 1e-12, and against the
# independent reader written from docs/format.md (read_adaptive.py, numpy +
# h5py); the refusals (cubic, bind of an albedo table, reject) carry clear
# messages.
import csv
import io
import json
import os
import pathlib
import sys

import numpy as np
import pytest

import brdftab

# A small rough-dielectric albedo from inside, refined to 3e-2 (seconds); the
# spec the CLI tests refine too.
INSIDE = (pathlib.Path(__file__).resolve().parents[1] / "data" / "adaptive_inside.toml").read_text()


@pytest.fixture(scope="module")
def adaptive(tables):
    spec = tables.directory / "inside_adaptive.toml"
    spec.write_text(INSIDE)
    out = tables.directory / "inside_adaptive.h5"
    if not out.exists():
        r = tables.run("generate", spec, "--representation", "adaptive", "--accuracy", "3e-2", "--abs",
                       "--max-values", "4000", "-q", "-o", out, check=False)
        assert r.returncode == 0, r.stderr
    return str(out)


def points(count, seed):
    # Some coordinates a little outside the ranges: clamped by both readers.
    rng = np.random.default_rng(seed)
    return {"mu_i": rng.uniform(-1.02, -0.01, count),
            "alpha": 10 ** rng.uniform(-1.4, 0.02, count),
            "eta": rng.uniform(1.19, 2.01, count)}


def write_points(path, p):
    names = list(p)
    text = ",".join(names) + "\n"
    for k in range(len(p[names[0]])):
        text += ",".join("%.17g" % p[n][k] for n in names) + "\n"
    path.write_text(text)


def query_column(text):
    return np.array([float(row["value"]) for row in csv.DictReader(io.StringIO(text))])


def test_batch_eval_equals_cli_query(tables, adaptive):
    table = brdftab.open(adaptive).tables["albedo_t_inside"]
    assert table.representation == "adaptive"
    p = points(3000, 11)
    csv_path = tables.directory / "adaptive_points.csv"
    write_points(csv_path, p)
    r = tables.run("query", adaptive, "--table", "albedo_t_inside", "--points", csv_path)
    expected = query_column(r.stdout)
    with pytest.warns(RuntimeWarning, match="clamped"):
        got = table.eval(**p)
    assert got.shape == (3000,)
    assert np.max(np.abs(got - expected)) <= 1e-12
    # The values are not all alike (the comparison is not trivially met).
    assert np.ptp(expected) > 0.1


def test_eval_equals_independent_reader(tables, adaptive):
    # read_adaptive.py follows docs/format.md alone.
    import subprocess
    pytest.importorskip("h5py")
    table = brdftab.open(adaptive).tables["albedo_t_inside"]
    p = points(500, 12)
    csv_path = tables.directory / "adaptive_points_reader.csv"
    write_points(csv_path, p)
    here = os.path.dirname(os.path.abspath(__file__))
    r = subprocess.run([sys.executable, os.path.join(here, "read_adaptive.py"), adaptive, "albedo_t_inside",
                        str(csv_path)], capture_output=True, text=True, check=True)
    expected = query_column(r.stdout)
    with pytest.warns(RuntimeWarning):
        got = table.eval(**p)
    assert np.max(np.abs(got - expected)) <= 1e-12


def test_scalar_eval_and_metadata(tables, adaptive):
    table = brdftab.open(adaptive).tables["albedo_t_inside"]
    r = tables.run("query", adaptive, "--table", "albedo_t_inside", "--json", "mu_i=-0.5", "alpha=0.2",
                   "eta=1.5")
    q = json.loads(r.stdout)
    v = table.eval(mu_i=-0.5, alpha=0.2, eta=1.5)
    assert isinstance(v, float) and abs(v - q["value"]) <= 1e-12
    # Broadcasting as for tensor tables.
    row = table.eval(mu_i=[-0.5, -0.9], alpha=0.2, eta=1.5)
    assert row.shape == (2,) and abs(row[0] - v) <= 1e-15
    assert table.coordinate_names == ["mu_i", "alpha", "eta"]
    assert table.values.ndim == 1 and not table.values.flags.writeable
    assert table.certificate is not None and table.certificate["passed"]
    assert "adaptive" in repr(table)
    if table.stderr is not None:
        se = table.eval_stderr(mu_i=-0.5, alpha=0.2, eta=1.5)
        assert se >= 0


def test_refusals_are_clear(adaptive):
    table = brdftab.open(adaptive).tables["albedo_t_inside"]
    with pytest.raises(brdftab.InputError, match="linearly only"):
        table.eval(interpolation="cubic", mu_i=-0.5, alpha=0.2, eta=1.5)
    with pytest.raises(brdftab.InputError, match="interpolation must be"):
        table.eval(interpolation="quintic", mu_i=-0.5, alpha=0.2, eta=1.5)
    with pytest.raises(brdftab.InputError, match="outside"):
        table.eval(out_of_range="reject", mu_i=-1.5, alpha=0.2, eta=1.5)
    with pytest.raises(brdftab.InputError, match="missing coordinate 'eta'"):
        table.eval(mu_i=-0.5, alpha=0.2)
    with pytest.raises(brdftab.InputError, match="'colour' is not a coordinate"):
        table.eval(mu_i=-0.5, alpha=0.2, eta=1.5, colour=1)
    # An albedo table has no directions to bind over (the message of the
    # tensor tables' bind).
    with pytest.raises(brdftab.InputError, match="direction-level lookup needs axes"):
        table.bind(alpha=0.2, eta=1.5)
    with pytest.raises(brdftab.InputError, match="is adaptive"):
        brdftab.to_xarray(table)
