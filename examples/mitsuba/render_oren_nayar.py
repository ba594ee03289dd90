"""Sphere on a plane in Mitsuba 3: the exact Oren-Nayar BRDF from a brdftab
table (left) next to the Oren-Nayar functional ("qualitative") approximation
as pbrt writes it (right), same roughness and albedo.  Writes one PNG.

    bash scripts/setup.sh --mitsuba
    build/brdftab generate examples/mitsuba/oren-nayar-sphere.toml -o oren-nayar-sphere.h5
    DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM-19.so PYTHONPATH=build/python \\
        .venv-mitsuba/bin/python examples/mitsuba/render_oren_nayar.py oren-nayar-sphere.h5 \\
        docs/figures/mitsuba-oren-nayar.png

docs/python.md shows the result and the measured time.  With --table-only
the script renders (and writes) the table's image alone, for timing the
plugin; with --diffuse it renders the same scene with Mitsuba's own
`diffuse` BSDF instead (same albedo), the time of everything but the
plugin.  --passes=N (default 8) renders the 128 spp as N renders of
128 / N spp with seeds 1 .. N and averages them; --passes=1 is one render
with seed 1.  Each render prints its time and the image's mean per
channel.
"""

import math
import sys
import time

import drjit as dr
import mitsuba as mi
import numpy as np

mi.set_variant("llvm_ad_rgb")

import brdftab.mitsuba  # noqa: E402  (after the variant is set)

SIGMA_DEG = 40.0                # must match examples/mitsuba/oren-nayar-sphere.toml
ALBEDO = [0.85, 0.55, 0.35]     # facet albedo rho per channel
RESOLUTION = 256
SPP = 128


class QualitativeOrenNayar(mi.BSDF):
    """Oren & Nayar's functional approximation, in the form pbrt uses:
    f = R/pi (A + B max(0, cos(phi_i - phi_o)) sin(alpha) tan(beta)),
    alpha = max(theta_i, theta_o), beta = min(theta_i, theta_o),
    A = 1 - s^2 / (2 (s^2 + 0.33)), B = 0.45 s^2 / (s^2 + 0.09), s = sigma in
    radians.  Sampled cosine-weighted."""

    def __init__(self, props):
        mi.BSDF.__init__(self, props)
        s2 = math.radians(float(props.get("sigma"))) ** 2
        self.a = 1 - s2 / (2 * (s2 + 0.33))
        self.b = 0.45 * s2 / (s2 + 0.09)
        self.reflectance = props.get_texture("reflectance")
        flags = mi.BSDFFlags.DiffuseReflection | mi.BSDFFlags.FrontSide
        self.m_components = [flags]
        self.m_flags = flags

    def _f(self, si, wo, active):
        wi = si.wi
        cos_i, cos_o = mi.Frame3f.cos_theta(wi), mi.Frame3f.cos_theta(wo)
        sin_i, sin_o = mi.Frame3f.sin_theta(wi), mi.Frame3f.sin_theta(wo)
        # cos(phi_i - phi_o) from the directions' projections on the plane.
        cos_phi = dr.select((sin_i > 1e-4) & (sin_o > 1e-4),
                            (wi.x * wo.x + wi.y * wo.y) / dr.maximum(sin_i * sin_o, 1e-8), 0.0)
        # sin(alpha) tan(beta): alpha the larger angle (the smaller cosine).
        sin_alpha = dr.select(cos_i > cos_o, sin_o, sin_i)
        tan_beta = dr.select(cos_i > cos_o, sin_i / cos_i, sin_o / dr.maximum(cos_o, 1e-8))
        value = self.a + self.b * dr.maximum(cos_phi, 0.0) * sin_alpha * tan_beta
        ok = active & (cos_i > 0) & (cos_o > 0)
        return dr.select(ok, self.reflectance.eval(si, active) * dr.inv_pi * value * cos_o, 0.0)

    def eval(self, ctx, si, wo, active=True):
        return self._f(si, wo, active)

    def pdf(self, ctx, si, wo, active=True):
        ok = (mi.Frame3f.cos_theta(si.wi) > 0) & (mi.Frame3f.cos_theta(wo) > 0)
        return dr.select(active & ok, mi.warp.square_to_cosine_hemisphere_pdf(wo), 0.0)

    def eval_pdf(self, ctx, si, wo, active=True):
        return self.eval(ctx, si, wo, active), self.pdf(ctx, si, wo, active)

    def sample(self, ctx, si, sample1, sample2, active=True):
        bs = dr.zeros(mi.BSDFSample3f)
        bs.wo = mi.warp.square_to_cosine_hemisphere(sample2)
        bs.pdf = mi.warp.square_to_cosine_hemisphere_pdf(bs.wo)
        bs.eta = 1.0
        bs.sampled_type = mi.UInt32(+mi.BSDFFlags.DiffuseReflection)
        bs.sampled_component = mi.UInt32(0)
        ok = active & (mi.Frame3f.cos_theta(si.wi) > 0) & (bs.pdf > 0)
        weight = self._f(si, bs.wo, ok) / dr.maximum(bs.pdf, 1e-12)
        return bs, dr.select(ok, weight, 0.0)

    def traverse(self, callback):
        pass

    def to_string(self):
        return "QualitativeOrenNayar[]"


def scene(material):
    return mi.load_dict({
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 4},
        "sensor": {
            "type": "perspective", "fov": 30,
            "to_world": mi.ScalarTransform4f().look_at(origin=[0, 1.6, 6.5], target=[0, 0.75, 0],
                                                       up=[0, 1, 0]),
            "film": {"type": "hdrfilm", "width": RESOLUTION, "height": RESOLUTION,
                     "pixel_format": "rgb"},
            "sampler": {"type": "independent", "sample_count": SPP},
        },
        # Light from just behind the camera: where Oren-Nayar differs most
        # from Lambert (the flat, "full moon" look of rough surfaces).
        "sun": {"type": "directional", "direction": [-0.25, -0.35, -1.0],
                "irradiance": {"type": "rgb", "value": 3.0}},
        "sky": {"type": "constant", "radiance": {"type": "rgb", "value": 0.08}},
        "sphere": {"type": "sphere", "center": [0, 0.75, 0], "radius": 0.75, "bsdf": material},
        "floor": {"type": "rectangle",
                  "to_world": mi.ScalarTransform4f().rotate([1, 0, 0], -90).scale(4),
                  "bsdf": material},
    })


def render(the_scene, passes):
    """SPP samples per pixel in `passes` renders of SPP / passes each (seeds
    1, 2, ...), averaged.  With symbolic loops off (the plugin's register())
    Mitsuba traces every sample of a render as one wavefront: at 256^2 x 128
    spp its arrays hold 33 MB each, which go back to the system when freed
    and come back as fresh, zeroed pages (system time: docs/python.md); at
    16 spp (4 MB) they are reused."""
    image = None
    for k in range(passes):
        one = mi.render(the_scene, seed=1 + k, spp=SPP // passes)
        image = one if image is None else image + one
    image = image / passes if passes > 1 else image
    dr.eval(image)
    return image


def main(table_path, png_path, table_only=False, diffuse=False, passes=8):
    brdftab.mitsuba.register()
    mi.register_bsdf("qualitative_oren_nayar", lambda props: QualitativeOrenNayar(props))
    albedo = {"type": "rgb", "value": ALBEDO}
    exact = {"type": "brdftab", "filename": table_path, "table": "brdf", "reflectance": albedo}
    approx = {"type": "qualitative_oren_nayar", "sigma": SIGMA_DEG, "reflectance": albedo}
    images = []
    materials = [("exact table", exact), ("pbrt approximation", approx)]
    if diffuse:
        materials = [("Mitsuba diffuse", {"type": "diffuse", "reflectance": albedo})]
    for name, material in materials[:1] if table_only or diffuse else materials:
        start = time.time()
        images.append(render(scene(material), passes))
        mean = np.array(images[-1]).reshape(-1, 3).mean(axis=0)
        print(f"{name}: {time.time() - start:.1f} s ({RESOLUTION}x{RESOLUTION}, {SPP} spp), "
              f"mean {mean[0]:.5f} {mean[1]:.5f} {mean[2]:.5f}")
    # Side by side, 4 white columns between.
    gap = np.ones((RESOLUTION, 4, 3))
    both = np.array(images[0]) if table_only or diffuse else \
        np.concatenate([np.array(images[0]), gap, np.array(images[1])], axis=1)
    mi.util.write_bitmap(png_path, mi.TensorXf(both.astype(np.float32)))
    print(f"wrote {png_path}")


if __name__ == "__main__":
    flags = {"--table-only", "--diffuse"}
    passes = [a for a in sys.argv[1:] if a.startswith("--passes=")]
    args = [a for a in sys.argv[1:] if a not in flags and a not in passes]
    if len(args) != 2 or (passes and passes[-1][9:] not in ("1", "2", "4", "8", "16")):
        sys.exit("usage: render_oren_nayar.py TABLE.h5 OUT.png [--table-only | --diffuse] "
                 "[--passes=1|2|4|8|16 (default 8)]")
    main(args[0], args[1], table_only="--table-only" in sys.argv[1:],
         diffuse="--diffuse" in sys.argv[1:], passes=int(passes[-1][9:]) if passes else 8)
