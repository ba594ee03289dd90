# Mitsuba's own chi^2 BSDF test (mitsuba.chi2.ChiSquareTest) on the plugin,
# and what its settings do to the p-value of a table.  CTest labels `chi2`
# and `mitsuba`; needs the venv of `scripts/setup.sh --mitsuba`.
#
# ChiSquareTest integrates the pdf over each of its cells with an ires x ires
# trapezoid rule.  The table sampler's pdf is piecewise constant (one value
# per table cell in (cos theta_o, phi_o), host/lookup/sample.cpp), so a chi^2
# cell that a table node line crosses gets a biased expected count unless
# the two grids are aligned.  ExactChiSquareTest replaces that quadrature by
# the exact cell integrals of test_chi2.cell_probabilities and keeps the rest
# of Mitsuba's test (its sampling, histogram, pooling and p-value).
#
# Run as a script, this file measures p over seeds for each setting (the
# table in docs/python.md, "chi^2 tests of the sampler"):
#
#     DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM-19.so BRDFTAB_CLI=build/brdftab \
#       PYTHONPATH=build/python:tests/python .venv-mitsuba/bin/python \
#       tests/python/test_chi2_mitsuba.py [SEEDS]
import math
import os
import sys
import tempfile
import time

import numpy as np
import pytest

import brdftab
import test_chi2 as exact
from conftest import OREN_NAYAR as OREN_NAYAR_ALIGNED

mi = pytest.importorskip("mitsuba")
dr = pytest.importorskip("drjit")
mi.set_variant("llvm_ad_rgb")
import brdftab.mitsuba  # noqa: E402  (after the variant is set)
from mitsuba.chi2 import BSDFAdapter, ChiSquareTest, SphericalDomain  # noqa: E402

PARAMS = {"sigma": 20.0, "rho": 0.8}
RES = 32      # ChiSquareTest's res: 32 rows in cos theta, 16 columns in phi


class ExactChiSquareTest(ChiSquareTest):
    """Mitsuba's ChiSquareTest on the plugin, with the expected count of each
    cell the exact integral of the bound table's pdf (no quadrature)."""

    def __init__(self, bound, wi, sample_func, **kwargs):
        super().__init__(domain=SphericalDomain(), sample_func=sample_func, pdf_func=None,
                         sample_dim=3, **kwargs)
        self.bound, self.wi = bound, np.asarray(wi, dtype=np.float64)
        self.tilt = 0.0

    def tabulate_pdf(self):
        self.histogram_start = time.time()
        # Mitsuba's cells: x = phi over [-pi, pi] (res / 2 columns), y = -cos
        # theta over [-1, 1] (res rows), index x + y * res.x;
        # cell_probabilities' rows run in +cos theta.
        prob = exact.cell_probabilities(self.bound, self.wi, rows=int(self.res.y),
                                        cols=int(self.res.x), tilt=self.tilt)
        self.pdf = mi.Float(np.ascontiguousarray(prob[::-1]).ravel() * self.sample_count)
        self.pdf_sum = dr.sum(self.pdf) / self.sample_count
        self.histogram_end = time.time()


def incidence(theta_deg, phi):
    return [float(c) for c in exact.incidence(theta_deg, phi)]


def plugin(path):
    return dict({"type": "brdftab", "filename": path, "table": "brdf"}, **PARAMS)


def exact_pvalues(path, wi, seeds, samples, res, tilt=0.0):
    brdftab.mitsuba.register()
    bound = brdftab.open(path).tables["brdf"].bind(**PARAMS)
    sample, _ = BSDFAdapter("brdftab", plugin(path), wi=wi)
    out = []
    for seed in range(seeds):
        t = ExactChiSquareTest(bound, wi, sample, sample_count=samples, res=res, seed=seed)
        t.tilt = tilt
        t.run(quiet=True)
        out.append(float(t.p_value))
    return np.array(out)


@pytest.mark.parametrize("tilt", [0.0, exact.TILT])
def test_mitsuba_chi2_exact_counts_uniform(tables, tilt, tmp_path, monkeypatch):
    """Mitsuba's test with exact expected counts on an unaligned Oren-Nayar
    table (test_chi2.OREN_NAYAR): uniform p over 40 seeds; the 5 %
    tilted density is rejected."""
    monkeypatch.chdir(tmp_path)  # a failing ChiSquareTest writes chi2_data.py
    path = tables.generate("chi2-oren-nayar", exact.OREN_NAYAR)
    p = exact_pvalues(path, incidence(62.0, 0.37), exact.SEEDS, exact.SAMPLES, RES, tilt)
    ks = exact.ks_uniform_pvalue(p)
    summary = f"tilt {tilt}: mean p {p.mean():.3f}, KS p {ks:.3g}"
    print(summary)
    if tilt == 0:
        assert ks > 0.01, summary
    else:
        assert ks < 0.01, summary


# ---- the measurement (script mode) -------------------------------------------
def study(seeds):
    """p over seeds for Mitsuba's ChiSquareTest at res = 48 against the sample
    count, ires and grid alignment, and with exact expected counts."""
    cli = os.environ.get("BRDFTAB_CLI", "build/brdftab")
    brdftab.mitsuba.register()
    work = tempfile.mkdtemp(prefix="chi2-study-")
    from conftest import Tables
    from pathlib import Path
    tables = Tables(Path(work))
    tables.cli = cli
    cases = {
        # name: (spec, wi azimuth): aligned = cos theta_o steps of 1/6, phi_d
        # steps of 30 degrees, wi at azimuth 0 (the chi^2 cells are 1/24 in
        # cos theta and 7.5 degrees in phi); unaligned = 24 x 25 linear nodes.
        "aligned": (OREN_NAYAR_ALIGNED, 0.0),
        "unaligned": (exact.OREN_NAYAR, 0.37),
    }
    res, counts, ireses = 48, (100_000, 1_000_000), (4, 16, 64)
    print(f"# Oren-Nayar sigma 20, rho 0.8, theta_i 62, res {res}, {seeds} seeds; "
          "mean p, share of p < 0.01, KS p of the p-values")
    print("| grid | samples | ires | mean p | p < 0.01 | KS p |")
    print("|---|---|---|---|---|---|")
    for name, (spec, azimuth) in cases.items():
        path = tables.generate(f"study-{name}", spec)
        wi = incidence(62.0, azimuth)
        bound = brdftab.open(path).tables["brdf"].bind(**PARAMS)
        sample, pdf = BSDFAdapter("brdftab", plugin(path), wi=wi)
        # The quadrature tables do not depend on the seed or (up to a factor)
        # on the sample count: tabulate once per ires.
        unit = {}
        for ires in ireses:
            t = ChiSquareTest(SphericalDomain(), sample, pdf, sample_dim=3, sample_count=1,
                              res=res, ires=ires)
            t.tabulate_pdf()
            unit[ires] = np.array(t.pdf, dtype=np.float64)
        e = ExactChiSquareTest(bound, wi, sample, sample_count=1, res=res)
        e.tabulate_pdf()
        unit["exact"] = np.array(e.pdf, dtype=np.float64)
        for n in counts:
            p = {k: [] for k in unit}
            for seed in range(seeds):
                t = ChiSquareTest(SphericalDomain(), sample, pdf, sample_dim=3, sample_count=n,
                                  res=res, seed=seed)
                t.tabulate_histogram()
                for k, table in unit.items():
                    t.pdf, t.fail = mi.Float(table * n), False
                    t.pdf_sum, t.histogram_start, t.histogram_end = dr.sum(t.pdf) / n, 0, 0
                    t.run(quiet=True)
                    p[k].append(float(t.p_value))
            for k, v in p.items():
                v = np.array(v)
                print(f"| {name} | {n:.0e} | {k} | {v.mean():.3f} | {np.mean(v < 0.01):.2f} | "
                      f"{exact.ks_uniform_pvalue(v):.2g} |", flush=True)


if __name__ == "__main__":
    study(int(sys.argv[1]) if len(sys.argv) > 1 else exact.SEEDS)
