// Registry entry and host compilation of the micrograin model (Lucas et al.
// 2024, kernels/models/micrograin.h).
#include "kernels/models/micrograin.h"

#include <vector>

#include "host/models/registry.h"
#include "kernels/common/compat.h"
#include "kernels/common/sampler.h"

namespace brdftab::detail {

namespace {

ModelInfo micrograin_model() {
    ModelBuilder b("micrograin", 60);
    b.citation(
        "S. Lucas, M. Ribardiere, R. Pacanowski, P. Barla. A Fully-correlated Anisotropic "
        "Micrograin BSDF Model. ACM Transactions on Graphics 43(4), article 111, 2024. "
        "doi:10.1145/3658224");
    b.description(
        "Porous layer of random half-ellipsoid grains (dust, rust, dirt) over a base surface: "
        "anisotropic micrograin NDF, height- and direction-correlated GAF from exact shadow "
        "areas, pore visibility, the full BRDF, and an explicit ray-traced grain simulator "
        "as reference.");
    b.kernel("models/micrograin.h", "micrograin_sample", &micrograin_sample);
    b.counts(MG_PARAM_COUNT, MG_OPT_COUNT, MG_Q_COUNT);

    b.parameter(
        MG_PARAM_TAU0,
        parameter_info("tau0", "1",
                       "filling factor: fraction of the base covered by grains (eq. 8)", 0, 1, 0.5)
            .open_min()
            .open_max());
    b.parameter(
        MG_PARAM_BETA_X,
        parameter_info("beta_x", "1", "lateral stretch along x: grain semi-axis 1/beta_x (Fig. 2c)",
                       0.01, 10, 1));
    b.parameter(MG_PARAM_BETA_Y,
                parameter_info("beta_y", "1", "lateral stretch along y: grain semi-axis 1/beta_y",
                               0.01, 10, 1));
    b.parameter(
        MG_PARAM_H,
        parameter_info("h", "1", "height in the layer (shadow/overlap areas, GAF quantities), n.m'",
                       0, 1, 0));
    b.parameter(MG_PARAM_KD, parameter_info("kd", "1", "grain diffuse albedo (eq. 21)", 0, 1, 0.5));
    b.parameter(
        MG_PARAM_ETA,
        parameter_info("eta", "1",
                       "grain index of refraction (dielectric) or its real part (conductor)", 0, 10,
                       1.5)
            .open_min());
    b.parameter(
        MG_PARAM_K,
        parameter_info("k", "1", "grain extinction coefficient (conductor grains)", 0, 20, 0));
    b.parameter(MG_PARAM_BASE_ALBEDO,
                parameter_info("base_albedo", "1", "Lambertian base albedo", 0, 1, 0.5));
    b.parameter(MG_PARAM_BASE_ALPHA,
                parameter_info("base_alpha", "1",
                               "GGX width of the rough conductor/dielectric base", 0, 2, 0.2)
                    .open_min());
    b.parameter(
        MG_PARAM_BASE_ETA,
        parameter_info("base_eta", "1",
                       "index of the rough base: conductor real part, or dielectric relative index",
                       0, 10, 0.2)
            .open_min());
    b.parameter(
        MG_PARAM_BASE_K,
        parameter_info("base_k", "1", "rough-conductor base extinction coefficient", 0, 20, 3.0));
    b.option(
        MG_OPT_GRAIN,
        {"grain",
         "grain reflectance: diffuse (kd, no Fresnel), dielectric (Fresnel from eta plus the kd "
         "lobe weighted by (1-F)(1-F)), conductor (Fresnel from eta + i k, same kd weighting)",
         {"diffuse", "dielectric", "conductor"},
         "diffuse"});
    b.option(MG_OPT_BASE,
             {"base",
              "base (bulk) BRDF: absorbing, Lambertian (base_albedo), rough conductor (GGX "
              "base_alpha, height-correlated Smith, Fresnel base_eta + i base_k), or rough "
              "dielectric (same surface, dielectric Fresnel with relative index base_eta; "
              "reflection only)",
              {"absorbing", "lambertian", "conductor", "dielectric"},
              "absorbing"});
    b.option(MG_OPT_CORRELATION,
             {"correlation",
              "distant GAF: direction-correlated with the shadow overlap (eqs. 18-19) or the "
              "uncorrelated product G1 G1 (eq. 17); both are height-correlated",
              {"direction", "none"},
              "direction"});
    b.option(MG_OPT_WEIGHTING,
             {"weighting",
              "component weights: this paper tau0 f^S + Vp f^B (eqs. 20, 23), or Lucas 2023 "
              "w+ f^S + (1-w+) f^B with 1-w+ = (1-tau0) G1(i,0) G1(o,0) (eqs. 1, 4, 25)",
              {"lucas2024", "lucas2023"},
              "lucas2024"});

    const std::vector<std::string> dir_i = {"theta_i", "phi_i"};
    const std::vector<std::string> dir_io = {"theta_i", "phi_i", "theta_o", "phi_o"};
    const std::vector<std::string> all_opts = {"grain", "base", "correlation", "weighting"};
    const auto I = QuantityKind::Integral;
    // A closed-form quantity (no random dimensions).
    auto closed = [](const char* name, int id, const char* desc, std::vector<std::string> dirs,
                     std::vector<std::string> opts, const char* eqs, const char* units = "1") {
        return QuantityInfo{name,  id, desc, units, QuantityKind::ClosedForm, std::move(dirs),
                            std::move(opts), eqs, Method::ClosedForm, 0};
    };
    b.quantity(closed("ndf", MG_Q_NDF,
                      "normal distribution D(m) with m = (theta_i, phi_i); int D(m) m.n dm = 1",
                      dir_i, {}, "eqs. 10-12", "1/sr"));
    b.quantity(closed("alpha_x", MG_Q_ALPHA_X, "equivalent GGX width along x (eq. 28, sign corrected)",
                      {}, {}, "eq. 28"));
    b.quantity(closed("alpha_y", MG_Q_ALPHA_Y, "equivalent GGX width along y (eq. 28, sign corrected)",
                      {}, {}, "eq. 28"));
    b.quantity(closed("shadow_area", MG_Q_SHADOW_AREA,
                      "area of the shadow cast from direction i by one grain (unit radius before "
                      "stretching) on the plane at height h, outside the grain: sigma_s(i', h)/(beta_x "
                      "beta_y)",
                      dir_i, {}, "Appendix A, §4.2 (det E^-1)"));
    b.quantity(closed("overlap_area", MG_Q_OVERLAP_AREA,
                      "area of the overlap of the shadows from i and o at height h: sigma_cap(i', o', "
                      "h)/(beta_x beta_y)",
                      dir_io, {}, "Appendix B (equivalent polar decomposition, see docs)"));
    b.quantity(closed("g1_dist", MG_Q_G1_DIST, "distant masking term G1_dist(i, h)", dir_i, {},
                      "eqs. 16, 9; anisotropic via E (§4.2)"));
    b.quantity(closed("g_dist", MG_Q_G_DIST, "distant bidirectional GAF G_dist(i, o, h)", dir_io,
                      {"correlation"}, "eq. 19 (correlation=direction) or eq. 17 (none)"));
    b.quantity(closed("pore_visibility", MG_Q_PORE_VISIBILITY,
                      "pore (base) visibility Vp(i, o) = (1 - tau0) G_dist(i, o, 0)", dir_io,
                      {"correlation"}, "eq. 23, Appendix C"));
    b.quantity(QuantityInfo{
        "brdf", MG_Q_BRDF,
        "full BRDF tau0 f^S + Vp f^B; the diffuse-grain part (eq. 21) is a Monte Carlo "
        "integral over microfacet normals (constant samples when kd = 0 or grains are "
        "diffuse-free)",
        "1/sr", I, dir_io, all_opts, "eqs. 20-23 (weighting=lucas2023: eqs. 1, 25)", Method::Rqmc, 2});
    b.quantity(
        QuantityInfo{"albedo", MG_Q_ALBEDO,
                     "directional albedo: integral of brdf cos(theta_o) over outgoing directions",
                     "1", I, dir_i, all_opts, "eqs. 20-23 integrated over o", Method::Rqmc, 6});
    b.quantity(QuantityInfo{"explicit_g1", MG_Q_EXPLICIT_G1,
                            "reference: G1_dist(i, h) ray-traced on explicit random grains (fraction "
                            "of pore points at height h that see i)",
                            "1", I, dir_i, {}, "§5.1 simulation; compare eq. 16", Method::MonteCarlo,
                            2});
    b.quantity(QuantityInfo{"explicit_g", MG_Q_EXPLICIT_G,
                            "reference: G_dist(i, o, h) ray-traced on explicit random grains", "1", I,
                            dir_io, {}, "§5.1 simulation; compare eqs. 17-19", Method::MonteCarlo, 2});
    b.quantity(QuantityInfo{
        "explicit_brdf", MG_Q_EXPLICIT_BRDF,
        "reference: single-scattering BRDF ray-traced on explicit random grains; non-Dirac "
        "lobes only (grain kd lobe and base), the grain specular lobe is not simulated",
        "1/sr", I, dir_io, {"grain", "base"}, "§5.1 simulation; compare eqs. 20-23",
        Method::MonteCarlo, 2});
    b.quantity(closed("p_bulk", MG_Q_P_BULK, "probability of sampling the base, eq. 26", dir_i, {},
                      "eq. 26"));
    b.quantity(closed("p_diffuse", MG_Q_P_DIFFUSE,
                      "probability of sampling the grain diffuse lobe, eq. 27", dir_i, {"grain"},
                      "eq. 27"));
    b.quantity(QuantityInfo{"explicit_coverage", MG_Q_COVERAGE,
                            "reference: fraction of the plane at height h inside grains, ray-free "
                            "check of the simulator's density (exact: 1 - (1 - tau0)^(1 - h^2))",
                            "1", I, {}, {}, "eqs. 7-9", Method::MonteCarlo, 2});

    // Forced inlining (registry.h): measured faster, every preset
    // bit-identical.  Not sample-parallel: brdf measured 0.6-1.0x the usual
    // kernel (calls, loops of data-dependent length, inner sums).
    b.force_inline();
    // Float against double (registry.h, docs/precision.md).
    b.float_vs_double(MG_Q_ALBEDO, 2.6e-06);
    b.float_vs_double(MG_Q_BRDF, 1e-05);
    b.float_vs_double(MG_Q_EXPLICIT_BRDF, 0.71, "the ray and grain geometry needs double");
    b.float_vs_double(MG_Q_G1_DIST, 1.1e-07);
    b.float_vs_double(MG_Q_G_DIST, 5.2e-07);
    b.float_vs_double(MG_Q_PORE_VISIBILITY, 6.9e-07);
    b.bench({"g_dist"});
    b.bench({"brdf"});
    return b.build();
}

BRDFTAB_REGISTER_MODEL(micrograin_model);

}  // namespace

}  // namespace brdftab::detail
