# The Python module against the CLI (`brdftab query`, same library, separate
# process and parser), against h5py (an independent reader of the stored
# values), and its sampler against its own density and the table values.
import csv
import io
import math

import numpy as np
import pytest

import brdftab
from conftest import OREN_NAYAR, ROUGH_DIELECTRIC


@pytest.fixture(scope="module")
def oren_nayar(tables):
    return tables.generate("oren_nayar", OREN_NAYAR)


@pytest.fixture(scope="module")
def rough_dielectric(tables):
    return tables.generate("rough_dielectric", ROUGH_DIELECTRIC)


def random_points(table, count, seed, margin=0.05):
    """Random coordinates over each axis' range, a few a little outside it
    (clamped by both the module and the CLI)."""
    rng = np.random.default_rng(seed)
    points = {}
    for a in table.axes:
        span = a.max - a.min
        points[a.name] = rng.uniform(a.min - margin * span, a.max + margin * span, count)
    rec = table.recombination
    if rec:
        points[rec["parameter"]] = rng.uniform(*rec["range"], count)
    return points


def cli_query(tables, path, name, points, *options):
    """Values (and stderr column, or None) of `brdftab query --points`."""
    names = list(points)
    text = ",".join(names) + "\n"
    for k in range(len(points[names[0]])):
        text += ",".join("%.17g" % points[n][k] for n in names) + "\n"
    csv_path = tables.directory / f"points_{name}.csv"
    csv_path.write_text(text)
    r = tables.run("query", path, "--table", name, "--points", csv_path, *options)
    rows = list(csv.DictReader(io.StringIO(r.stdout)))
    value = np.array([float(row["value"]) for row in rows])
    se = np.array([float(row["stderr"]) for row in rows]) if "stderr" in rows[0] else None
    return value, se


@pytest.mark.parametrize("which,name", [("oren_nayar", "brdf"), ("oren_nayar", "brdf_direct"),
                                        ("rough_dielectric", "bsdf")])
@pytest.mark.parametrize("interpolation", ["linear", "cubic"])
def test_eval_equals_cli_query(request, tables, which, name, interpolation):
    path = request.getfixturevalue(which)
    table = brdftab.open(path).tables[name]
    points = random_points(table, 60, seed=hash((which, name)) % 1000)
    options = ["--cubic"] if interpolation == "cubic" else []
    expected, expected_se = cli_query(tables, path, name, points, *options)
    got = table.eval(interpolation=interpolation, **points)
    assert got.shape == expected.shape
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-12)
    if expected_se is not None:
        got_se = table.eval_stderr(**{n: points[n] for n in table.coordinate_names})
        np.testing.assert_allclose(got_se, expected_se, rtol=1e-12, atol=1e-12)


def test_values_are_a_view_of_the_stored_table(oren_nayar):
    h5py = pytest.importorskip("h5py")
    table = brdftab.open(oren_nayar).tables["brdf_direct"]
    values = table.values
    assert values.shape == tuple(a.count for a in table.axes)
    assert not values.flags.writeable and not values.flags.owndata
    assert np.shares_memory(values, table.values)  # the same buffer, no copy
    with h5py.File(oren_nayar, "r") as f:
        np.testing.assert_array_equal(values, f["brdf_direct"]["value"][...])
        np.testing.assert_array_equal(table.stderr, f["brdf_direct"]["stderr"][...])
        for a in table.axes:
            np.testing.assert_array_equal(a.values, f["brdf_direct"][a.name][...])
    # Interpolation passes through the nodes.
    grid = np.meshgrid(*[a.values for a in table.axes], indexing="ij")
    at_nodes = table.eval(**{a.name: g for a, g in zip(table.axes, grid)})
    np.testing.assert_allclose(at_nodes, values, rtol=1e-13, atol=0)


def test_broadcasting_and_scalars(oren_nayar):
    table = brdftab.open(oren_nayar).tables["brdf"]
    v = table.eval(theta_i=30.0, theta_o=40.0, phi_d=90.0, sigma=20.0, rho=0.5)
    assert isinstance(v, float)
    grid = table.eval(theta_i=30.0, theta_o=np.array([10.0, 40.0])[:, None],
                      phi_d=np.array([0.0, 90.0, 180.0]), sigma=20.0, rho=0.5)
    assert grid.shape == (2, 3)
    assert grid[1, 1] == v
    # Recombination: rho * direct + rho^2 * interreflection (docs/lookup.md).
    f = brdftab.open(oren_nayar)
    d = f.tables["brdf_direct"].eval(theta_i=30.0, theta_o=40.0, phi_d=90.0, sigma=20.0)
    i2 = f.tables["brdf_interreflection"].eval(theta_i=30.0, theta_o=40.0, phi_d=90.0, sigma=20.0)
    assert v == pytest.approx(0.5 * d + 0.25 * i2, rel=1e-14)


def sphere_directions(rng, n):
    w = rng.normal(size=(n, 3))
    return w / np.linalg.norm(w, axis=1, keepdims=True)


def test_bound_eval_is_eval_at_the_directions_angles(oren_nayar):
    table = brdftab.open(oren_nayar).tables["brdf"]
    bsdf = table.bind(sigma=25.0, rho=0.7)
    rng = np.random.default_rng(7)
    wi, wo = sphere_directions(rng, 500), sphere_directions(rng, 500)
    wi[:, 2], wo[:, 2] = np.abs(wi[:, 2]), np.abs(wo[:, 2])
    # Angles computed here from the definitions (docs/lookup.md): theta from
    # z, phi_d = phi_o - phi_i folded to [0, 180].
    theta_i = np.degrees(np.arccos(wi[:, 2]))
    theta_o = np.degrees(np.arccos(wo[:, 2]))
    phi = np.degrees(np.arctan2(wo[:, 1], wo[:, 0]) - np.arctan2(wi[:, 1], wi[:, 0]))
    phi_d = np.abs((phi + 180.0) % 360.0 - 180.0)
    expected = table.eval(theta_i=theta_i, theta_o=theta_o, phi_d=phi_d, sigma=25.0, rho=0.7)
    np.testing.assert_allclose(bsdf.eval(wi, wo), expected, rtol=1e-10, atol=1e-14)


@pytest.mark.parametrize("which,name,params", [
    ("oren_nayar", "brdf", {"sigma": 20.0, "rho": 0.8}),
    ("rough_dielectric", "bsdf", {"alpha": 0.5}),   # reflection and transmission
])
def test_sample_pdf_eval_consistent(request, which, name, params):
    table = brdftab.open(request.getfixturevalue(which)).tables[name]
    bsdf = table.bind(**params)
    rng = np.random.default_rng(11)
    n = 20000
    for theta_deg in (0.0, 23.0, 61.0, 78.0):
        t = math.radians(theta_deg)
        wi = np.array([math.sin(t) * math.cos(0.4), math.sin(t) * math.sin(0.4), math.cos(t)])
        wo, weight, pdf = bsdf.sample(wi, rng.random((n, 2)))
        np.testing.assert_allclose(np.linalg.norm(wo, axis=1), 1.0, rtol=1e-12)
        assert np.all(pdf > 0)
        # pdf() of the sampled direction is the density sample() reports.
        np.testing.assert_allclose(bsdf.pdf(wi, wo), pdf, rtol=1e-9)
        # weight = f |cos theta_o| / pdf.
        np.testing.assert_allclose(weight, bsdf.eval(wi, wo) * np.abs(wo[:, 2]) / pdf,
                                   rtol=1e-9, atol=1e-15)
        # The density integrates to 1 over the sphere, and the sampled
        # estimate of the albedo agrees with uniform sampling of f |cos|.
        m = 200000
        w = sphere_directions(rng, m)
        p_uniform = bsdf.pdf(wi, w) * 4 * math.pi
        assert abs(p_uniform.mean() - 1) < 5 * p_uniform.std() / math.sqrt(m)
        f_uniform = bsdf.eval(wi, w) * np.abs(w[:, 2]) * 4 * math.pi
        if table.axes[1].max <= 90:  # a reflection table: f = 0 below the horizon
            f_uniform[w[:, 2] < 0] = 0
        se = math.hypot(f_uniform.std() / math.sqrt(m), weight.std() / math.sqrt(n))
        assert abs(f_uniform.mean() - weight.mean()) < 5 * se


def cli_error(tables, *args):
    r = tables.run(*args, check=False)
    assert r.returncode == 2, r.stderr
    prefix = "brdftab: error: "
    line = [ln for ln in r.stderr.splitlines() if ln.startswith(prefix)][0]
    return line[len(prefix):]


def test_errors_carry_the_cli_messages(tables, oren_nayar):
    missing = str(tables.directory / "no-such-file.h5")
    with pytest.raises(brdftab.InputError) as e:
        brdftab.open(missing)
    assert str(e.value) == cli_error(tables, "query", missing, "--table", "brdf", "theta_i=1")

    f = brdftab.open(oren_nayar)
    with pytest.raises(brdftab.InputError) as e:
        f.tables["nope"]
    assert str(e.value) == cli_error(tables, "query", oren_nayar, "--table", "nope", "theta_i=1")

    table = f.tables["brdf"]
    good = dict(theta_i=30.0, theta_o=40.0, phi_d=90.0, sigma=20.0, rho=0.5)
    cases = [
        (dict(theta_i=30.0), [], "theta_i=30"),
        (dict(good, colour=1.0), [], "colour=1"),
        (dict(good, theta_o=95.0), ["--reject"], "theta_o=95"),
        (dict(good, rho=1.5), ["--reject"], "rho=1.5"),
    ]
    for coords, options, changed in cases:
        with pytest.raises(brdftab.InputError) as e:
            table.eval(out_of_range="reject" if options else "clamp", **coords)
        args = [f"{k}={v!r}" for k, v in coords.items()]
        expected = cli_error(tables, "query", oren_nayar, "--table", "brdf", *args, *options)
        assert str(e.value) == expected, changed
        assert isinstance(e.value, ValueError) and isinstance(e.value, brdftab.Error)

    with pytest.raises(brdftab.InputError, match="parameter 'sigma' is missing"):
        table.bind(rho=0.5)
    with pytest.raises(brdftab.InputError, match="interpolation must be"):
        table.eval(interpolation="quintic", **good)
    with pytest.raises(brdftab.InputError, match="stores no standard errors"):
        table.eval_stderr(**good)
    # A table whose theta_o stops short of the horizon cannot be sampled.
    short = tables.generate("short", OREN_NAYAR.replace("range = [0.0, 90.0]", "range = [0.0, 70.0]"))
    bsdf = brdftab.open(short).tables["brdf"].bind(sigma=20.0, rho=0.5)
    assert not bsdf.can_sample
    with pytest.raises(brdftab.Error, match="sampling needs the theta_o axis") as e:
        bsdf.sample([0, 0, 1], [0.5, 0.5])
    assert str(e.value) == bsdf.sampling_error


def test_to_xarray(oren_nayar):
    pytest.importorskip("xarray")
    table = brdftab.open(oren_nayar).tables["brdf_direct"]
    da = brdftab.to_xarray(table)
    assert da.dims == tuple(a.name for a in table.axes)
    np.testing.assert_array_equal(da.values, table.values)
    np.testing.assert_array_equal(da.coords["theta_o"].values, table.axes[1].values)
    assert da.attrs["units"] == table.units


# ---- clamping warns, as `brdftab query` does; "reject" still raises.

def test_clamped_coordinates_warn_once_per_call(rough_dielectric):
    import warnings
    t = brdftab.open(rough_dielectric).tables["bsdf"]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        t.eval(mu_i=0.5, theta_o=30, phi_d=90, alpha=0.5)           # inside: no warning
        assert caught == []
        t.eval(mu_i=0.5, theta_o=30, phi_d=90, alpha=0.9)           # alpha above [0.2, 0.8]
        t.eval(mu_i=[0.5, 0.6, 0.7], theta_o=30, phi_d=90, alpha=[0.1, 0.5, 0.9])
        t.eval(mu_i=0.5, theta_o=30, phi_d=-90, alpha=0.5)          # phi_d folds: not clamped
    assert len(caught) == 2, [str(w.message) for w in caught]
    assert all(issubclass(w.category, RuntimeWarning) for w in caught)
    assert "alpha = 0.9 is outside [0.2, 0.8]" in str(caught[0].message)
    assert "clamped (out_of_range='reject'" in str(caught[0].message)
    assert "alpha is outside [0.2, 0.8] at 2 of 3 points (first 0.1)" in str(caught[1].message)
    # The clamped value is the edge's.
    assert t.eval(mu_i=0.5, theta_o=30, phi_d=90, alpha=0.9) == t.eval(mu_i=0.5, theta_o=30, phi_d=90, alpha=0.8)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with pytest.raises(brdftab.InputError, match="alpha"):
            t.eval(mu_i=0.5, theta_o=30, phi_d=90, alpha=0.9, out_of_range="reject")
        t.bind(alpha=0.95)
    assert len(caught) == 1 and "alpha = 0.95 is outside" in str(caught[0].message)


# ---- the certificate: the error between nodes, next to the stored stderr.

def test_certificate_read_as_stored(tables, oren_nayar):
    import h5py
    t = brdftab.open(oren_nayar).tables["brdf_direct"]
    assert t.certificate is None
    assert "no certificate" in repr(t)
    certified = tables.directory / "certified.h5"
    certified.write_bytes(open(oren_nayar, "rb").read())
    r = tables.run("certify", certified, "--table", "brdf_direct", "--accuracy", "1", "--store", "-q",
                   check=False)
    assert r.returncode == 0, r.stderr
    c = brdftab.open(certified).tables["brdf_direct"].certificate
    with h5py.File(certified, "r") as f:   # an independent reader of the attributes
        g = f["brdf_direct"]
        assert c["max_error"] == g.attrs["certificate_max_error"]
        assert c["rms_error"] == g.attrs["certificate_rms_error"]
        assert c["target"] == 1 and c["passed"] is True
        assert c["measure"] == "relative" and c["interpolation"] == "linear"
    assert f"certified max total error {c['max_error']:.3g} relative" in repr(
        brdftab.open(certified).tables["brdf_direct"])


def test_batch_results_do_not_depend_on_threads(oren_nayar, rough_dielectric):
    """The batch loops split large arrays over threads: every number must be
    bit-identical to the one-thread result, and an error must be the first
    bad point's, as in a serial loop."""
    rng = np.random.default_rng(11)
    n = 40_000  # several chunks of the threaded loops
    t = brdftab.open(rough_dielectric).tables["bsdf"]
    coords = dict(mu_i=rng.uniform(0, 1, n), theta_o=rng.uniform(0, 180, n),
                  phi_d=rng.uniform(0, 180, n), alpha=rng.uniform(0.2, 0.8, n))
    b = brdftab.open(oren_nayar).tables["brdf"].bind(sigma=25.0, rho=0.7)
    wi = np.stack([np.full(n, 0.6), np.zeros(n), np.full(n, 0.8)], axis=1)
    u = rng.random((n, 2))
    wo = b.sample(wi, u)[0]
    results = {}
    try:
        for threads in (1, 3):
            brdftab.set_threads(threads)
            assert brdftab.threads() == threads
            results[threads] = (t.eval(**coords), b.eval(wi, wo), b.pdf(wi, wo), *b.sample(wi, u))
            bad = dict(coords, alpha=coords["alpha"].copy())
            bad["alpha"][[20_000, 35_000]] = [0.95, 0.99]  # in the 2nd and 3rd chunk
            with pytest.raises(brdftab.InputError, match="0.95"):
                t.eval(out_of_range="reject", **bad)
    finally:
        brdftab.set_threads(0)  # the default: one per hardware thread
    for one, many in zip(results[1], results[3]):
        assert np.array_equal(one, many)
