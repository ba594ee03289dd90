"""The sphere-on-a-plane scene of render_oren_nayar.py, rendered twice in
Mitsuba 3 from the same exact Oren-Nayar table: left with Mitsuba's own
`measured` BSDF reading the table exported as an RGL file (`brdftab export
--rgl`, no plugin of ours), right with brdftab's Python plugin reading the
table itself.  Writes one PNG and prints the render times and the images'
difference.

    bash scripts/setup.sh --mitsuba
    build/brdftab generate examples/mitsuba/oren-nayar-sphere.toml -o oren-nayar-sphere.h5
    build/brdftab export oren-nayar-sphere.h5 --table brdf --rgl oren-nayar-sphere.bsdf \\
        --rgb 0.85,0.55,0.35
    DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM-19.so PYTHONPATH=build/python \\
        .venv-mitsuba/bin/python examples/mitsuba/render_rgl.py oren-nayar-sphere.h5 \\
        oren-nayar-sphere.bsdf docs/figures/mitsuba-rgl-measured.png

docs/format.md ("RGL export") shows the result and the measured figures.
"""

import sys
import time

import drjit as dr
import mitsuba as mi
import numpy as np

mi.set_variant("llvm_ad_rgb")

import brdftab.mitsuba  # noqa: E402  (after the variant is set)

ALBEDO = [0.85, 0.55, 0.35]  # must match the --rgb of the export
RESOLUTION = 128
SPP = 64


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
        "sun": {"type": "directional", "direction": [-0.25, -0.35, -1.0],
                "irradiance": {"type": "rgb", "value": 3.0}},
        "sky": {"type": "constant", "radiance": {"type": "rgb", "value": 0.08}},
        "sphere": {"type": "sphere", "center": [0, 0.75, 0], "radius": 0.75, "bsdf": material},
        "floor": {"type": "rectangle",
                  "to_world": mi.ScalarTransform4f().rotate([1, 0, 0], -90).scale(4),
                  "bsdf": material},
    })


def main(table_path, rgl_path, png_path):
    brdftab.mitsuba.register()
    measured = {"type": "measured", "filename": rgl_path}
    plugin = {"type": "brdftab", "filename": table_path, "table": "brdf",
              "reflectance": {"type": "rgb", "value": ALBEDO}}
    images = []
    for name, material in (("measured (RGL file)", measured), ("brdftab plugin", plugin)):
        start = time.time()
        images.append(np.array(mi.render(scene(material), seed=1)))
        print(f"{name}: {time.time() - start:.1f} s ({RESOLUTION}x{RESOLUTION}, {SPP} spp)")
    a, b = images
    # The noise floor: the plugin against itself with other random numbers.
    c = np.array(mi.render(scene(plugin), seed=2))

    def rms(x, y):
        return np.sqrt(np.mean((x - y) ** 2)) / b.mean()

    print(f"mean over pixels and channels: measured {a.mean():.4f}, plugin {b.mean():.4f} "
          f"(relative difference {abs(a.mean() - b.mean()) / b.mean():.2%}); RMS pixel difference "
          f"{rms(a, b):.2%} of the mean (plugin against itself at another seed: {rms(c, b):.2%})")
    gap = np.ones((RESOLUTION, 4, 3))
    both = np.concatenate([a, gap, b], axis=1)
    mi.util.write_bitmap(png_path, mi.TensorXf(both.astype(np.float32)))
    print(f"wrote {png_path}")


if __name__ == "__main__":
    if len(sys.argv) != 4:
        sys.exit("usage: render_rgl.py TABLE.h5 TABLE.bsdf OUT.png")
    main(sys.argv[1], sys.argv[2], sys.argv[3])
