"""A Mitsuba 3 BSDF plugin backed by a brdftab table (docs/python.md).

    import mitsuba as mi
    mi.set_variant("llvm_ad_rgb")          # or "scalar_rgb"
    import brdftab.mitsuba
    brdftab.mitsuba.register()
    bsdf = mi.load_dict({"type": "brdftab", "filename": "oren-nayar-brdf.h5",
                         "table": "brdf", "sigma": 20.0,
                         "reflectance": {"type": "rgb", "value": [0.8, 0.5, 0.3]}})

Plugin parameters:
  filename      the table file (required)
  table         the table's name in the file (default "brdf")
  <axis name>   a number for every axis of the table that is not an angle
                (e.g. sigma for Oren-Nayar, tau0 for a micrograin table)
  <parameter>   the recombination parameter of a recombined table (e.g. rho
                for Oren-Nayar), a number ...
  reflectance   ... or, instead, a texture giving it per channel and per
                point (a factored table: value = N(p)/D(p) sum_k C_k(p) T_k)
  interpolation "linear" (default) or "cubic"

eval, sample and pdf come from the table (host/lookup: interpolation in the
warped coordinates, sampling proportional to f |cos theta_o| per table
cell).  Isotropic tables (theta_i|mu_i, theta_o|mu_o, optional phi_d) are
sampled from the table; anisotropic ones (phi_i and phi_o axes) are
evaluated from the table and sampled cosine-weighted.  A table whose
theta_o axis reaches 180 degrees transmits; one whose theta_i axis stops at
90 is lit from above only (f = 0 for wi below the surface).

The plugin converts Dr.Jit arrays to numpy and calls the C++ library, so in
the JIT variants it needs evaluated (wavefront) loops and calls: register()
switches off Dr.Jit's symbolic loops and calls.
"""

import math

import numpy as np

import drjit as dr
import mitsuba as mi

import brdftab
from brdftab import _brdftab

PLUGIN_NAME = "brdftab"

_ANGLE_AXES = {"theta_i", "mu_i", "theta_o", "mu_o", "phi_d", "phi_i", "phi_o"}


def _lanes(*values):
    """Dr.Jit scalars/arrays -> 1-D numpy arrays of one common length."""
    arrays = [np.atleast_1d(np.asarray(v, dtype=np.float64)).reshape(-1) for v in values]
    n = max(len(a) for a in arrays)
    return [np.broadcast_to(a, (n,)) for a in arrays]


def _vectors(v):
    """(n, 3) numpy directions; rows of inactive lanes (zero or NaN vectors)
    become +z and are masked out by _valid()."""
    x, y, z = _lanes(v.x, v.y, v.z)
    w = np.stack([x, y, z], axis=1)
    bad = ~(np.einsum("ij,ij->i", w, w) > 0)
    w[bad] = (0.0, 0.0, 1.0)
    return w, bad


def _f32(v):
    """A Dr.Jit scalar/array as a 1-D float32 numpy array (length n or 1)."""
    return np.asarray(v, dtype=np.float32).reshape(-1)


_ONE = np.ones(1, dtype=np.float32)


def _mask(active):
    """Dr.Jit's active mask as a 1-D bool numpy array (length n or 1)."""
    return np.asarray(active, dtype=bool).reshape(-1)


def _polynomial(coeffs, p):
    out = np.zeros_like(p)
    for c in reversed(coeffs):
        out = out * p + c
    return out


class _TableBSDF:
    """The `brdftab` plugin (see the module docstring): its methods become a
    subclass of the current variant's mi.BSDF in register()."""

    def __init__(self, props):
        mi.BSDF.__init__(self, props)
        self._scalar = mi.variant().startswith("scalar")
        if "filename" not in props:
            raise ValueError("brdftab plugin: 'filename' (a brdftab table file) is required")
        filename = str(props.get("filename"))
        name = str(props.get("table", "brdf"))
        interpolation = str(props.get("interpolation", "linear"))
        table = brdftab.open(filename).tables[name]
        self.table = table
        self.filename, self.table_name = filename, name
        axes = {a.name: a for a in table.axes}

        # Fixed parameters: every non-angle axis, from the properties.
        params = {}
        for a in table.axes:
            if a.name in _ANGLE_AXES:
                continue
            if a.name not in props:
                raise ValueError(f"brdftab plugin: table '{name}' needs parameter '{a.name}' "
                                 f"(range [{a.min:g}, {a.max:g}] {a.unit})")
            params[a.name] = float(props.get(a.name))
        self.params = params

        recipe = table.recombination
        self.reflectance = None
        if "reflectance" in props:
            if recipe is None:
                raise ValueError(f"brdftab plugin: table '{name}' is not a factored (recombined) "
                                 "table, so it takes no 'reflectance'")
            self.reflectance = props.get_texture("reflectance")
        elif recipe is not None:
            p = recipe["parameter"]
            if p not in props:
                raise ValueError(f"brdftab plugin: table '{name}' is recombined in '{p}': give "
                                 f"'{p}' (a number) or 'reflectance' (a texture)")
            params[p] = float(props.get(p))

        self.anisotropic = "phi_i" in axes or "phi_o" in axes
        theta_i = axes.get("theta_i")
        theta_o = axes.get("theta_o")
        # Which sides the table covers: theta beyond 90 (or mu below 0).
        self.lit_from_below = (theta_i.max > 90 if theta_i else axes["mu_i"].min < 0)
        self.transmits = (theta_o.max > 90 if theta_o else axes["mu_o"].min < 0)

        if self.anisotropic:
            self._eval_table = lambda wi, wo: self._eval_anisotropic(wi, wo)
            self.sampler = None
        elif self.reflectance is None:
            bound = table.bind(interpolation=interpolation, **params)
            self._eval_table = bound.eval
            self.sampler = bound
        else:
            # Factored table under a texture: the term tables are bound
            # once and combined per channel with the texture's value of p.
            f = brdftab.open(filename)
            self.terms = [(f.tables[t["table"]].bind(interpolation=interpolation, **params),
                           t["coeffs"]) for t in recipe["terms"]]
            prefactor = recipe.get("prefactor", {})
            self.num, self.den = prefactor.get("num", [1.0]), prefactor.get("den", [1.0])
            # Sampling follows the table at the middle of p's range: the
            # density need not match f exactly, only be positive where f is.
            lo, hi = recipe.get("range", [0.0, 1.0])
            self.sampler = table.bind(interpolation=interpolation,
                                      **dict(params, **{recipe["parameter"]: 0.5 * (lo + hi)}))
        if self.sampler is not None and not self.sampler.can_sample:
            raise ValueError(f"brdftab plugin: {self.sampler.sampling_error}")
        # Isotropic tables: one C++ call per BSDF method and wavefront
        # (_brdftab._PluginKernel, threaded over the lanes).
        self.kernel = None
        if not self.anisotropic:
            if self.reflectance is None:
                self.kernel = _brdftab._PluginKernel(bound._b, [], [1.0], [1.0], bound._b,
                                                     self.lit_from_below, self.transmits)
            else:
                self.kernel = _brdftab._PluginKernel(
                    None, [(b._b, [float(c) for c in coeffs]) for b, coeffs in self.terms],
                    [float(c) for c in self.num], [float(c) for c in self.den],
                    self.sampler._b, self.lit_from_below, self.transmits)

        flags = mi.BSDFFlags.GlossyReflection | mi.BSDFFlags.FrontSide
        if self.transmits:
            flags = flags | mi.BSDFFlags.GlossyTransmission
        if self.lit_from_below:
            flags = flags | mi.BSDFFlags.BackSide
        self.m_components = [flags]
        self.m_flags = flags

    # ---- table access on numpy arrays -----------------------------------
    def _eval_anisotropic(self, wi, wo):
        def angles(w):
            theta = np.degrees(np.arccos(np.clip(w[:, 2], -1, 1)))
            phi = np.degrees(np.arctan2(w[:, 1], w[:, 0])) % 360.0
            return theta, phi
        theta_i, phi_i = angles(wi)
        theta_o, phi_o = angles(wo)
        axes = {a.name: a for a in self.table.axes}
        # A phi_i axis over [0, 90] relies on the mirror symmetries of an
        # axis-aligned anisotropic surface: (phi_i, phi_o) -> (-phi_i, -phi_o)
        # and (180 - phi_i, 180 - phi_o) (tables/interfaced-lambertian-anisotropic.toml).
        if axes["phi_i"].max <= 90:
            flip = phi_i > 180
            phi_i, phi_o = np.where(flip, 360 - phi_i, phi_i), np.where(flip, 360 - phi_o, phi_o)
            mirror = phi_i > 90
            phi_i = np.where(mirror, 180 - phi_i, phi_i)
            phi_o = np.where(mirror, 180 - phi_o, phi_o) % 360.0
        return self.table.eval(theta_i=theta_i, phi_i=phi_i, theta_o=theta_o, phi_o=phi_o,
                               **self.params)

    def _valid(self, wi, wo=None, bad=None):
        ok = np.ones(len(wi), dtype=bool) if bad is None else ~bad
        if not self.lit_from_below:
            ok &= wi[:, 2] > 0
        if wo is not None and not self.transmits:
            ok &= wo[:, 2] > 0
        return ok

    def _f_rgb(self, si, wi, wo, active):
        """f(wi, wo) per channel, shape (3, n)."""
        n = len(wi)
        if self.reflectance is None:
            return np.broadcast_to(self._eval_table(wi, wo), (3, n))
        albedo = self.reflectance.eval(si, active)
        p = np.stack(_lanes(albedo[0], albedo[1], albedo[2]))
        p = np.broadcast_to(p, (3, n)) if p.shape[1] != n else p
        total = np.zeros((3, n))
        for bound, coeffs in self.terms:
            total += _polynomial(coeffs, p) * bound.eval(wi, wo)[None, :]
        return total * _polynomial(self.num, p) / _polynomial(self.den, p)

    def _pdf_np(self, wi, wo):
        if self.sampler is None:  # cosine-weighted on the side(s) the table covers
            return np.abs(wo[:, 2]) / (2 * math.pi if self.transmits else math.pi) * \
                (1.0 if self.transmits else (wo[:, 2] > 0))
        return self.sampler.pdf(wi, wo)

    # ---- conversions back to Dr.Jit ---------------------------------------
    def _float(self, a):
        return float(a[0]) if self._scalar else mi.Float(np.asarray(a, dtype=np.float32))

    def _spectrum(self, rgb):
        return mi.Spectrum(self._float(rgb[0]), self._float(rgb[1]), self._float(rgb[2]))

    # ---- the BSDF interface ---------------------------------------------------
    def _pair(self, wi, wo):
        (wi_np, bad_i), (wo_np, bad_o) = _vectors(wi), _vectors(wo)
        n = max(len(wi_np), len(wo_np))
        bad = np.broadcast_to(bad_i, (n,)) | np.broadcast_to(bad_o, (n,))
        return np.broadcast_to(wi_np, (n, 3)), np.broadcast_to(wo_np, (n, 3)), bad

    def _albedo(self, si, active):
        """The reflectance texture's value per channel (three lanes)."""
        if self.reflectance is None:
            return _ONE, _ONE, _ONE
        a = self.reflectance.eval(si, active)
        return a[0], a[1], a[2]

    def _lanes(self, *values):
        """The kernel's inputs as 1-D numpy arrays (float32; the last, the
        active mask, bool).  In JIT variants the Dr.Jit arrays are evaluated
        together first, one kernel for all of them, and numpy then views
        their memory; converting them one by one would evaluate each
        component's expression separately."""
        if not self._scalar:
            dr.eval(*values)
        return tuple(_f32(v) for v in values[:-1]) + (_mask(values[-1]),)

    def _outputs(self, n, count):
        """In JIT variants, `count` new Dr.Jit arrays of n floats and writable
        numpy views of them: the kernel writes its results straight into
        Dr.Jit's memory (no numpy allocation, no copy)."""
        if self._scalar:
            return None, None
        arrays = [dr.empty(mi.Float, n) for _ in range(count)]
        dr.eval(*arrays)
        return arrays, tuple(np.asarray(a) for a in arrays)

    def _kernel_eval_pdf(self, si, wo, active, want_f, want_pdf):
        wi = si.wi
        lanes = self._lanes(wi.x, wi.y, wi.z, wo.x, wo.y, wo.z, *self._albedo(si, active), active)
        arrays, views = self._outputs(max(a.size for a in lanes), 4)
        if views is not None:
            views = tuple(v if want else None for v, want in
                          zip(views, (want_f, want_f, want_f, want_pdf)))
        f, p = self.kernel.eval_pdf(*lanes, want_f, want_pdf, views)
        # Inactive lanes are 0 already (the kernel skips them).
        if arrays is not None:
            return (mi.Spectrum(*arrays[:3]) if want_f else None), (arrays[3] if want_pdf else None)
        return (None if f is None else self._spectrum(f)), (None if p is None else self._float(p))

    def eval(self, ctx, si, wo, active=True):
        if self.kernel is not None:
            return self._kernel_eval_pdf(si, wo, active, True, False)[0]
        wi_np, wo_np, bad = self._pair(si.wi, wo)
        f = self._f_rgb(si, wi_np, wo_np, active) * np.abs(wo_np[:, 2])
        f = np.where(self._valid(wi_np, wo_np, bad), f, 0.0)
        return dr.select(active, self._spectrum(f), 0.0)

    def pdf(self, ctx, si, wo, active=True):
        if self.kernel is not None:
            return self._kernel_eval_pdf(si, wo, active, False, True)[1]
        wi_np, wo_np, bad = self._pair(si.wi, wo)
        p = np.where(self._valid(wi_np, wo_np, bad), self._pdf_np(wi_np, wo_np), 0.0)
        return dr.select(active, self._float(p), 0.0)

    def eval_pdf(self, ctx, si, wo, active=True):
        if self.kernel is not None:
            return self._kernel_eval_pdf(si, wo, active, True, True)
        return self.eval(ctx, si, wo, active), self.pdf(ctx, si, wo, active)

    def _sample_record(self, wo, pdf, weight, wi_z, active):
        """BSDFSample3f and weight from the kernel's or the numpy path's
        results: wo as three lanes, pdf (0 where the sample is invalid) and
        weight (three lanes), as Dr.Jit arrays or numpy arrays."""
        bs = dr.zeros(mi.BSDFSample3f)
        if isinstance(pdf, np.ndarray):
            bs.wo = mi.Vector3f(self._float(wo[0]), self._float(wo[1]), self._float(wo[2]))
            bs.pdf = self._float(pdf)
            weight = self._spectrum(weight)
        else:
            bs.wo = mi.Vector3f(*wo)
            bs.pdf = pdf
            weight = mi.Spectrum(*weight)
        bs.eta = 1.0
        reflect = mi.UInt32(+mi.BSDFFlags.GlossyReflection)
        if self.transmits:
            transmit = mi.UInt32(+mi.BSDFFlags.GlossyTransmission)
            if self._scalar:
                bs.sampled_type = transmit if bs.wo.z * wi_z < 0 else reflect
            else:
                bs.sampled_type = dr.select(bs.wo.z * wi_z < 0, transmit, reflect)
        else:
            bs.sampled_type = reflect
        bs.sampled_component = mi.UInt32(0)
        if self._scalar:
            return bs, weight if (active and bs.pdf > 0) else mi.Spectrum(0.0)
        # Invalid and inactive lanes have pdf = weight = 0.
        return bs, weight

    def _kernel_sample(self, si, sample2, active):
        wi = si.wi
        lanes = self._lanes(wi.x, wi.y, wi.z, sample2[0], sample2[1], *self._albedo(si, active), active)
        arrays, views = self._outputs(max(a.size for a in lanes), 7)
        wo, pdf, weight = self.kernel.sample(*lanes, views)
        if arrays is not None:
            wo, pdf, weight = arrays[:3], arrays[3], arrays[4:]
        return self._sample_record(wo, pdf, weight, wi.z, active)

    def sample(self, ctx, si, sample1, sample2, active=True):
        if self.kernel is not None:
            return self._kernel_sample(si, sample2, active)
        wi_np, bad = _vectors(si.wi)
        u1, u2 = _lanes(sample2[0], sample2[1])
        n = max(len(wi_np), len(u1))
        wi_np, bad = np.broadcast_to(wi_np, (n, 3)), np.broadcast_to(bad, (n,))
        u = np.stack(np.broadcast_arrays(u1, u2), axis=1)
        u = np.broadcast_to(u, (n, 2))
        if self.sampler is None:
            r, phi = np.sqrt(u[:, 0]), 2 * math.pi * u[:, 1]
            wo_np = np.stack([r * np.cos(phi), r * np.sin(phi), np.sqrt(1 - u[:, 0])], axis=1)
            pdf = self._pdf_np(wi_np, wo_np)
        else:
            wo_np, _, pdf = self.sampler.sample(wi_np, np.minimum(u, 1 - 1e-12))
        valid = self._valid(wi_np, wo_np, bad) & (pdf > 0) & _mask(active)
        f = self._f_rgb(si, wi_np, wo_np, active) * np.abs(wo_np[:, 2])
        weight = np.where(valid, f / np.where(valid, pdf, 1.0), 0.0)
        return self._sample_record(wo_np.T, np.where(valid, pdf, 0.0), weight,
                                   self._float(wi_np[:, 2]), active)

    def traverse(self, callback):
        pass

    def to_string(self):
        return (f"brdftab[filename='{self.filename}', table='{self.table_name}', "
                f"params={self.params}, reflectance={'texture' if self.reflectance else None}]")


def register():
    """Register the BSDF plugin `brdftab` with Mitsuba (after mi.set_variant).
    In JIT variants (llvm_*, cuda_*) this also switches off Dr.Jit's symbolic
    loops and calls: the plugin evaluates tables on numpy arrays."""
    if not mi.variant().startswith("scalar"):
        dr.set_flag(dr.JitFlag.SymbolicLoops, False)
        dr.set_flag(dr.JitFlag.SymbolicCalls, False)
    # mi.BSDF is the class of the variant set when register() runs.
    # (nanobind classes take one base: the methods are copied in.)
    methods = {k: v for k, v in vars(_TableBSDF).items() if k not in ("__dict__", "__weakref__")}
    plugin = type("TableBSDF", (mi.BSDF,), methods)
    mi.register_bsdf(PLUGIN_NAME, lambda props: plugin(props))
