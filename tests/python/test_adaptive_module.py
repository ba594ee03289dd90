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


# An adaptive Oren-Nayar direct term over (theta_i, theta_o, phi_d) at
# sigma = 30 degrees, refined to 2e-2 absolute (about a second): a table
# over directions, which bind() serves.
OREN_NAYAR_ADAPTIVE = """
model = "oren-nayar"
[parameters]
sigma = 30.0
nodes = 8
[[axes]]
name = "theta_i"
range = [0.0, 80.0]
count = 5
[[axes]]
name = "theta_o"
range = [0.0, 90.0]
count = 5
[[axes]]
name = "phi_d"
range = [0.0, 180.0]
count = 5
[[tables]]
quantity = "brdf_direct"
[integration]
method = "quadrature"
[output]
type = "float64"
"""


@pytest.fixture(scope="module")
def adaptive_brdf(tables):
    spec = tables.directory / "on_adaptive.toml"
    spec.write_text(OREN_NAYAR_ADAPTIVE)
    out = tables.directory / "on_adaptive.h5"
    if not out.exists():
        r = tables.run("generate", spec, "--representation", "adaptive", "--accuracy", "2e-2", "--abs",
                       "--max-values", "6000", "-q", "-o", out, check=False)
        assert r.returncode == 0, r.stderr
    return str(out)


def hemisphere_directions(rng, n, max_theta=90.0):
    theta = np.radians(rng.uniform(0, max_theta, n))
    phi = rng.uniform(0, 2 * np.pi, n)
    return np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], axis=1)


def test_bound_adaptive_eval_is_the_independent_reader_at_the_directions_angles(tables, adaptive_brdf):
    # The oracle: read_adaptive.py (docs/format.md alone) at the angles
    # computed here from the directions (theta from z, phi_d = phi_o - phi_i
    # folded to [0, 180]), and `brdftab query` at the same points.
    import subprocess
    pytest.importorskip("h5py")
    table = brdftab.open(adaptive_brdf).tables["brdf_direct"]
    assert table.representation == "adaptive"
    bound = table.bind()
    rng = np.random.default_rng(5)
    wi, wo = hemisphere_directions(rng, 400, 80.0), hemisphere_directions(rng, 400)
    theta_i = np.degrees(np.arccos(wi[:, 2]))
    theta_o = np.degrees(np.arccos(wo[:, 2]))
    phi = np.degrees(np.arctan2(wo[:, 1], wo[:, 0]) - np.arctan2(wi[:, 1], wi[:, 0]))
    phi_d = np.abs((phi + 180.0) % 360.0 - 180.0)
    p = {"theta_i": theta_i, "theta_o": theta_o, "phi_d": phi_d}
    csv_path = tables.directory / "adaptive_bound_points.csv"
    write_points(csv_path, p)
    here = os.path.dirname(os.path.abspath(__file__))
    r = subprocess.run([sys.executable, os.path.join(here, "read_adaptive.py"), adaptive_brdf, "brdf_direct",
                        str(csv_path)], capture_output=True, text=True, check=True)
    expected = query_column(r.stdout)
    got = bound.eval(wi, wo)
    assert got.shape == (400,)
    # The library's angles differ from numpy's by rounding only.
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-10)
    q = tables.run("query", adaptive_brdf, "--table", "brdf_direct", "--points", csv_path)
    np.testing.assert_allclose(got, query_column(q.stdout), rtol=0, atol=1e-10)
    assert np.ptp(expected) > 0.05
    # Broadcasting: one wi against many wo, and a single pair as a float.
    one = bound.eval(wi[0], wo)
    np.testing.assert_allclose(one, bound.eval(np.broadcast_to(wi[0], wo.shape), wo), rtol=0, atol=0)
    assert isinstance(bound.eval(wi[0], wo[0]), float)


def hemisphere_quadrature(nm, nphi):
    """Midpoints of an nm x nphi grid in (mu_o, phi_o) over the upper
    hemisphere: directions (nm * nphi, 3) and the solid angle of a cell."""
    mu = (np.arange(nm) + 0.5) / nm
    phi = 2 * np.pi * (np.arange(nphi) + 0.5) / nphi
    m, f = np.meshgrid(mu, phi, indexing="ij")
    s = np.sqrt(1 - m * m)
    w = np.stack([s * np.cos(f), s * np.sin(f), m], axis=-1).reshape(-1, 3)
    return w, (1.0 / nm) * (2 * np.pi / nphi)


@pytest.mark.parametrize("theta_i", [0.0, 35.0, 70.0])
def test_bound_adaptive_sampling_follows_its_pdf(adaptive_brdf, theta_i):
    bound = brdftab.open(adaptive_brdf).tables["brdf_direct"].bind()
    assert bound.can_sample
    t = np.radians(theta_i)
    wi = np.array([np.sin(t) * np.cos(0.4), np.sin(t) * np.sin(0.4), np.cos(t)])
    # The pdf is a density: it integrates to 1 over the hemisphere.
    w, cell = hemisphere_quadrature(400, 400)
    assert np.sum(bound.pdf(wi, w)) * cell == pytest.approx(1.0, abs=1e-2)
    # Samples: pdf and weight are the bound table's pdf and f |cos| / pdf.
    n = 1_000_000
    u = np.random.default_rng(int(theta_i) + 1).random((n, 2))
    wo, weight, pdf = bound.sample(wi, u)
    np.testing.assert_allclose(np.linalg.norm(wo, axis=1), 1.0, rtol=0, atol=1e-12)
    assert np.all(wo[:, 2] >= 0) and np.all(pdf > 0)
    np.testing.assert_allclose(pdf, bound.pdf(wi, wo), rtol=1e-9)
    np.testing.assert_allclose(weight, bound.eval(wi, wo) * wo[:, 2] / pdf, rtol=1e-9)
    # Histogram over 10 x 12 cells in (mu_o, phi_o - phi_i) against the
    # pdf's cell integrals (midpoint rule, 60 x 60 per cell): chi^2 with
    # 119 degrees of freedom (mean 119, sd 15.4) below 119 + 6 sd.
    nm, nphi = 10, 12
    mu_bin = np.minimum((wo[:, 2] * nm).astype(int), nm - 1)
    rel = (np.arctan2(wo[:, 1], wo[:, 0]) - 0.4) % (2 * np.pi)
    phi_bin = np.minimum((rel / (2 * np.pi) * nphi).astype(int), nphi - 1)
    observed = np.bincount(mu_bin * nphi + phi_bin, minlength=nm * nphi)
    fine_m, fine_p = nm * 60, nphi * 60
    w, cell = hemisphere_quadrature(fine_m, fine_p)
    # Rotate the grid's phi by wi's azimuth (0.4) so bins are relative to it.
    c, s = np.cos(0.4), np.sin(0.4)
    w = np.stack([c * w[:, 0] - s * w[:, 1], s * w[:, 0] + c * w[:, 1], w[:, 2]], axis=1)
    density = bound.pdf(wi, w).reshape(nm, 60, nphi, 60).sum(axis=(1, 3)) * cell
    expected = n * density.reshape(-1)
    assert expected.sum() == pytest.approx(n, rel=1e-2)
    chi2 = np.sum((observed - expected) ** 2 / expected)
    assert chi2 < 119 + 6 * 15.4, (chi2, observed, expected)
    # The control: the same counts against a density tilted by 10 % along
    # mu_o fail.
    tilted = expected * (1 + 0.1 * (np.repeat(np.arange(nm), nphi) / (nm - 1) - 0.5))
    tilted *= n / tilted.sum()
    assert np.sum((observed - tilted) ** 2 / tilted) > 119 + 6 * 15.4
    # The weights' mean estimates the albedo, integral of f cos over the
    # hemisphere, computed here by the midpoint rule from eval.
    w, cell = hemisphere_quadrature(400, 400)
    albedo = np.sum(bound.eval(wi, w) * w[:, 2]) * cell
    assert abs(np.mean(weight) - albedo) < 5 * np.std(weight) / np.sqrt(n) + 1e-3 * albedo


def test_bound_adaptive_refusals(adaptive_brdf):
    table = brdftab.open(adaptive_brdf).tables["brdf_direct"]
    with pytest.raises(brdftab.InputError, match="linearly only"):
        table.bind(interpolation="cubic")
    with pytest.raises(brdftab.InputError, match="interpolation must be"):
        table.bind(interpolation="quintic")
