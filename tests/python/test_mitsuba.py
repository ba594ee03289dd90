# The Mitsuba 3 plugin (python/brdftab/mitsuba.py): Mitsuba's own chi^2 BSDF
# test (mitsuba.chi2, what its developers run on every BSDF) on small tables
# of four models in llvm_ad_rgb, and the plugin's eval/sample/pdf against the
# Python module in llvm_ad_rgb and scalar_rgb.  CTest label `mitsuba`; needs
# the venv of `scripts/setup.sh --mitsuba` and libLLVM-19 (run_pytest.sh
# skips otherwise).  mitsuba.chi2 does not run in scalar variants.
import math

import numpy as np
import pytest

import brdftab
from conftest import OREN_NAYAR

mi = pytest.importorskip("mitsuba")
dr = pytest.importorskip("drjit")

# Angular axes shared by the chi^2 tables: theta_o must reach 90 (sampling
# covers the hemisphere).
ANGLES = """
    [[axes]]
    name = "theta_i"
    range = [0.0, 80.0]
    count = 6
    [[axes]]
    name = "theta_o"
    range = [0.0, 90.0]
    count = 7
    spacing = "cos"
    [[axes]]
    name = "phi_d"
    range = [0.0, 180.0]
    count = 7
"""

SPECS = {
    # model: (spec, plugin parameters beyond filename/table)
    "oren-nayar": (OREN_NAYAR, {"sigma": 20.0, "rho": 0.8}),
    "interfaced-lambertian": ("""
        model = "interfaced-lambertian"
        [parameters]
        distribution = "ggx-smith"
        ni = 1.5
        kd = 0.6
    """ + ANGLES + """
        [[axes]]
        name = "alpha"
        range = [0.3, 0.6]
        count = 2
        [[tables]]
        name = "brdf"
        quantity = "brdf"
        [integration]
        method = "rqmc"
        samples = 128
    """, {"alpha": 0.45}),
    "lambert-sphere": ("""
        model = "lambert-sphere"
        [parameters]
        c = 0.8
        max_order = 40
    """ + ANGLES + """
        [[tables]]
        name = "brdf"
        quantity = "brdf_mc"
        [integration]
        method = "mc"
        samples = 256
    """, {}),
    "micrograin": ("""
        model = "micrograin"
        [parameters]
        grain = "diffuse"
        kd = 0.5
        base = "lambertian"
        base_albedo = 0.5
        correlation = "direction"
    """ + ANGLES + """
        [[axes]]
        name = "tau0"
        range = [0.2, 0.5]
        count = 2
        [[tables]]
        name = "brdf"
        quantity = "brdf"
        [integration]
        method = "rqmc"
        samples = 128
    """, {"tau0": 0.3}),
    # Reflection and transmission: theta_o up to 180 degrees.
    "rough-dielectric": ("""
        model = "rough-dielectric"
        [parameters]
        distribution = "ggx"
        alpha = 0.5
        eta = 1.5
        [[axes]]
        name = "theta_i"
        range = [0.0, 80.0]
        count = 6
        [[axes]]
        name = "theta_o"
        range = [0.0, 180.0]
        count = 13
        spacing = "cos"
        [[axes]]
        name = "phi_d"
        range = [0.0, 180.0]
        count = 7
        [[tables]]
        name = "brdf"
        quantity = "bsdf"
    """, {}),
}


def plugin_dict(path, params, table="brdf", **extra):
    d = {"type": "brdftab", "filename": path, "table": table}
    d.update(params)
    d.update(extra)
    return d


def set_variant(name):
    mi.set_variant(name)
    import brdftab.mitsuba
    brdftab.mitsuba.register()


def incidence(theta_deg, phi=0.0):
    t = math.radians(theta_deg)
    return [math.sin(t) * math.cos(phi), math.sin(t) * math.sin(phi), math.cos(t)]


# The chi^2 test integrates the pdf over its cells with the trapezoid rule
# (mitsuba.chi2.ChiSquareTest.tabulate_pdf).  The table's density is
# constant on each table cell in (cos theta_o, phi), so a chi^2 cell that a
# table cell boundary crosses gets a biased expected count (measured: 0.3 %
# of the total with the default 4 x 4 points, enough to reject at 400k
# samples).  Aligned grids make the expected counts exact: theta_o axes with
# "cos" spacing in steps of 1/6 in cos theta, phi_d in 30-degree steps, wi at
# azimuth 0, and the test's cells 1/24 in cos theta (res = 48) by 15 degrees
# in phi (res/2 = 24 columns).  Unaligned grids, with exact expected counts
# and p-value uniformity over 40 seeds: test_chi2.py, test_chi2_mitsuba.py.
CHI2_RES = 48


@pytest.mark.parametrize("model", list(SPECS))
def test_chi2(tables, model, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # a failing run writes chi2_data.py here
    from mitsuba.chi2 import BSDFAdapter, ChiSquareTest, SphericalDomain
    set_variant("llvm_ad_rgb")
    spec, params = SPECS[model]
    path = tables.generate(model.replace("-", "_") + "_mi", spec)
    p_values = []
    for theta in (15.0, 62.0):
        sample, pdf = BSDFAdapter("brdftab", plugin_dict(path, params), wi=incidence(theta))
        chi2 = ChiSquareTest(domain=SphericalDomain(), sample_func=sample, pdf_func=pdf,
                             sample_dim=3, sample_count=400000, res=CHI2_RES)
        passed = chi2.run()
        p_values.append(chi2.p_value)
        assert passed, f"{model}, theta_i = {theta}: {chi2.messages}"
    print(f"chi2 {model}: p = " + ", ".join("%.3g" % p for p in p_values))


def module_reference(path, name, wi, wo, **params):
    bound = brdftab.open(path).tables[name].bind(**params)
    return bound.eval(wi, wo), bound.pdf(wi, wo)


@pytest.mark.parametrize("variant", ["llvm_ad_rgb", "scalar_rgb"])
def test_plugin_matches_module(tables, variant):
    set_variant(variant)
    path = tables.generate("oren_nayar", OREN_NAYAR)
    bsdf = mi.load_dict(plugin_dict(path, {"sigma": 20.0, "rho": 0.8}))
    coloured = mi.load_dict(plugin_dict(path, {"sigma": 20.0},
                                        reflectance={"type": "rgb", "value": [0.9, 0.5, 0.2]}))
    ctx = mi.BSDFContext()
    rng = np.random.default_rng(5)
    wi = np.array(incidence(40.0))
    for _ in range(5 if variant.startswith("scalar") else 1):
        u = rng.random((64, 2))
        si = dr.zeros(mi.SurfaceInteraction3f)
        si.wi = mi.Vector3f(*map(float, wi))
        if variant.startswith("scalar"):
            u = u[:1]
            bs, weight = bsdf.sample(ctx, si, 0.5, mi.Point2f(*u[0]))
            wo = np.array([[bs.wo[0], bs.wo[1], bs.wo[2]]])
            weight, pdf = np.array([weight[0]]), np.array([bs.pdf])
            f = np.array([bsdf.eval(ctx, si, bs.wo)[0]])
            p = np.array([bsdf.pdf(ctx, si, bs.wo)])
            fc = np.array(coloured.eval(ctx, si, bs.wo)).reshape(3, 1)
        else:
            bs, weight = bsdf.sample(ctx, si, mi.Float(0.5), mi.Point2f(u[:, 0], u[:, 1]))
            wo = np.stack([np.array(bs.wo.x), np.array(bs.wo.y), np.array(bs.wo.z)], axis=1)
            weight, pdf = np.array(weight[0]), np.array(bs.pdf)
            f = np.array(bsdf.eval(ctx, si, bs.wo)[0])
            p = np.array(bsdf.pdf(ctx, si, bs.wo))
            fc = np.array(coloured.eval(ctx, si, bs.wo))
        ref_f, ref_p = module_reference(path, "brdf", wi, wo, sigma=20.0, rho=0.8)
        cos_o = np.abs(wo[:, 2])
        # Mitsuba's eval includes |cos theta_o|; single precision in the plugin.
        np.testing.assert_allclose(f, ref_f * cos_o, rtol=2e-6)
        np.testing.assert_allclose(p, ref_p, rtol=2e-6)
        np.testing.assert_allclose(pdf, ref_p, rtol=2e-6)
        np.testing.assert_allclose(weight, ref_f * cos_o / ref_p, rtol=2e-6)
        # reflectance texture: rho per channel.
        for c, rho in enumerate([0.9, 0.5, 0.2]):
            ref_c, _ = module_reference(path, "brdf", wi, wo, sigma=20.0, rho=rho)
            np.testing.assert_allclose(fc[c], ref_c * cos_o, rtol=2e-6)
    # Below the surface: a reflection table gives nothing.
    si = dr.zeros(mi.SurfaceInteraction3f)
    si.wi = mi.Vector3f(*map(float, incidence(40.0)))
    below = mi.Vector3f(0.3, 0.0, -0.9)
    assert np.all(np.array(bsdf.eval(ctx, si, below)) == 0)
    assert np.all(np.array(bsdf.pdf(ctx, si, below)) == 0)


def test_bad_parameters(tables):
    set_variant("scalar_rgb")
    path = tables.generate("oren_nayar", OREN_NAYAR)
    with pytest.raises(Exception, match="needs parameter 'sigma'"):
        mi.load_dict(plugin_dict(path, {"rho": 0.5}))
    with pytest.raises(Exception, match="recombined in 'rho'"):
        mi.load_dict(plugin_dict(path, {"sigma": 20.0}))
    with pytest.raises(Exception, match="not a factored"):
        mi.load_dict(plugin_dict(path, {"sigma": 20.0}, table="brdf_direct",
                                 reflectance={"type": "rgb", "value": [0.5, 0.5, 0.5]}))


# An anisotropic table (GGX alpha_x != alpha_y): phi_i over [0, 90] (the
# mirror symmetries of an axis-aligned surface give the rest), phi_o the
# full circle, as tables/interfaced-lambertian-anisotropic.toml.
ANISOTROPIC = """
    model = "interfaced-lambertian"
    [parameters]
    distribution = "ggx-smith"
    alpha_x = 0.2
    alpha_y = 0.5
    ni = 1.5
    kd = 0.6
    [[axes]]
    name = "theta_i"
    range = [0.0, 80.0]
    count = 5
    [[axes]]
    name = "phi_i"
    range = [0.0, 90.0]
    count = 4
    [[axes]]
    name = "theta_o"
    range = [0.0, 90.0]
    count = 6
    [[axes]]
    name = "phi_o"
    range = [0.0, 360.0]
    count = 13
    [[tables]]
    name = "brdf"
    quantity = "body"
    [integration]
    method = "rqmc"
    samples = 64
"""


def test_anisotropic_table(tables, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    from mitsuba.chi2 import BSDFAdapter, ChiSquareTest, SphericalDomain
    set_variant("llvm_ad_rgb")
    path = tables.generate("anisotropic", ANISOTROPIC)
    # Sampling (cosine-weighted for anisotropic tables) against its pdf.
    sample, pdf = BSDFAdapter("brdftab", plugin_dict(path, {}), wi=incidence(50.0, 2.0))
    chi2 = ChiSquareTest(domain=SphericalDomain(), sample_func=sample, pdf_func=pdf,
                         sample_dim=3, sample_count=200000, res=CHI2_RES)
    assert chi2.run(), chi2.messages
    # eval against the module at the angles, phi_i in (90, 180) mirrored to
    # 180 - phi_i (and phi_o to 180 - phi_o), phi_i < 0 to -phi_i.
    bsdf = mi.load_dict(plugin_dict(path, {}))
    table = brdftab.open(path).tables["brdf"]
    rng = np.random.default_rng(3)
    n = 200
    theta_i, phi_i = rng.uniform(5, 75, n), rng.uniform(-180, 180, n)
    theta_o, phi_o = rng.uniform(5, 85, n), rng.uniform(0, 360, n)

    def direction(theta, phi):
        t, p = np.radians(theta), np.radians(phi)
        return np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=1)
    wi, wo = direction(theta_i, phi_i), direction(theta_o, phi_o)
    si = dr.zeros(mi.SurfaceInteraction3f, n)
    si.wi = mi.Vector3f(*[mi.Float(c) for c in wi.T])
    f = np.array(bsdf.eval(mi.BSDFContext(), si, mi.Vector3f(*[mi.Float(c) for c in wo.T]))[0])
    neg = phi_i < 0
    pi_, po_ = np.where(neg, -phi_i, phi_i), np.where(neg, -phi_o, phi_o)
    mirror = pi_ > 90
    pi_, po_ = np.where(mirror, 180 - pi_, pi_), np.where(mirror, 180 - po_, po_) % 360
    expected = table.eval(theta_i=theta_i, phi_i=pi_, theta_o=theta_o, phi_o=po_)
    np.testing.assert_allclose(f, expected * np.cos(np.radians(theta_o)), rtol=1e-5, atol=1e-7)
