// Registry entry and host compilation of the interfaced-lambertian model
// (Meneveaux et al., interfaced Lambertian microfacets; kernel math in
// kernels/models/interfaced_lambertian.h).
#include "kernels/models/interfaced_lambertian.h"

#include <vector>

#include "host/models/registry.h"
#include "kernels/common/compat.h"
#include "kernels/common/sampler.h"

namespace brdftab::detail {

namespace {

ModelInfo interfaced_lambertian_model() {
    ModelBuilder b("interfaced-lambertian", 30);
    b.citation(
        "D. Meneveaux, B. Bringier, E. Tauzia, M. Ribardiere, L. Simonot. Rendering Rough "
        "Opaque Materials with Interfaced Lambertian Microfacets. IEEE Transactions on "
        "Visualization and Computer Graphics 24(3), 2018 (preprint: Isotropic and Anisotropic "
        "Interfaced Lambertian Microfacets, 2015).");
    b.description(
        "Rough plastics, paints, ceramics: every microfacet is a flat dielectric interface "
        "(relative index ni) over a Lambertian substrate (Kd). Body term (eq. 12) tabulated "
        "without its Kd prefactor, specular term (eq. 3), r_e/r_i (eqs. 9-10), albedos, and "
        "multiple V-cavity bounces per order (eqs. 22-23, point estimator).");
    b.kernel("models/interfaced_lambertian.h", "interfaced_lambertian_sample",
             &interfaced_lambertian_sample);
    b.counts(IL_PARAM_COUNT, IL_OPT_COUNT, IL_Q_COUNT);

    b.parameter(
        IL_PARAM_SIGMA,
        parameter_info("sigma", "deg",
                       "Gaussian-of-normals width (distribution = gaussian-ts only, eq. 13); "
                       "0 = flat",
                       0, 89, 20)
            .degrees());
    b.parameter(
        IL_PARAM_ALPHA,
        parameter_info("alpha", "1", "Beckmann/GGX width (isotropic; eqs. 15, 20)", 0, 4, 0.3)
            .open_min());
    b.parameter(IL_PARAM_ALPHA_X,
                parameter_info("alpha_x", "1",
                               "anisotropic Beckmann/GGX width along x; 0 = use alpha", 0, 4, 0));
    b.parameter(IL_PARAM_ALPHA_Y,
                parameter_info("alpha_y", "1",
                               "anisotropic Beckmann/GGX width along y; 0 = use alpha", 0, 4, 0));
    b.parameter(IL_PARAM_NI,
                parameter_info("ni", "1", "relative index n1/n0 of the facet interface (eq. 7)", 1,
                               4, 1.5));
    b.parameter(
        IL_PARAM_KD,
        parameter_info("kd", "1",
                       "Lambertian substrate reflectance Kd (brdf, albedo_body, Rb, vcavity)", 0, 1,
                       0.5));
    b.parameter(IL_PARAM_ORDER,
                parameter_info(
                    "order", "1",
                    "vcavity: bounce order, 0 = all orders summed (up to 128), k >= 1 = exactly k "
                    "facet interactions (integer)",
                    0, 128, 0)
                    .whole());
    b.option(
        IL_OPT_DISTRIBUTION,
        {"distribution",
         "normal distribution / shadowing pair (Table 2): Gaussian normals + Torrance-Sparrow "
         "(eqs. 13-14), Beckmann + TS (eqs. 15, 14), Beckmann + Smith (eqs. 15-19), GGX + Smith "
         "(eqs. 20-21)",
         {"gaussian-ts", "beckmann-ts", "beckmann-smith", "ggx-smith"},
         "beckmann-smith"});
    b.option(
        IL_OPT_SAMPLING,
        {"sampling",
         "how microfacet normals are sampled: visible normals of the Beckmann/GGX distribution "
         "(bounded weights), or D(m)|m.n| (eqs. 29-31). Gaussian always samples D(m)|m.n| "
         "(exactly, by rejection)",
         {"visible", "distribution"},
         "visible"});
    b.option(IL_OPT_INTERREFLECTION,
             {"interreflection",
              "vcavity: at each facet hit inside the groove, full = specular reflection with "
              "probability F or body scattering; body = body scattering only (specular light "
              "inside the groove dropped)",
              {"full", "body"},
              "full"});

    const std::vector<std::string> all_dirs = {"theta_i", "phi_i", "theta_o", "phi_o"};
    const std::vector<std::string> shape = {"distribution"};
    const std::vector<std::string> sampled = {"distribution", "sampling"};
    auto q = [](const char* name, int id, const char* units, QuantityKind kind,
                std::vector<std::string> dirs, std::vector<std::string> opts, const char* desc,
                const char* eqs, Method method, unsigned dims) {
        QuantityInfo x;
        x.name = name;
        x.id = id;
        x.units = units;
        x.kind = kind;
        x.directions = std::move(dirs);
        x.uses_options = std::move(opts);
        x.description = desc;
        x.equations = eqs;
        x.default_method = method;
        x.dimensions = dims;
        return x;
    };
    const auto CF = QuantityKind::ClosedForm;
    const auto IN = QuantityKind::Integral;
    const auto QU = QuantityKind::Quadrature;
    b.quantity(q("body", IL_Q_BODY, "1", IN, all_dirs, sampled,
                 "integral of eq. 12 WITHOUT the prefactor Kd/(pi ni^2 (1 - ri Kd)): "
                 "int T(i,m) T(o,m) D G |i.m||o.m|/(|i.n||o.n|) dm",
                 "eqs. 7, 12-21; sampling eqs. 29-31 or visible normals", Method::Rqmc, 2));
    b.quantity(q("brdf", IL_Q_BRDF, "1/sr", IN, all_dirs, sampled,
                 "f = Kd/(pi ni^2 (1 - ri Kd)) * body + specular", "eqs. 3, 11, 12", Method::Rqmc, 2));
    b.quantity(q("specular", IL_Q_SPECULAR, "1/sr", CF, all_dirs, shape,
                 "specular term F D G / (4 |i.n||o.n|)", "eq. 3 (denominator corrected), 7",
                 Method::ClosedForm, 0));
    b.quantity(q("re", IL_Q_RE, "1", CF, {}, {}, "external diffuse reflectance r_e (Molenaar)",
                 "eq. 10", Method::ClosedForm, 0));
    b.quantity(q("ri", IL_Q_RI, "1", CF, {}, {},
                 "internal diffuse reflectance r_i = 1 - (1 - r_e)/ni^2", "eqs. 9-10",
                 Method::ClosedForm, 0));
    b.quantity(q("re_integral", IL_Q_RE_INTEGRAL, "1", QU, {}, {},
                 "r_e by Gauss-Legendre quadrature of int F(mu) 2 mu dmu", "eqs. 7, 9 (external)",
                 Method::Quadrature, 0));
    b.quantity(q("ri_integral", IL_Q_RI_INTEGRAL, "1", QU, {}, {},
                 "r_i by Gauss-Legendre quadrature of eq. 9 (internal Fresnel, total internal "
                 "reflection)",
                 "eqs. 7, 9", Method::Quadrature, 0));
    b.quantity(q("Rs", IL_Q_RS, "1", CF, {}, {}, "specular sampling weight R_s = r_e", "§4.1",
                 Method::ClosedForm, 0));
    b.quantity(q("Rb", IL_Q_RB, "1", CF, {}, {},
                 "body sampling weight R_b = (1 - r_e)^2 Kd / (ni^2 (1 - Kd r_i))", "§4.1",
                 Method::ClosedForm, 0));
    b.quantity(q("albedo_body", IL_Q_ALBEDO_BODY, "1", IN, {"theta_i", "phi_i"}, sampled,
                 "directional albedo of the body term (with the Kd prefactor)", "eqs. 8, 12",
                 Method::Rqmc, 4));
    b.quantity(q("albedo_specular", IL_Q_ALBEDO_SPECULAR, "1", IN, {"theta_i", "phi_i"}, sampled,
                 "directional albedo of the specular term", "eq. 3", Method::Rqmc, 2));
    b.quantity(q("vcavity", IL_Q_VCAVITY, "1/sr", IN, all_dirs,
                 {"distribution", "sampling", "interreflection"},
                 "body reflection with multiple bounces inside V-cavities (point estimator at o), "
                 "bounce order selected by `order` (0 = all); uses the chosen distribution with "
                 "V-cavity visibility whatever its GAF",
                 "eqs. 8, 14, 22-23", Method::Rqmc, 8));
    // A vcavity sample is the facet, then the walk in its groove: staged
    // sample-parallel launches run the facet as a vectorised kernel of its
    // own (kernels/models/interfaced_lambertian.h, interfaced_lambertian_stage;
    // docs/benchmarks.md, "Sample-parallel launches").
    b.quantity_by_id(IL_Q_VCAVITY).staged = {"interfaced_lambertian_stage",
                                             "interfaced_lambertian_rest", IL_VCAVITY_STAGE};

    // Launch preferences (registry.h; docs/benchmarks.md, "Sample-parallel
    // launches").  The visible-normal search of Beckmann normals is a loop
    // that keeps PoCL's work-item loop scalar; with a fixed number of steps
    // (and a redo of the rare unfinished sample) it vectorises.  vcavity's
    // facet, its first stage, is the same search.
    const std::vector<OptionChoice> beckmann = {{"distribution", "beckmann-smith"},
                                                {"distribution", "beckmann-ts"}};
    b.quantity_by_id(IL_Q_BODY).fixed_step_solver = beckmann;
    b.quantity_by_id(IL_Q_VCAVITY).fixed_step_solver = beckmann;
    const OptionChoice visible = {"sampling", "visible"};
    for (Method method : {Method::MonteCarlo, Method::Rqmc}) {
        // body sample-parallel: Beckmann-Smith with visible normals (the
        // fixed-step search) 2.2x less CPU time, GGX-Smith 1.2-1.4x; not
        // Beckmann-TS, Gaussian-TS or normals sampled from the distribution
        // (1.4-1.9x slower).
        QuantityInfo& body = b.quantity_by_id(IL_Q_BODY);
        body.sample_parallel.push_back({method, {{"distribution", "beckmann-smith"}, visible}});
        body.sample_parallel.push_back({method, {{"distribution", "ggx-smith"}}});
        // vcavity in two stages where its facet search takes fixed steps:
        // Beckmann-Smith 4.3x the serial host against 3.5x, the Beckmann-TS
        // preset 5.6-5.8 s against 7.4-7.5 s; not GGX-Smith (4.6-4.8 s
        // against 3.4 s).
        QuantityInfo& vcavity = b.quantity_by_id(IL_Q_VCAVITY);
        vcavity.sample_parallel.push_back({method, {{"distribution", "beckmann-smith"}, visible}});
        vcavity.sample_parallel.push_back({method, {{"distribution", "beckmann-ts"}, visible}});
    }
    // Forced inlining: body 1.6x and vcavity 1.2x per CPU-second, presets
    // bit-identical, even where its sample loops stay scalar.
    b.force_inline();

    // Float against double (registry.h, docs/precision.md).
    b.float_vs_double(IL_Q_BODY, 4.4e-05);
    b.float_vs_double(IL_Q_BRDF, 0.97, "the specular peak with alpha = 0.1 (double 796, float 20)");
    b.float_vs_double(IL_Q_RI, 0);
    b.float_vs_double(IL_Q_VCAVITY, 2.3e-05);

    b.bench({"body"});
    b.bench({"vcavity"});
    return b.build();
}

BRDFTAB_REGISTER_MODEL(interfaced_lambertian_model);

}  // namespace

}  // namespace brdftab::detail
