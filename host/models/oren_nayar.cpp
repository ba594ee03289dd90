// Registry entry and host compilation of the Oren-Nayar V-cavity model
// (kernels/models/oren_nayar.h; docs/models/oren-nayar.md).
#include "kernels/models/oren_nayar.h"

#include <string>
#include <vector>

#include "host/models/registry.h"

namespace brdftab::detail {

namespace {

ModelInfo oren_nayar_model() {
    ModelBuilder b("oren-nayar", 20);
    b.citation(
        "M. Oren, S. K. Nayar. Generalization of Lambert's Reflectance Model. Proc. SIGGRAPH "
        "'94, pp. 239-246, 1994.");
    b.description(
        "Rough Lambertian surface of long symmetric V-cavities (Gaussian slope-area "
        "distribution): the exact facet integral (eq. 25) with masking/shadowing and two-bounce "
        "interreflection, the single-slope surfaces, and the paper's functional and "
        "qualitative approximations. Reflection only (theta > 90 deg gives 0).");
    b.kernel("models/oren_nayar.h", "oren_nayar_sample", &oren_nayar_sample);
    b.counts(ON_PARAM_COUNT, ON_OPT_COUNT, ON_Q_COUNT);

    b.parameter(ON_PARAM_SIGMA,
                parameter_info("sigma", "deg",
                               "standard deviation of the facet slope (Gaussian slope-area "
                               "distribution, eq. 26)",
                               0, 80)
                    .degrees());
    b.parameter(
        ON_PARAM_RHO,
        parameter_info("rho", "1",
                       "facet albedo (brdf, uni_slope, functional, qualitative, approx_error, "
                       "albedo, albedo_avg)",
                       0, 1, 1.0));
    b.parameter(
        ON_PARAM_THETA_A,
        parameter_info("theta_a", "deg",
                       "facet slope of the single-slope surfaces (uni_slope, single_slope_*)", 0,
                       90, 20.0)
            .degrees()
            .open_max());
    b.parameter(
        ON_PARAM_PHI_A,
        parameter_info("phi_a", "deg",
                       "azimuth of a facet normal of the uni-directional surface (uni_slope; "
                       "the other facet is at phi_a + 180)",
                       -360, 360, 0.0)
            .degrees());
    b.parameter(
        ON_PARAM_NODES,
        parameter_info("nodes", "1",
                       "method quadrature: Gauss-Legendre nodes per sub-interval in theta_a and "
                       "in phi_a (the error estimate is the distance to the rule with half the "
                       "nodes)",
                       2, 64, 12.0)
                    .whole());

    b.option(
        ON_OPT_QUALITATIVE_A,
        {"qualitative_a",
         "constant in coefficient A of the qualitative model: 0.33 (eq. 30) or 0.57 (footnote 7, "
         "partly compensating the missing interreflection)",
         {"0.33", "0.57"},
         "0.33"});
    b.option(ON_OPT_APPROXIMATION, {"approximation",
                                    "approx_error: which approximation is compared with eq. 25",
                                    {"functional", "qualitative", "lambert"},
                                    "functional"});
    b.option(ON_OPT_ERROR,
             {"error",
              "approx_error: relative (approx/exact - 1) or absolute (approx - exact, 1/sr)",
              {"relative", "absolute"},
              "relative"});

    const std::vector<std::string> dirs = {"theta_i", "phi_i", "theta_o", "phi_o"};
    auto make = [&](const char* name, int id, const char* desc, const char* units,
                    QuantityKind kind, const char* eqs, std::vector<std::string> opts,
                    unsigned dims) {
        QuantityInfo q;
        q.name = name;
        q.id = id;
        q.description = desc;
        q.units = units;
        q.kind = kind;
        q.directions = dirs;
        q.uses_options = std::move(opts);
        q.equations = eqs;
        q.default_method = kind == QuantityKind::ClosedForm   ? Method::ClosedForm
                           : kind == QuantityKind::Quadrature ? Method::Quadrature
                                                              : Method::Rqmc;
        q.dimensions = dims;
        return q;
    };
    const auto Q = QuantityKind::Quadrature, C = QuantityKind::ClosedForm,
               I = QuantityKind::Integral;
    b.quantity(make("brdf", ON_Q_BRDF,
                    "exact V-cavity BRDF at rho: rho * brdf_direct + rho^2 * brdf_interreflection",
                    "1/sr", Q,
                    "eqs. 25-26 with Table 1, eqs. 10-11 (GAF = max(0, min(1, X, Y))) and "
                    "eqs. 15-20",
                    {}, 2));
    b.quantity(make("brdf_direct", ON_Q_BRDF_DIRECT,
                    "direct (single-bounce) part of the exact BRDF per unit rho", "1/sr", Q,
                    "eqs. 25-26, Table 1, eqs. 10-11 (GAF = max(0, min(1, X, Y)))", {}, 2));
    b.quantity(make("brdf_interreflection", ON_Q_BRDF_INTER,
                    "two-bounce interreflection part of the exact BRDF per unit rho^2", "1/sr", Q,
                    "eqs. 25-26, 15-20", {}, 2));
    b.quantity(
        make("uni_slope", ON_Q_UNI_SLOPE,
             "uni-directional single-slope surface (all cavities along one direction; facets "
             "(theta_a, phi_a) and (theta_a, phi_a + 180)) at rho, direct + two-bounce",
             "1/sr", C, "eq. 22 with Table 1 and eqs. 15-21", {}, 0));
    b.quantity(make("single_slope_direct", ON_Q_SS_DIRECT,
                    "isotropic single-slope surface (slope theta_a), direct term per unit rho, "
                    "integrated numerically over phi_a",
                    "1/sr", Q, "eq. 23 (Table 1, eq. 11)", {}, 1));
    b.quantity(make("single_slope_interreflection", ON_Q_SS_INTER,
                    "isotropic single-slope surface, two-bounce term per unit rho^2, integrated "
                    "numerically over phi_a",
                    "1/sr", Q, "eq. 46 with eqs. 18-20", {}, 1));
    b.quantity(make("single_slope_direct_closed", ON_Q_SS_DIRECT_CF,
                    "the paper's closed form of single_slope_direct (exact in and perpendicular to "
                    "the plane of incidence, eq. 44 interpolation elsewhere)",
                    "1/sr", C, "eqs. 39-45", {}, 0));
    b.quantity(make("single_slope_interreflection_closed", ON_Q_SS_INTER_CF,
                    "the paper's approximation of single_slope_interreflection (IF approximated by "
                    "eq. 48)",
                    "1/sr", C, "eqs. 48-49", {}, 0));
    b.quantity(make("functional", ON_Q_FUNCTIONAL, "the paper's functional approximation at rho",
                    "1/sr", C, "eqs. 27-29", {}, 0));
    b.quantity(make("qualitative", ON_Q_QUALITATIVE, "the paper's qualitative model at rho", "1/sr",
                    C, "eq. 30 (footnote 7 with qualitative_a = 0.57)", {"qualitative_a"}, 0));
    b.quantity(
        make("approx_error", ON_Q_APPROX_ERROR,
             "error of an approximation against the exact brdf at rho: relative (approx/exact "
             "- 1; under mc/rqmc linearised as (approx - exact)/approx) or absolute",
             "1", Q, "eqs. 27-30 vs eq. 25", {"qualitative_a", "approximation", "error"}, 2));
    b.quantity(make("albedo", ON_Q_ALBEDO,
                    "directional albedo at rho: integral of brdf cos(theta_o) over the hemisphere",
                    "1", I, "eq. 25 integrated over outgoing directions", {}, 4));
    b.quantity(make("albedo_avg", ON_Q_ALBEDO_AVG,
                    "cosine-weighted average of the directional albedo, 2 int E(mu) mu dmu", "1", I,
                    "eq. 25 integrated over both hemispheres", {}, 5));
    b.quantity(
        make("albedo_direct", ON_Q_ALBEDO_DIRECT,
             "directional albedo of brdf_direct (per unit rho): albedo = rho * albedo_direct + "
             "rho^2 * albedo_interreflection",
             "1", I, "eq. 25 (direct) integrated over outgoing directions", {}, 4));
    b.quantity(make("albedo_interreflection", ON_Q_ALBEDO_INTER,
                    "directional albedo of brdf_interreflection (per unit rho^2)", "1", I,
                    "eq. 25 (two-bounce) integrated over outgoing directions", {}, 4));
    b.quantity(make("albedo_avg_direct", ON_Q_ALBEDO_AVG_DIRECT,
                    "cosine-weighted average of albedo_direct", "1", I,
                    "eq. 25 (direct) integrated over both hemispheres", {}, 5));
    b.quantity(make("albedo_avg_interreflection", ON_Q_ALBEDO_AVG_INTER,
                    "cosine-weighted average of albedo_interreflection", "1", I,
                    "eq. 25 (two-bounce) integrated over both hemispheres", {}, 5));
    // approx_error in 1/sr for the absolute variant: the unit string covers both.
    b.quantity_by_id(ON_Q_APPROX_ERROR).units = "1 (relative) or 1/sr (absolute)";
    // The directional albedos depend on theta_i alone, their averages on no direction.
    for (int id : {ON_Q_ALBEDO, ON_Q_ALBEDO_DIRECT, ON_Q_ALBEDO_INTER})
        b.quantity_by_id(id).directions = {"theta_i"};
    for (int id : {ON_Q_ALBEDO_AVG, ON_Q_ALBEDO_AVG_DIRECT, ON_Q_ALBEDO_AVG_INTER})
        b.quantity_by_id(id).directions = {};
    // The Gaussian-surface quadrature runs node-parallel on OpenCL devices
    // (nested sums: theta_a nodes, each with its phi_a nodes;
    // kernels/models/oren_nayar.h, oren_nayar_node_*; docs/benchmarks.md,
    // "Node-parallel quadrature").
    for (int id : {ON_Q_BRDF, ON_Q_BRDF_DIRECT, ON_Q_BRDF_INTER, ON_Q_APPROX_ERROR}) {
        NodeParallelFunctions& f = b.quantity_by_id(id).node_parallel;
        f.count = "oren_nayar_node_count";
        f.prepare = "oren_nayar_node_prepare";
        f.term = "oren_nayar_node_term";
        f.finish = "oren_nayar_node_finish";
        f.state_size = ON_NODE_ITEM_STATE;
        f.host_count = &oren_nayar_node_count;
        f.group_prepare = "oren_nayar_node_group";
        f.group_reduce = "oren_nayar_node_group_reduce";
        f.group_add = "oren_nayar_node_group_add";
        f.sample = "oren_nayar_sample";
        f.group_state_size = ON_NODE_GROUP_STATE;
        f.terms = ON_NODE_TERMS;
        f.partials = ON_NODE_PARTIALS;
        f.acc_size = ON_NODE_ACC;
        f.max_groups = ON_NODE_MAX_GROUPS;
        f.table = "oren_nayar_node_table";
        f.table_entries = ON_NODE_TABLE_ENTRIES;
        f.table_size = ON_NODE_TABLE_SIZE;
    }

    // Float against double (registry.h, docs/precision.md).
    const char* kCancellation = "small values formed by cancellation";
    b.float_vs_double(ON_Q_ALBEDO_AVG_DIRECT, 1.9e-07);
    b.float_vs_double(ON_Q_ALBEDO_AVG_INTER, 2.4e-05);
    b.float_vs_double(ON_Q_ALBEDO_DIRECT, 3.8e-07);
    b.float_vs_double(ON_Q_ALBEDO_INTER, 0.0011, kCancellation);
    b.float_vs_double(ON_Q_APPROX_ERROR, 0.00063, kCancellation);
    b.float_vs_double(ON_Q_BRDF_DIRECT, 3.6e-07);
    b.float_vs_double(ON_Q_BRDF_INTER, 6.8e-05);

    b.bench({"brdf", true});
    return b.build();
}

BRDFTAB_REGISTER_MODEL(oren_nayar_model);

}  // namespace

}  // namespace brdftab::detail
