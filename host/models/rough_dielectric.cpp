// host_models.cpp — the model entries of the registry, and the host (C++)
// compilation of each model's kernel math, which is the serial reference path
// (`--device host`) and what the unit tests exercise.
//
// Adding a model: write kernels/models/<model>.h (sample function) and
// kernels/<model>.cl (entry kernel), then add an entry below.
#include "host/models/registry.h"
#include "kernels/models/rough_dielectric.h"

namespace brdftab::detail {

// Host (C++) compilation of the kernel's sample function: the `--device host`
// reference path.
REAL host_rough_dielectric_sample(const REAL* point, const int* options, int quantity,
                                  const bt_sampler* sampler) {
    return rough_dielectric_sample(point, options, quantity, sampler);
}

namespace {

ModelInfo rough_dielectric_model() {
    ModelInfo m;
    m.name = "rough-dielectric";
    m.citation =
        "B. Walter, S. R. Marschner, H. Li, K. E. Torrance. Microfacet Models for "
        "Refraction through Rough Surfaces. Eurographics Symposium on Rendering, 2007.";
    m.description =
        "Rough dielectric interface (glass, water, varnish): microfacet reflection and "
        "transmission with exact dielectric Fresnel, Beckmann/GGX/Phong normal "
        "distributions and Smith shadowing. Light may arrive from either side.";
    m.kernel_file = "rough_dielectric.cl";
    m.kernel_name = "rough_dielectric_estimate";

    m.parameters = {
        parameter_info("alpha", "1",
                       "roughness (Beckmann/GGX alpha; Phong uses alpha_p = 2/alpha^2 - 2)", 0, 4)
            .open_min(),
        parameter_info("eta", "1", "index of refraction, interior / exterior (may be < 1)", 0, 10)
            .open_min(),
    };

    m.options = {
        {"distribution", "microfacet normal distribution", {"beckmann", "ggx", "phong"}, "ggx"},
        {"g1",
         "Smith masking for Beckmann: exact (eq. 26), or Walter's rational fit (eq. 27); GGX is "
         "always exact (eq. 34); Phong always uses Walter's rational fit (eqs. 27, 31) whatever "
         "this option says",
         {"smith", "walter-fit"},
         "smith"},
        {"shadowing",
         "G from G1: separable G1(i)G1(o) (eq. 23), or height-correlated 1/(1+L(i)+L(o))",
         {"separable", "height-correlated"},
         "separable"},
        {"lobe", "albedo_avg: which lobes are counted", {"both", "reflection", "transmission"},
         "both"},
        {"side", "albedo_avg: light arriving from outside (above) or inside (below)",
         {"outside", "inside"},
         "outside"},
        {"sampling",
         "albedos: how microfacet normals are sampled: visible normals (Heitz 2018 for GGX, "
         "Heitz & d'Eon 2014 for Beckmann; weights bounded by 1) or Walter's m ~ D|m.n| "
         "(eqs. 28-35, weight eq. 41: heavy-tailed). Phong has no visible-normal sampler and "
         "always uses Walter's",
         {"visible", "walter"},
         "visible"},
    };

    const std::vector<std::string> all_dirs = {"theta_i", "phi_i", "theta_o", "phi_o"};
    const std::vector<std::string> shape_opts = {"distribution", "g1", "shadowing"};
    const std::vector<std::string> albedo_opts = {"distribution", "g1", "shadowing", "sampling"};
    auto closed = [&](const char* name, int id, const char* desc, const char* eqs) {
        QuantityInfo q;
        q.name = name;
        q.id = id;
        q.description = desc;
        q.units = "1/sr";
        q.kind = QuantityKind::ClosedForm;
        q.directions = all_dirs;
        q.uses_options = shape_opts;
        q.equations = eqs;
        q.default_method = "closed-form";
        return q;
    };
    auto integral = [&](const char* name, int id, const char* desc, const char* eqs,
                        std::vector<std::string> dirs, std::vector<std::string> opts,
                        unsigned dims) {
        QuantityInfo q;
        q.name = name;
        q.id = id;
        q.description = desc;
        q.units = "1";
        q.kind = QuantityKind::Integral;
        q.directions = std::move(dirs);
        q.uses_options = std::move(opts);
        q.equations = eqs;
        q.default_method = "rqmc";
        q.dimensions = dims;
        return q;
    };
    const char* kAlbedoEqs =
        "eqs. 14, 17, 20-22, 39-40; sampling=walter: eqs. 28-35 and weight eq. 41; "
        "sampling=visible: Heitz 2018 (JCGT 7(4), GGX) and Heitz & d'Eon 2014 (EGSR, "
        "Beckmann), weight F G/G1(i)";
    // ids: the `quantity` switch of rough_dielectric_sample (kernels/models/rough_dielectric.h)
    m.quantities = {
        closed("brdf", 0, "reflection f_r (0 when i and o are on opposite sides)",
               "eqs. 13, 20 (h_r, f_r), 22 (Fresnel), 23 (G)"),
        closed("btdf", 1, "transmission f_t (0 when i and o are on the same side)",
               "eqs. 16, 21 (h_t, f_t), 22 (Fresnel), 23 (G)"),
        closed("bsdf", 2, "f_r or f_t, whichever applies to the pair of sides",
               "eqs. 20-21"),
        integral("albedo_r", 3,
                 "directional reflectance: integral of f_r cos(theta_o) over outgoing directions",
                 kAlbedoEqs, {"theta_i"}, albedo_opts, 2),
        integral("albedo_t", 4,
                 "directional transmittance: integral of f_t |cos(theta_o)| over outgoing "
                 "directions",
                 kAlbedoEqs, {"theta_i"}, albedo_opts, 2),
        integral("albedo_avg", 5,
                 "cosine-weighted hemispherical average of the directional albedo, "
                 "2 * int E(mu) mu dmu, for the chosen lobe(s) and side",
                 kAlbedoEqs, {},
                 {"distribution", "g1", "shadowing", "lobe", "side", "sampling"}, 3),
    };
    m.host_fn = &host_rough_dielectric_sample;
    return m;
}

}  // namespace

std::vector<ModelInfo> build_model_list() { return {rough_dielectric_model()}; }

}  // namespace brdftab::detail
