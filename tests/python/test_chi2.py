# chi^2 goodness-of-fit of the table sampler (BoundTable.sample against
# BoundTable.pdf) with exact expected counts, and the uniformity of its
# p-values over independent seeds.  CTest label `chi2` (docs/python.md,
# "chi^2 tests of the sampler"):
#
#     ctest --test-dir build -L chi2
#
# The sampler's density is piecewise constant in (cos theta_o, phi_o) at a
# fixed wi: per theta_i node one constant per table cell, mixed with the
# theta_i interpolation weights (host/lookup/sample.cpp).  On every
# sub-rectangle cut out by both the chi^2 cell edges and the table's node
# lines it is constant, so its integral over a chi^2 cell is the sum of
# (value at the sub-rectangle's centre) x (area): exact, whatever the
# alignment of the two grids.  A quadrature rule that evaluates the pdf at
# points inside each chi^2 cell (Mitsuba's ChiSquareTest) is biased where a
# table boundary crosses a cell; test_chi2_mitsuba.py measures that.
#
# Each (model, theta_i) draws SEEDS independent sample sets on a table whose
# nodes are not aligned with the chi^2 cells, and the Kolmogorov-Smirnov
# test must accept the uniformity of the SEEDS p-values (p > 0.01).  The
# same histograms against a density tilted by 5 % (p'(w) ~ p(w) (1 + 0.05
# cos theta_o)) must be rejected: the test can fail.
import math

import numpy as np
import pytest

import brdftab

SEEDS = 40
SAMPLES = 250_000          # per seed
RES = 16                   # chi^2 cells: RES in cos theta over [-1, 1], 2 RES in phi
POOL = 5.0                 # cells with a smaller expected count are pooled
TILT = 0.05


# ---- statistics (closed forms, no scipy) ----------------------------------
def gamma_q(a, x):
    """Regularised upper incomplete gamma function Q(a, x) = Gamma(a, x) / Gamma(a):
    the power series of P for x < a + 1, else the continued fraction of Q
    (modified Lentz)."""
    if x <= 0:
        return 1.0
    log_prefactor = -x + a * math.log(x) - math.lgamma(a)
    if x < a + 1:
        term = total = 1.0 / a
        n = a
        while abs(term) > 1e-16 * abs(total):
            n += 1
            term *= x / n
            total += term
        return max(0.0, 1.0 - total * math.exp(log_prefactor))
    tiny = 1e-300
    b = x + 1 - a
    c = 1 / tiny
    d = 1 / b
    h = d
    for i in range(1, 10_000):
        an = -i * (i - a)
        b += 2
        d = an * d + b
        d = tiny if abs(d) < tiny else d
        c = b + an / c
        c = tiny if abs(c) < tiny else c
        d = 1 / d
        delta = d * c
        h *= delta
        if abs(delta - 1) < 1e-16:
            break
    return math.exp(log_prefactor) * h


def chi2_pvalue(observed, expected, pool=POOL):
    """Pearson's chi^2 with cells of expected count < pool merged (in order of
    increasing expected count, as Mitsuba's chi2 does); p = Q(dof / 2, chi2 / 2).
    0 when a cell of zero expected count holds samples."""
    observed = np.asarray(observed, dtype=np.float64).ravel()
    expected = np.asarray(expected, dtype=np.float64).ravel()
    if np.any((expected <= 0) & (observed > 0)):
        return 0.0
    keep = expected > 0
    order = np.argsort(expected[keep], kind="stable")
    obs, exp = observed[keep][order], expected[keep][order]
    chi2, cells = 0.0, 0
    acc_o = acc_e = 0.0
    for o, e in zip(obs, exp):
        if e < pool or acc_e > 0:
            acc_o += o
            acc_e += e
            if acc_e >= pool:
                chi2 += (acc_o - acc_e) ** 2 / acc_e
                cells += 1
                acc_o = acc_e = 0.0
        else:
            chi2 += (o - e) ** 2 / e
            cells += 1
    if acc_e > 0:
        chi2 += (acc_o - acc_e) ** 2 / acc_e
        cells += 1
    dof = cells - 1
    return gamma_q(dof / 2, chi2 / 2)


def ks_uniform_pvalue(values):
    """Kolmogorov-Smirnov test of values against U(0, 1): the asymptotic
    Kolmogorov distribution with Stephens' small-sample correction."""
    x = np.sort(np.asarray(values, dtype=np.float64))
    n = len(x)
    i = np.arange(1, n + 1)
    d = max(np.max(i / n - x), np.max(x - (i - 1) / n))
    lam = (math.sqrt(n) + 0.12 + 0.11 / math.sqrt(n)) * d
    if lam < 0.2:
        return 1.0
    q = 2 * sum((-1) ** (k - 1) * math.exp(-2 * k * k * lam * lam) for k in range(1, 101))
    return min(1.0, max(0.0, q))


# ---- the sampler's cells ----------------------------------------------------
def _wrap(phi):
    return (phi + math.pi) % (2 * math.pi) - math.pi


def cell_probabilities(bound, wi, rows=RES, cols=2 * RES, tilt=0.0):
    """Exact probability of each chi^2 cell (shape (rows, cols): cos theta
    rows over [-1, 1], phi columns over [-pi, pi]) under bound.pdf, times
    (1 + tilt cos theta) and renormalised when tilt != 0.  bound.pdf is
    constant on every sub-rectangle between the chi^2 edges and the table's
    node lines (theta_o nodes in cos theta; phi_i +- phi_d nodes), and the
    tilt is linear in cos theta, so value-at-centre x area is exact."""
    axes = bound.table.axes
    ao = axes[1]
    mu_nodes = ao.values if ao.name == "mu_o" else np.cos(np.radians(ao.values))
    phi_i = math.atan2(wi[1], wi[0])
    phi_nodes = np.radians(axes[2].values) if len(axes) > 2 and axes[2].name == "phi_d" else []
    mu_edges = np.linspace(-1, 1, rows + 1)
    phi_edges = np.linspace(-math.pi, math.pi, cols + 1)
    mus = np.unique(np.concatenate([mu_edges, np.clip(mu_nodes, -1, 1)]))
    phis = np.unique(np.concatenate(
        [phi_edges, [_wrap(phi_i + s * p) for p in phi_nodes for s in (1, -1)]]))
    mid_mu, mid_phi = 0.5 * (mus[1:] + mus[:-1]), 0.5 * (phis[1:] + phis[:-1])
    area = np.outer(np.diff(mus), np.diff(phis))
    m, p = np.meshgrid(mid_mu, mid_phi, indexing="ij")
    s = np.sqrt(1 - m * m)
    wo = np.stack([s * np.cos(p), s * np.sin(p), m], axis=-1).reshape(-1, 3)
    dens = bound.pdf(np.broadcast_to(wi, wo.shape), wo).reshape(m.shape)
    r = np.clip(np.searchsorted(mu_edges, mid_mu) - 1, 0, rows - 1)
    c = np.clip(np.searchsorted(phi_edges, mid_phi) - 1, 0, cols - 1)
    prob = np.zeros((rows, cols))
    np.add.at(prob, (r[:, None], c[None, :]), dens * area * (1 + tilt * m))
    return prob / prob.sum() if tilt else prob


def histogram(wo, rows=RES, cols=2 * RES):
    r = np.clip(np.floor((wo[:, 2] + 1) / 2 * rows).astype(int), 0, rows - 1)
    c = np.clip(np.floor((np.arctan2(wo[:, 1], wo[:, 0]) + math.pi) / (2 * math.pi)
                         * cols).astype(int), 0, cols - 1)
    h = np.zeros((rows, cols))
    np.add.at(h, (r, c), 1.0)
    return h


def incidence(theta_deg, phi=0.37):
    t = math.radians(theta_deg)
    return np.array([math.sin(t) * math.cos(phi), math.sin(t) * math.sin(phi), math.cos(t)])


def seed_pvalues(bound, wi, seeds=SEEDS, samples=SAMPLES):
    prob = cell_probabilities(bound, wi)
    wrong = cell_probabilities(bound, wi, tilt=TILT)
    good, bad = [], []
    for seed in range(seeds):
        u = np.random.default_rng(1000 + seed).random((samples, 2))
        wo, _, _ = bound.sample(np.broadcast_to(wi, (samples, 3)), u)
        h = histogram(wo)
        good.append(chi2_pvalue(h, samples * prob))
        bad.append(chi2_pvalue(h, samples * wrong))
    return prob, np.array(good), np.array(bad)


# ---- the tests of the statistics themselves ---------------------------------
def test_gamma_q_closed_forms():
    for x in (0.01, 0.5, 1.0, 3.0, 10.0, 40.0, 200.0):
        assert gamma_q(1.0, x / 2) == pytest.approx(math.exp(-x / 2), rel=1e-12)          # dof 2
        assert gamma_q(0.5, x / 2) == pytest.approx(math.erfc(math.sqrt(x / 2)), rel=1e-10)  # dof 1
        assert gamma_q(2.0, x / 2) == pytest.approx((1 + x / 2) * math.exp(-x / 2), rel=1e-12)


def test_chi2_pvalue_large_dof_normal_limit():
    # chi^2 with k dof is about N(k, 2k): at k + 2.326 sqrt(2k), p ~ 0.01.
    k = 5000
    obs = np.full(k + 1, 100.0)
    exp = np.full(k + 1, 100.0)
    obs[0] += math.sqrt(100 * (k + 2.326 * math.sqrt(2 * k)))
    obs[1:] -= (obs[0] - 100) / k  # keep the totals equal
    assert chi2_pvalue(obs, exp) == pytest.approx(0.01, abs=0.002)


def test_ks_accepts_uniform_and_rejects_skewed():
    rng = np.random.default_rng(5)
    accepted = [ks_uniform_pvalue(rng.random(SEEDS)) > 0.01 for _ in range(200)]
    assert 0.95 <= np.mean(accepted) <= 1.0   # about 99 % by construction
    assert ks_uniform_pvalue(rng.random(SEEDS) ** 2) < 0.01


# ---- the sampler on unaligned tables ------------------------------------------
# Node counts chosen so that no table node line coincides with a chi^2 edge
# (cos theta steps of 1/8, phi steps of 11.25 degrees; wi at azimuth 0.37 rad).
OREN_NAYAR = """
    model = "oren-nayar"
    [parameters]
    nodes = 6
    [[axes]]
    name = "theta_i"
    range = [0.0, 80.0]
    count = 9
    [[axes]]
    name = "theta_o"
    range = [0.0, 90.0]
    count = 24
    [[axes]]
    name = "phi_d"
    range = [0.0, 180.0]
    count = 25
    [[axes]]
    name = "sigma"
    range = [0.0, 40.0]
    count = 3
    [[tables]]
    quantity = "brdf_direct"
    [[tables]]
    quantity = "brdf_interreflection"
    [[recombined]]
    name = "brdf"
    parameter = "rho"
    range = [0.0, 1.0]
    [[recombined.terms]]
    table = "brdf_direct"
    coeffs = [0.0, 1.0]
    [[recombined.terms]]
    table = "brdf_interreflection"
    coeffs = [0.0, 0.0, 1.0]
    [integration]
    method = "quadrature"
"""

ROUGH_DIELECTRIC = """
    model = "rough-dielectric"
    [parameters]
    distribution = "ggx"
    alpha = 0.4
    eta = 1.5
    [[axes]]
    name = "theta_i"
    range = [0.0, 80.0]
    count = 9
    [[axes]]
    name = "theta_o"
    range = [0.0, 180.0]
    count = 41
    [[axes]]
    name = "phi_d"
    range = [0.0, 180.0]
    count = 19
    [[tables]]
    name = "bsdf"
    quantity = "bsdf"
"""

INTERFACED_LAMBERTIAN = """
    model = "interfaced-lambertian"
    [parameters]
    distribution = "ggx-smith"
    ni = 1.5
    kd = 0.6
    alpha = 0.3
    [[axes]]
    name = "theta_i"
    range = [0.0, 80.0]
    count = 9
    [[axes]]
    name = "mu_o"
    range = [0.0, 1.0]
    count = 15
    [[axes]]
    name = "phi_d"
    range = [0.0, 180.0]
    count = 14
    [[tables]]
    name = "brdf"
    quantity = "brdf"
    [integration]
    method = "rqmc"
    samples = 64
"""

MODELS = {
    "oren-nayar": (OREN_NAYAR, "brdf", {"sigma": 20.0, "rho": 0.8}),
    "rough-dielectric": (ROUGH_DIELECTRIC, "bsdf", {}),
    "interfaced-lambertian": (INTERFACED_LAMBERTIAN, "brdf", {}),
}


def bound_table(tables, model):
    spec, name, params = MODELS[model]
    path = tables.generate(f"chi2-{model}", spec)
    return brdftab.open(path).tables[name].bind(**params)


@pytest.mark.parametrize("theta_i", [15.0, 62.0])
@pytest.mark.parametrize("model", sorted(MODELS))
def test_sampler_pvalues_uniform_on_unaligned_grid(tables, model, theta_i):
    bound = bound_table(tables, model)
    wi = incidence(theta_i)
    prob, good, bad = seed_pvalues(bound, wi)
    # The pdf integrates to 1 over the sphere (exact cell integrals).
    assert prob.sum() == pytest.approx(1.0, abs=1e-9)
    ks_good, ks_bad = ks_uniform_pvalue(good), ks_uniform_pvalue(bad)
    summary = (f"{model} theta_i={theta_i}: mean p {good.mean():.3f}, KS p {ks_good:.3g}; "
               f"tilted pdf: mean p {bad.mean():.3g}, KS p {ks_bad:.3g}")
    print(summary)
    assert ks_good > 0.01, summary
    assert ks_bad < 0.01, summary
