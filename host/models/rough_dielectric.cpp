// Registry entry of the rough-dielectric model (Walter et al. 2007; kernel
// math in kernels/models/rough_dielectric.h, docs/models/rough-dielectric.md).
#include "kernels/models/rough_dielectric.h"

#include "host/core/text.h"
#include "host/models/registry.h"

namespace brdftab::detail {

namespace {

// Walter's Phong exponent alpha_p = 2/alpha^2 - 2 (section 5.2) is <= 0 for
// alpha >= 1: eq. 30 then no longer describes a distribution peaked at the
// normal (alpha = 1 is uniform in solid angle, alpha > sqrt(2) grows toward
// grazing), the fitted G1 of eq. 31 is far from Smith's, and the albedos leave
// [0, 1] (alpha = 1: 1.04, alpha = 4: 7.8e30).  So Phong is refused there,
// for every quantity; Beckmann and GGX keep the whole range (0, 4].
std::string check_phong_alpha(const QuantityInfo&, const double* point,
                              const std::vector<int>& options) {
    if (options.size() <= RD_OPT_DISTRIBUTION || options[RD_OPT_DISTRIBUTION] != BT_MF_PHONG)
        return "";
    const double alpha = point[RD_PARAM_ALPHA];
    if (alpha > 0 && alpha < 1) return "";
    return "alpha = " + number_text(alpha) +
           " is out of range for distribution = phong; allowed: (0, 1) (the Phong exponent "
           "2/alpha^2 - 2 must be > 0; beckmann and ggx allow (0, 4])";
}

// check_phong_alpha over a span of cells (ModelInfo::cells_pass): the same
// test, without a message, so that the engine's per-cell check costs a
// comparison; NaN fails both.
bool phong_alpha_cells_pass(const QuantityInfo&, const double* points, std::size_t count,
                            std::size_t stride, const std::vector<int>& options) {
    if (options.size() <= RD_OPT_DISTRIBUTION || options[RD_OPT_DISTRIBUTION] != BT_MF_PHONG)
        return true;
    for (std::size_t k = 0; k < count; ++k) {
        const double alpha = points[k * stride + RD_PARAM_ALPHA];
        if (!(alpha > 0 && alpha < 1)) return false;
    }
    return true;
}

ModelInfo rough_dielectric_model() {
    ModelBuilder b("rough-dielectric", 10);
    b.citation(
        "B. Walter, S. R. Marschner, H. Li, K. E. Torrance. Microfacet Models for "
        "Refraction through Rough Surfaces. Eurographics Symposium on Rendering, 2007.");
    b.description(
        "Rough dielectric interface (glass, water, varnish): microfacet reflection and "
        "transmission with exact dielectric Fresnel, Beckmann/GGX/Phong normal "
        "distributions and Smith shadowing. Light may arrive from either side.");
    b.kernel("models/rough_dielectric.h", "rough_dielectric_sample", &rough_dielectric_sample);
    b.counts(RD_PARAM_COUNT, RD_OPT_COUNT, RD_Q_COUNT);

    b.parameter(
        RD_PARAM_ALPHA,
        parameter_info("alpha", "1",
                       "roughness (Beckmann/GGX alpha; Phong uses alpha_p = 2/alpha^2 - 2)", 0, 4)
            .open_min());
    b.parameter(
        RD_PARAM_ETA,
        parameter_info("eta", "1", "index of refraction, interior / exterior (may be < 1)", 0, 100)
            .open_min());

    b.parameter(
        RD_PARAM_NODES,
        parameter_info("nodes", "1",
                       "method quadrature (albedos): Gauss-Legendre nodes per sub-interval in each "
                       "of the two directions (the error estimate is the distance to the rule with "
                       "half the nodes)",
                       2, 64, 12.0)
            .whole());

    // The figures below were measured with the quadrature (checked against
    // mc) on theta_i 0..89 (25 nodes) x alpha 0.05..0.999 (15) x eta 0.1..10
    // (11): docs/models/rough-dielectric.md, "Phong albedos above 1";
    // tests/cli_reliability_tests.sh evaluates the points named here.
    b.option(RD_OPT_DISTRIBUTION,
             {"distribution",
              "microfacet normal distribution. phong does not conserve energy (Walter's fitted "
              "G1, eqs. 27 and 31): albedo_r exceeds 1 for eta < 1 near grazing incidence from "
              "alpha 0.4 on, up to 1.30 (alpha = 0.999, eta = 0.1, theta_i = 89); albedo_t "
              "exceeds 1 near eta = 1, at eta = 1 for every alpha (1.0009 at alpha = 0.05, "
              "theta_i = 85), up to 1.16 (alpha = 0.999, eta = 1, theta_i = 52); albedo_r + "
              "albedo_t exceeds 1 from alpha 0.3 on for eta >= 1.5, up to 1.28 at eta = 10 "
              "(alpha = 0.999, theta_i = 89). beckmann and ggx with g1 = smith stay within 1",
              {"beckmann", "ggx", "phong"},
              "ggx"});
    b.option(
        RD_OPT_G1,
        {"g1",
         "Smith masking for Beckmann: exact (eq. 26), or Walter's rational fit (eq. 27); GGX is "
         "exact (eq. 34) under both; schlick: Schlick's approximation cos/(cos (1-k) + k), "
         "k = alpha/2, for Beckmann and GGX (Karis 2013's image-lighting G1); Phong always uses "
         "Walter's rational fit (eqs. 27, 31) whatever this option says",
         {"smith", "walter-fit", "schlick"},
         "smith"});
    b.option(RD_OPT_SHADOWING,
             {"shadowing",
              "G from G1: separable G1(i)G1(o) (eq. 23), or height-correlated 1/(1+L(i)+L(o))",
              {"separable", "height-correlated"},
              "separable"});
    b.option(RD_OPT_LOBE, {"lobe",
                           "albedo_avg: which lobes are counted",
                           {"both", "reflection", "transmission"},
                           "both"});
    b.option(RD_OPT_SIDE, {"side",
                           "albedo_avg: light arriving from outside (above) or inside (below)",
                           {"outside", "inside"},
                           "outside"});
    b.option(RD_OPT_SAMPLING,
             {"sampling",
              "albedos: how microfacet normals are sampled: visible normals (Heitz 2018 for GGX, "
              "Heitz & d'Eon 2014 for Beckmann; weights bounded by 1) or Walter's m ~ D|m.n| "
              "(eqs. 28-35, weight eq. 41: heavy-tailed). Phong has no visible-normal sampler and "
              "always uses Walter's",
              {"visible", "walter"},
              "visible"});
    b.option(RD_OPT_FRESNEL,
             {"fresnel",
              "facet reflectance F: the exact dielectric Fresnel factor (eq. 22), none (F = 1: "
              "all light is reflected and eta is not read; albedo_r is then the albedo E of "
              "energy compensation), or Schlick's approximation with F0 = ((eta-1)/(eta+1))^2",
              {"dielectric", "none", "schlick"},
              "dielectric"});
    b.option(RD_OPT_MU_RULE,
             {"mu_rule",
              "albedo_avg under quadrature: the mu integral as one Gauss-Legendre rule per side "
              "of the critical cosine (single), or on panels geometric towards grazing and the "
              "critical cosine, (nodes + 1)/2 nodes each (graded: for errors near 1e-6)",
              {"single", "graded"},
              "single"});
    b.option(RD_OPT_TIR_RULE,
             {"tir_rule",
              "albedos under quadrature, light in the denser medium: split (panels end at the "
              "total-internal-reflection level, graded there) or sqrt (also u = sqrt(phi_tir - "
              "phi) on the panels just short of it, the rows where a horizon level meets it, "
              "and, for albedo_avg, mu = 2 mu_c and mu = 1/eta; for errors near 1e-6)",
              {"split", "sqrt"},
              "split"});
    b.option(RD_OPT_COARSE_RULE,
             {"coarse_rule",
              "method quadrature: the rule the error estimate compares with, half the nodes "
              "(half) or ceil(3 nodes / 4) (three-quarters: its error is closer to the accurate "
              "rule's, so the estimate overstates that less, at a higher cost)",
              {"half", "three-quarters"},
              "half"});

    const std::vector<std::string> all_dirs = {"theta_i", "phi_i", "theta_o", "phi_o"};
    const std::vector<std::string> shape_opts = {"distribution", "g1", "shadowing", "fresnel"};
    const std::vector<std::string> albedo_opts = {"distribution", "g1", "shadowing", "sampling",
                                                  "fresnel", "tir_rule", "coarse_rule"};
    const std::vector<std::string> split_opts = {"distribution", "g1", "shadowing", "sampling",
                                                 "coarse_rule"};
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
        q.default_method = Method::ClosedForm;
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
        // Deterministic quadrature (the default) or sampling: see the
        // "Quadrature" section of docs/models/rough-dielectric.md.
        q.kind = QuantityKind::Quadrature;
        q.directions = std::move(dirs);
        q.uses_options = std::move(opts);
        q.equations = eqs;
        q.default_method = Method::Quadrature;
        q.dimensions = dims;
        return q;
    };
    const char* kAlbedoEqs =
        "eqs. 14, 17, 20-22, 39-40; sampling=walter: eqs. 28-35 and weight eq. 41; "
        "sampling=visible: Heitz 2018 (JCGT 7(4), GGX) and Heitz & d'Eon 2014 (EGSR, "
        "Beckmann), weight F G/G1(i)";
    b.quantity(closed("brdf", RD_Q_BRDF, "reflection f_r (0 when i and o are on opposite sides)",
                      "eqs. 13, 20 (h_r, f_r), 22 (Fresnel), 23 (G)"));
    b.quantity(closed("btdf", RD_Q_BTDF, "transmission f_t (0 when i and o are on the same side)",
                      "eqs. 16, 21 (h_t, f_t), 22 (Fresnel), 23 (G)"));
    b.quantity(closed("bsdf", RD_Q_BSDF, "f_r or f_t, whichever applies to the pair of sides",
                      "eqs. 20-21"));
    b.quantity(
        integral("albedo_r", RD_Q_ALBEDO_R,
                 "directional reflectance: integral of f_r cos(theta_o) over outgoing directions",
                 kAlbedoEqs, {"theta_i"}, albedo_opts, 2));
    b.quantity(integral("albedo_t", RD_Q_ALBEDO_T,
                        "directional transmittance: integral of f_t |cos(theta_o)| over outgoing "
                        "directions",
                        kAlbedoEqs, {"theta_i"}, albedo_opts, 2));
    b.quantity(integral("albedo_avg", RD_Q_ALBEDO_AVG,
                        "cosine-weighted hemispherical average of the directional albedo, "
                        "2 * int E(mu) mu dmu, for the chosen lobe(s) and side",
                        kAlbedoEqs, {},
                        {"distribution", "g1", "shadowing", "lobe", "side", "sampling", "fresnel",
                         "mu_rule", "tir_rule", "coarse_rule"},
                        3));
    const char* kSplitEqs =
        "eqs. 14, 20, 39 with F = 1, weighted by Schlick's factors (Schlick 1994 eq. 15; "
        "Karis 2013 split sum); sampling as the albedos";
    b.quantity(integral("split_a", RD_Q_SPLIT_A,
                        "split-sum scale: integral of f_r cos(theta_o) (1 - (1 - o.m)^5) with F = 1, "
                        "so that the reflectance under Schlick's F is F0 split_a + split_b (eta is "
                        "not read)",
                        kSplitEqs, {"theta_i"}, split_opts, 2));
    b.quantity(integral("split_b", RD_Q_SPLIT_B,
                        "split-sum bias: integral of f_r cos(theta_o) (1 - o.m)^5 with F = 1; "
                        "split_a + split_b is albedo_r with fresnel = none (eta is not read)",
                        kSplitEqs, {"theta_i"}, split_opts, 2));
    b.quantity(integral("albedo", RD_Q_ALBEDO,
                        "directional albedo of both lobes, albedo_r + albedo_t: the fraction of "
                        "light from direction i that leaves the interface (glass albedo)",
                        kAlbedoEqs, {"theta_i"}, albedo_opts, 2));
    b.quantity(integral("sheen_albedo", RD_Q_SHEEN_ALBEDO,
                        "directional albedo of the Charlie sheen lobe (Estevez & Kulla 2017) with "
                        "Neubelt & Pettineo's visibility 1/(4 (n.l + n.v - n.l n.v)), roughness "
                        "alpha: Filament's cloth DFG channel (eta and the microfacet options are not "
                        "read)",
                        "Estevez & Kulla 2017 eq. 2; Neubelt & Pettineo 2013", {"theta_i"},
                        {"coarse_rule"}, 2));
    b.check_cell(&check_phong_alpha);
    b.cells_pass(&phong_alpha_cells_pass);

    // Launch preferences (registry.h; docs/benchmarks.md, "Sample-parallel
    // launches").  The GGX albedos' sample kernels vectorise across work
    // items and run 2.1-2.4x faster per CPU-second sample-parallel, by Monte
    // Carlo and RQMC (the sampler vectorises too, kernels/common/sobol.h);
    // Beckmann and Phong measured slower, so they keep the usual kernel.
    for (int id : {RD_Q_ALBEDO_R, RD_Q_ALBEDO_T, RD_Q_ALBEDO_AVG})
        for (Method method : {Method::MonteCarlo, Method::Rqmc})
            b.quantity_by_id(id).sample_parallel.push_back({method, {{"distribution", "ggx"}}});
    // Forced inlining: measured faster, every preset bit-identical.
    b.force_inline();

    // Float against double (registry.h, docs/precision.md).
    b.float_vs_double(RD_Q_ALBEDO_AVG, 2.4e-07);
    b.float_vs_double(RD_Q_ALBEDO_R, 4.9e-07);
    b.float_vs_double(RD_Q_ALBEDO_T, 1.6e-06);
    b.float_vs_double(RD_Q_BSDF, 1.0,
                      "grazing mirror directions of sharp lobes (theta_i = theta_o = 90 deg, "
                      "smallest alpha: in float cos 90 deg is -4.4e-8)");

    // `brdftab bench` cases.  flops_estimate of bsdf: counted by hand in
    // kernels/models/rough_dielectric.h for a reflection pair (two
    // directions from angles, half vector, GGX D, two Smith G1, dielectric
    // Fresnel, the eq. 20 quotient): about 110 additions/multiplications
    // plus 4 sin/cos, 3 sqrt and 6 divisions, each of those counted as 10.
    // An estimate, only to put the achieved rate next to the peak.
    b.bench({"bsdf", false, 240, 179, Method::Auto, true});
    // The albedos' default is quadrature; the bench keeps timing their
    // sampled (RQMC) kernel, the sample-parallel launch's main case.
    b.bench({"albedo_r", false, 0, 89, Method::Rqmc});
    b.bench({"albedo_t", false, 0, 89, Method::Rqmc});
    return b.build();
}

BRDFTAB_REGISTER_MODEL(rough_dielectric_model);

}  // namespace

}  // namespace brdftab::detail
