# `brdftab export --rgl` (host/io/rgl_export.cpp, docs/format.md "RGL
# export") inside the renderers that read the format natively: Mitsuba 3's
# own `measured` plugin loads the exported file and its eval is compared
# with the table (the lookup library through the Python module) at random
# direction pairs, for tables of all five models (one anisotropic), and
# Mitsuba's chi^2 test runs on `measured` with the file.  pbrt-v4's
# `measured` material is not installed here, so a reader written below
# from pbrt-v4's loader (MeasuredBxDF::f, PiecewiseLinear2D) reads the
# spectral file and must reproduce Mitsuba's values.  CTest label
# `mitsuba`; needs the venv of `scripts/setup.sh --mitsuba` (run_pytest.sh
# skips otherwise).
import math
import re
import struct

import numpy as np
import pytest

import brdftab
from conftest import OREN_NAYAR

mi = pytest.importorskip("mitsuba")
dr = pytest.importorskip("drjit")

ANGLES = """
    [[axes]]
    name = "theta_i"
    range = [0.0, 80.0]
    count = 9
    [[axes]]
    name = "theta_o"
    range = [0.0, 90.0]
    count = 10
    [[axes]]
    name = "phi_d"
    range = [0.0, 180.0]
    count = 13
"""

# model: (spec, table, --slice values, module parameters)
MODELS = {
    "oren-nayar": (OREN_NAYAR, "brdf", {"sigma": 20.0, "rho": 0.8}),
    "rough-dielectric": ("""
        model = "rough-dielectric"
        [parameters]
        distribution = "ggx"
        alpha = 0.4
        eta = 1.5
        [[axes]]
        name = "theta_i"
        range = [0.0, 90.0]
        count = 31
        [[axes]]
        name = "theta_o"
        range = [0.0, 180.0]
        count = 61
        [[axes]]
        name = "phi_d"
        range = [0.0, 180.0]
        count = 37
        [[tables]]
        name = "bsdf"
        quantity = "bsdf"
    """, "bsdf", {}),
    "interfaced-lambertian": ("""
        model = "interfaced-lambertian"
        [parameters]
        distribution = "ggx-smith"
        ni = 1.5
        kd = 0.6
        alpha = 0.5
    """ + ANGLES + """
        [[tables]]
        name = "brdf"
        quantity = "brdf"
        [integration]
        method = "rqmc"
        samples = 256
    """, "brdf", {}),
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
    """, "brdf", {}),
    "micrograin": ("""
        model = "micrograin"
        [parameters]
        grain = "diffuse"
        kd = 0.5
        base = "lambertian"
        base_albedo = 0.5
        correlation = "direction"
        tau0 = 0.3
    """ + ANGLES + """
        [[tables]]
        name = "brdf"
        quantity = "brdf"
        [integration]
        method = "rqmc"
        samples = 128
    """, "brdf", {}),
}

# Anisotropic GGX interfaced Lambertian over all four angles; phi_i over
# [0, 90] (the surface is even in x and in y), phi_o the full circle.
ANISOTROPIC = """
    model = "interfaced-lambertian"
    [parameters]
    distribution = "ggx-smith"
    alpha_x = 0.3
    alpha_y = 0.6
    ni = 1.5
    kd = 0.6
    [[axes]]
    name = "theta_i"
    range = [0.0, 80.0]
    count = 9
    [[axes]]
    name = "phi_i"
    range = [0.0, 90.0]
    count = 7
    [[axes]]
    name = "theta_o"
    range = [0.0, 90.0]
    count = 10
    [[axes]]
    name = "phi_o"
    range = [0.0, 360.0]
    count = 25
    [[tables]]
    name = "brdf"
    quantity = "brdf"
    [integration]
    method = "rqmc"
    samples = 128
"""

PAIRS = 4000
REPORT = re.compile(r"median ([0-9.e+-]+), p99 ([0-9.e+-]+), max ([0-9.e+-]+)")


def export(tables, path, table, out, *extra):
    r = tables.run("export", path, "--table", table, "--rgl", out, *extra, check=False)
    assert r.returncode == 0, r.stderr
    m = REPORT.search(r.stdout)
    assert m, r.stdout
    return [float(x) for x in m.groups()], r.stdout


def slice_args(params, grey=False):
    """--slice for every parameter (rho too when `grey`; else --rgb gives it)."""
    args = []
    for k, v in params.items():
        if k != "rho" or grey:
            args += ["--slice", f"{k}={v}"]
    return args


def cosine_directions(rng, n, theta_max_deg, phi_lo=0.0, phi_span=2 * math.pi):
    """Uniform in projected solid angle over theta <= theta_max."""
    c_min = math.cos(math.radians(theta_max_deg))
    cos_t = np.sqrt(1 - rng.random(n) * (1 - c_min * c_min))
    sin_t = np.sqrt(1 - cos_t * cos_t)
    phi = phi_lo + rng.random(n) * phi_span
    return np.stack([sin_t * np.cos(phi), sin_t * np.sin(phi), cos_t], axis=1)


def mitsuba_eval(path, wi, wo, variant="llvm_ad_rgb"):
    """Mitsuba's `measured` eval (f cos theta_o) per channel, shape (3, n)."""
    mi.set_variant(variant)
    bsdf = mi.load_dict({"type": "measured", "filename": str(path)})
    si = dr.zeros(mi.SurfaceInteraction3f)
    si.wi = mi.Vector3f(wi[:, 0], wi[:, 1], wi[:, 2])
    if "spectral" in variant:
        si.wavelengths = mi.Spectrum(550.0)
    value = bsdf.eval(mi.BSDFContext(), si, mi.Vector3f(wo[:, 0], wo[:, 1], wo[:, 2]))
    return np.array(value).reshape(-1, len(wi))


def relative_error(got, ref):
    floor = 1e-3 * np.mean(np.abs(ref))
    return np.abs(got - ref) / np.maximum(np.abs(ref), floor)


@pytest.mark.parametrize("model", list(MODELS))
def test_measured_matches_table(tables, model, tmp_path):
    spec, table, params = MODELS[model]
    path = tables.generate(model.replace("-", "_") + "_rgl", spec)
    out = tmp_path / "m.bsdf"
    extra = slice_args(params)
    rgb = (0.8, 0.5, 0.2)
    if "rho" in params:
        extra += ["--rgb", ",".join(map(str, rgb))]
    (median, p99, _), text = export(tables, path, table, out, *extra)
    t = brdftab.open(path).tables[table]
    m = re.search(r"theta_i <= ([0-9.]+), theta_o <= ([0-9.]+)", text)
    theta_i_max, theta_o_max = float(m.group(1)), float(m.group(2))
    rng = np.random.default_rng(11)
    wi = cosine_directions(rng, PAIRS, theta_i_max)
    wo = cosine_directions(rng, PAIRS, theta_o_max)
    got = mitsuba_eval(out, wi, wo) / wo[:, 2]
    channels = [dict(params, rho=r) for r in rgb] if "rho" in params else [params] * 3
    errors = []
    for c, p in enumerate(channels):
        ref = t.bind(**p).eval(wi, wo)
        errors.append(relative_error(got[c], ref))
    err = np.concatenate(errors)
    med, q99 = np.median(err), np.quantile(err, 0.99)
    print(f"rgl {model}: Mitsuba measured vs table: median {med:.3g}, p99 {q99:.3g} "
          f"(export printed median {median:.3g}, p99 {p99:.3g})")
    assert med <= 0.01 and q99 <= 0.05, (med, q99)
    # Within the error the export measured with its own model of the reader
    # (other random pairs, float32 arithmetic in Mitsuba).
    assert med <= 1.5 * median + 2e-4 and q99 <= 1.5 * p99 + 2e-3, (med, q99, median, p99)


def test_measured_anisotropic(tables, tmp_path):
    path = tables.generate("interfaced_lambertian_aniso_rgl", ANISOTROPIC)
    out = tmp_path / "a.bsdf"
    (median, p99, _), text = export(tables, path, "brdf", out)
    assert "360/4" in text
    rng = np.random.default_rng(12)
    # Incidence inside the table's phi_i range: the table is read as stored,
    # with no symmetry assumed on this side.
    wi = cosine_directions(rng, PAIRS, 80.0, 0.0, math.pi / 2)
    wo = cosine_directions(rng, PAIRS, 90.0)
    got = mitsuba_eval(out, wi, wo)[1] / wo[:, 2]
    t = brdftab.open(path).tables["brdf"]
    deg = np.degrees
    ref = t.eval(theta_i=deg(np.arccos(wi[:, 2])), phi_i=deg(np.arctan2(wi[:, 1], wi[:, 0])),
                 theta_o=deg(np.arccos(wo[:, 2])),
                 phi_o=deg(np.arctan2(wo[:, 1], wo[:, 0])) % 360.0)
    err = relative_error(got, ref)
    med, q99 = np.median(err), np.quantile(err, 0.99)
    print(f"rgl anisotropic: median {med:.3g}, p99 {q99:.3g} (printed {median:.3g}, {p99:.3g})")
    assert med <= 0.01 and q99 <= 0.05, (med, q99)
    assert med <= 1.5 * median + 2e-4 and q99 <= 1.5 * p99 + 2e-3


@pytest.mark.parametrize("model", list(MODELS) + ["anisotropic"])
def test_measured_chi2(tables, model, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # a failing run writes chi2_data.py here
    from mitsuba.chi2 import BSDFAdapter, ChiSquareTest, SphericalDomain
    if model == "anisotropic":
        path = tables.generate("interfaced_lambertian_aniso_rgl", ANISOTROPIC)
        table, args, phi = "brdf", [], math.radians(30.0)
    else:
        spec, table, params = MODELS[model]
        path = tables.generate(model.replace("-", "_") + "_rgl", spec)
        args, phi = slice_args(params, grey=True), 0.0
    out = tmp_path / "c.bsdf"
    export(tables, path, table, out, *args)
    mi.set_variant("llvm_ad_rgb")
    for theta in (15.0, 62.0):
        t = math.radians(theta)
        wi = [math.sin(t) * math.cos(phi), math.sin(t) * math.sin(phi), math.cos(t)]
        sample, pdf = BSDFAdapter("measured", {"type": "measured", "filename": str(out)}, wi=wi)
        # ires = 16 points per cell side for the expected counts: the
        # density of `measured` is bilinear in the warped square, bent by two
        # warps, and the default 4 x 4 rule integrates it too coarsely where
        # the table's values are noisy (micrograin at 62 degrees: p < 1e-6 with
        # ires = 4, p = 0.63 with 16).
        chi2 = ChiSquareTest(domain=SphericalDomain(), sample_func=sample, pdf_func=pdf,
                             sample_dim=3, ires=16)
        assert chi2.run(), f"{model}, theta_i = {theta}: {chi2.messages}"
        print(f"chi2 measured {model}, theta_i = {theta}: p = {chi2.p_value:.3g}")


def test_refuses_non_brdf(tables, tmp_path):
    path = tables.generate("interfaced_lambertian_aniso_body", ANISOTROPIC.replace(
        'name = "brdf"\n    quantity = "brdf"', 'name = "body"\n    quantity = "body"'))
    out = tmp_path / "x.bsdf"
    r = tables.run("export", path, "--table", "body", "--rgl", out, check=False)
    assert r.returncode == 2 and "units 1/sr" in r.stderr and not out.exists(), r.stderr


@pytest.mark.parametrize("args, message", [
    (["--slice", "sigma=20"], "give the value of 'rho'"),
    (["--slice", "sigma=20", "--slice", "rho=0.5", "--slice", "c=1"], "'c' is not a parameter"),
    (["--slice", "sigma=20", "--rgb", "1,1,1", "--spectral"], "--spectral writes one flat"),
    (["--slice", "sigma=20", "--slice", "rho=0.5", "--rgl-theta-i", "1"], "--rgl-theta-i 1"),
])
def test_refusals_keep_existing_file(tables, tmp_path, args, message):
    path = tables.generate("oren_nayar_rgl", OREN_NAYAR)
    out = tmp_path / "keep.bsdf"
    out.write_text("keep")
    r = tables.run("export", path, "--table", "brdf", "--rgl", out, *args, check=False)
    assert r.returncode == 2 and message in r.stderr, r.stderr
    assert out.read_text() == "keep"


# ---- an independent reader of the format, after pbrt-v4's loader ---------------

def read_tensor_file(path):
    """Fields of a tensor file: 12-byte magic, version 1.0, uint32 count,
    per field name, rank, type, offset and extents, then the data."""
    types = {1: np.uint8, 10: np.float32}
    data = path.read_bytes()
    assert data[:12] == b"tensor_file\0" and data[12:14] == bytes([1, 0])
    (count,), pos, fields = struct.unpack_from("<I", data, 14), 18, {}
    for _ in range(count):
        (n,) = struct.unpack_from("<H", data, pos)
        name = data[pos + 2:pos + 2 + n].decode()
        pos += 2 + n
        ndim, dtype, offset = struct.unpack_from("<HBQ", data, pos)
        pos += 11
        shape = struct.unpack_from("<" + "Q" * ndim, data, pos)
        pos += 8 * ndim
        fields[name] = np.frombuffer(data, types[dtype], int(np.prod(shape)), offset).reshape(shape)
    return fields


class PiecewiseLinear2D:
    """pbrt-v4's PiecewiseLinear2D<N> (the same construction as Mitsuba's
    continuous Marginal2D): a bilinear density on a grid over [0, 1]^2,
    linearly interpolated between parameter slices; invert() maps a point
    to the uniform square, evaluate() is the bilinear interpolant."""

    def __init__(self, data, params, normalize=True):
        self.params = [np.asarray(p, np.float64) for p in params]
        self.h, self.w = data.shape[-2:]
        d = data.reshape(-1, self.h, self.w).astype(np.float64)
        cond = np.cumsum(0.5 / (self.w - 1) * (d[:, :, 1:] + d[:, :, :-1]), axis=2)
        row = cond[:, :, -1]
        marg = np.cumsum(0.5 / (self.h - 1) * (row[:, 1:] + row[:, :-1]), axis=1)
        norm = 1 / marg[:, -1] if normalize else np.ones(len(d))
        self.data = d * norm[:, None, None]
        self.cond = cond * norm[:, None, None]
        self.marg = marg * norm[:, None]

    def _slices(self, param):
        """Per point: up to 2^N (slice index, weight) pairs."""
        n = len(param[0]) if self.params else 1
        combos = [(np.zeros(n, np.int64), np.ones(n))]
        stride = 1
        strides = []
        for p in reversed(self.params):
            strides.append(stride)
            stride *= len(p)
        strides.reverse()
        for dim, p in enumerate(self.params):
            if len(p) == 1:
                continue
            x = np.asarray(param[dim], np.float64)
            i = np.clip(np.searchsorted(p, x, side="right") - 1, 0, len(p) - 2)
            w1 = np.clip((x - p[i]) / (p[i + 1] - p[i]), 0, 1)
            combos = [(idx + (i + k) * strides[dim], wt * (w1 if k else 1 - w1))
                      for idx, wt in combos for k in (0, 1)]
        return combos

    def _cell(self, u):
        x = np.clip(u[0], 0, 1) * (self.w - 1)
        y = np.clip(u[1], 0, 1) * (self.h - 1)
        ix = np.minimum(x.astype(np.int64), self.w - 2)
        iy = np.minimum(y.astype(np.int64), self.h - 2)
        return ix, iy, x - ix, y - iy

    def evaluate(self, u, param=()):
        ix, iy, fx, fy = self._cell(u)
        out = 0
        for s, wt in self._slices(param):
            d = self.data
            v = ((1 - fx) * (1 - fy) * d[s, iy, ix] + fx * (1 - fy) * d[s, iy, ix + 1] +
                 (1 - fx) * fy * d[s, iy + 1, ix] + fx * fy * d[s, iy + 1, ix + 1])
            out = out + wt * v
        return out

    def invert(self, u, param=()):
        ix, iy, fx, fy = self._cell(u)
        sl = self._slices(param)

        def mix(get):
            return sum(wt * get(s) for s, wt in sl)

        d00 = mix(lambda s: self.data[s, iy, ix])
        d10 = mix(lambda s: self.data[s, iy, ix + 1])
        d01 = mix(lambda s: self.data[s, iy + 1, ix])
        d11 = mix(lambda s: self.data[s, iy + 1, ix + 1])
        c0, c1 = d00 + (d01 - d00) * fy, d10 + (d11 - d10) * fy
        sx = fx * (c0 + (c1 - c0) * 0.5 * fx) / (self.w - 1)
        prev = np.maximum(ix - 1, 0)
        before = mix(lambda s: self.cond[s, iy, prev] * (1 - fy) + self.cond[s, iy + 1, prev] * fy)
        sx = sx + np.where(ix > 0, before, 0)
        r0 = mix(lambda s: self.cond[s, iy, -1])
        r1 = mix(lambda s: self.cond[s, iy + 1, -1])
        sx = sx / (r0 + (r1 - r0) * fy)
        sy = fy * (r0 + (r1 - r0) * 0.5 * fy) / (self.h - 1)
        prev_y = np.maximum(iy - 1, 0)
        sy = sy + np.where(iy > 0, mix(lambda s: self.marg[s, prev_y]), 0)
        return np.stack([sx, sy])


class PbrtMeasured:
    """MeasuredBxDF::f of pbrt-v4 (spectral files; isotropic, or anisotropic
    over the full circle): f(wo, wi) with the slice chosen by wo."""

    def __init__(self, path):
        f = read_tensor_file(path)
        self.isotropic = f["phi_i"].shape[0] <= 2
        assert f["jacobian"][0] == 1
        self.ndf = PiecewiseLinear2D(f["ndf"], [], normalize=False)
        self.sigma = PiecewiseLinear2D(f["sigma"], [], normalize=False)
        self.vndf = PiecewiseLinear2D(f["vndf"], [f["phi_i"], f["theta_i"]])
        self.spectra = PiecewiseLinear2D(f["spectra"], [f["phi_i"], f["theta_i"], f["wavelengths"]],
                                         normalize=False)

    def f(self, wo, wi, wavelength):
        wm = wo + wi
        wm /= np.linalg.norm(wm, axis=1)[:, None]
        theta_o, phi_o = np.arccos(np.clip(wo[:, 2], -1, 1)), np.arctan2(wo[:, 1], wo[:, 0])
        theta_m, phi_m = np.arccos(np.clip(wm[:, 2], -1, 1)), np.arctan2(wm[:, 1], wm[:, 0])
        u_wo = np.stack([np.sqrt(theta_o * 2 / np.pi), (phi_o + np.pi) / (2 * np.pi)])
        u_wm = np.stack([np.sqrt(theta_m * 2 / np.pi),
                         (((phi_m - phi_o) if self.isotropic else phi_m) + np.pi) / (2 * np.pi)])
        u_wm[1] -= np.floor(u_wm[1])
        sample = self.vndf.invert(u_wm, (phi_o, theta_o))
        fr = self.spectra.evaluate(sample, (phi_o, theta_o, np.full(len(wo), wavelength)))
        fr = np.maximum(fr, 0)
        return fr * self.ndf.evaluate(u_wm) / (4 * self.sigma.evaluate(u_wo) * np.abs(wi[:, 2]))


@pytest.mark.parametrize("model", ["oren-nayar", "rough-dielectric"])
def test_pbrt_reader_reproduces_mitsuba(tables, model, tmp_path):
    spec, table, params = MODELS[model]
    path = tables.generate(model.replace("-", "_") + "_rgl", spec)
    rgb_file, spectral_file = tmp_path / "r.bsdf", tmp_path / "s.bsdf"
    grey = slice_args(params, grey=True)
    export(tables, path, table, rgb_file, *grey)
    export(tables, path, table, spectral_file, *grey, "--spectral")
    rng = np.random.default_rng(13)
    wi = cosine_directions(rng, 2000, 80.0)
    wo = cosine_directions(rng, 2000, 89.0)
    mitsuba = mitsuba_eval(rgb_file, wi, wo)[0] / wo[:, 2]
    mitsuba_spectral = mitsuba_eval(spectral_file, wi, wo, "llvm_ad_spectral")[0] / wo[:, 2]
    # pbrt's wo is Mitsuba's wi (the direction that selects the slice).
    pbrt = PbrtMeasured(spectral_file).f(wi, wo, 550.0)
    scale = np.mean(np.abs(mitsuba))
    assert np.max(np.abs(pbrt - mitsuba)) <= 1e-4 * scale + 1e-4 * np.abs(mitsuba).max(), \
        np.max(np.abs(pbrt - mitsuba) / scale)
    assert np.max(np.abs(mitsuba_spectral - mitsuba)) <= 1e-4 * np.abs(mitsuba).max()
