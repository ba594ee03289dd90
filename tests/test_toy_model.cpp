// The test-only toy-lambert model (tests/toy_model/), added by following
// docs/adding-a-model.md and nothing else: it is registered, evaluates on the
// host and on the OpenCL device, and generates a table from a spec.  Oracles:
// Lambert's f = albedo/pi, its albedo (the parameter itself) and the variance
// of the uniform-hemisphere estimator 2 albedo u, albedo^2/3.
#include <doctest/doctest.h>

#include <cmath>
#include <map>
#include <string>

#include "host/engine/engine.h"
#include "host/generate/generate.h"
#include "host/models/registry.h"
#include "host/plan/plan.h"
#include "host/spec/spec.h"

using namespace brdftab;

namespace {

const double kInvPi = 0.318309886183790671538;

EstimateResult run(Backend& backend, const std::string& quantity,
                   const std::map<std::string, double>& values, const std::string& sampling,
                   std::uint64_t samples) {
    const ModelInfo& m = find_model("toy-lambert");
    const QuantityInfo& q = m.quantity(quantity);
    std::vector<double> point(m.point_stride());
    PointBuilder(m, q).build(values, point.data());
    IntegrationSettings settings;
    settings.samples = samples;
    settings.seed = 11;
    return estimate(backend, m, q, resolve_options(m, {{"sampling", sampling}}, "test"), 1,
                    [&](std::size_t, double* out) { std::copy(point.begin(), point.end(), out); },
                    settings);
}

// The pilot of `plan` (256 reference samples per probe) on an albedo table
// with explicit theta_i and albedo axes.
// `spec` receives the parsed spec.
TablePilot explicit_axes_pilot(const std::string& sampling, const std::string& theta_values,
                               Spec* spec_out = nullptr) {
    const std::string text = "model = \"toy-lambert\"\n[parameters]\nsampling = \"" + sampling +
                             "\"\n[[axes]]\nname = \"theta_i\"\nspacing = \"explicit\"\nvalues = " +
                             theta_values +
                             "\n[[axes]]\nname = \"albedo\"\nspacing = \"explicit\"\n"
                             "values = [0.2, 0.5, 0.8]\n[[tables]]\nname = \"albedo\"\n"
                             "quantity = \"albedo\"\n[integration]\nmethod = \"mc\"\nsamples = 4096\n";
    const Spec spec = parse_spec_string(text, "toy-" + sampling + ".toml");
    if (spec_out) *spec_out = spec;
    auto backend = make_backend("host", Precision::Double);
    PilotOptions options;
    options.reference_samples = 256;
    return run_pilot(spec, 0, *backend, options);
}

}  // namespace

TEST_CASE("the toy model is registered and listed last") {
    const ModelInfo& m = find_model("toy-lambert");
    CHECK(all_models().back().name == "toy-lambert");
    CHECK(m.point_stride() == kDirectionSlots + 1);
    CHECK(m.quantity("albedo").id == 1);
    const nlohmann::json listing = describe_models();
    CHECK(listing.back()["name"] == "toy-lambert");
}

TEST_CASE("the toy model evaluates on the host and on the device") {
    auto host = make_backend("host", Precision::Double);
    auto device = make_backend("", Precision::Double);
    for (Backend* b : {host.get(), device.get()}) {
        CAPTURE(b->device_name());
        const auto f = run(*b, "brdf", {{"theta_i", 40}, {"theta_o", 70}, {"albedo", 0.8}},
                           "uniform", 1);
        CHECK(f.value[0] == doctest::Approx(0.8 * kInvPi).epsilon(1e-15));
        const auto below = run(*b, "brdf", {{"theta_i", 40}, {"theta_o", 100}, {"albedo", 0.8}},
                               "uniform", 1);
        CHECK(below.value[0] == 0.0);
        const auto exact = run(*b, "albedo", {{"theta_i", 20}, {"albedo", 0.6}}, "cosine", 256);
        CHECK(exact.value[0] == doctest::Approx(0.6).epsilon(1e-15));
        const std::uint64_t n = 1 << 16;
        const auto mc = run(*b, "albedo", {{"theta_i", 20}, {"albedo", 0.6}}, "uniform", n);
        const double expected_stderr = 0.6 / std::sqrt(3.0 * double(n));
        CHECK(std::fabs(mc.value[0] - 0.6) < 4 * expected_stderr);
        CHECK(mc.stderr_[0] == doctest::Approx(expected_stderr).epsilon(0.05));
    }
}

TEST_CASE("the toy model generates a table from a spec") {
    const Spec spec = parse_spec_file(std::string(BT_SOURCE_DIR) + "/tests/toy_model/toy_lambert.toml");
    auto device = make_backend("", Precision::Double);
    const auto tables = generate_tables(spec, *device, spec.integration);
    REQUIRE(tables.size() == 2);
    const TableData& albedo = tables[0].data;
    REQUIRE(albedo.axes.size() == 2);
    const auto& theta = albedo.axes[0].values;
    const auto& a = albedo.axes[1].values;
    for (std::size_t i = 0; i < theta.size(); ++i)
        for (std::size_t j = 0; j < a.size(); ++j) {
            const std::size_t cell = i * a.size() + j;
            CAPTURE(cell);
            CHECK(std::fabs(albedo.value[cell] - a[j]) < 5 * albedo.stderr_[cell]);
        }
    const TableData& brdf = tables[1].data;
    for (std::size_t i = 0; i < theta.size(); ++i)
        for (std::size_t j = 0; j < a.size(); ++j)
            CHECK(brdf.value[i * a.size() + j] == doctest::Approx(a[j] * kInvPi).epsilon(1e-15));
}

// plan's pilot on a table whose truth is exactly linear along both explicit
// axes (the albedo equals its parameter, whatever theta_i): the true
// interpolation error is 0, so what its lines measure is the Monte Carlo
// noise of the pilot's own values, d = noise with variance v <= sigma_probe^2 +
// sigma_node^2, sigma^2 = albedo^2 / (3 N).  The noise-free measure
// sqrt((d^2 - sigma_probe^2 - sigma_node^2)+) has E[.^2] <= E[(Z^2 - 1)+] v
// = 2 phi(1) v = 0.48 v (Z standard normal; the raw measure's is v), so its
// RMS comes out near 0.7 x the raw RMS or below (measured 0.69 and 0.63; a
// measure without the subtraction gives 1); and it is what an explicit axis
// predicts (axis_error).
TEST_CASE("pilot: on explicit axes the noise of the pilot's values is taken out") {
    Spec spec;
    const TablePilot p = explicit_axes_pilot("uniform", "[0.0, 30.0, 60.0, 85.0]", &spec);
    REQUIRE(p.linear.size() == 2);
    for (const AxisFit& f : p.linear) {
        CAPTURE(f.axis);
        CHECK_FALSE(f.planned);
        REQUIRE(f.levels.size() == 1);
        const LevelErrors& l = f.levels[0];
        // sigma at albedo 0.8 with 256 samples: 0.8 / sqrt(768) = 0.029.
        CHECK(l.noise > 0.01);
        CHECK(l.noise < 0.05);
        CHECK(l.rms_abs > 0.2 * l.noise);   // the raw lines see the noise...
        CHECK(l.denoised_rms_abs < 0.85 * l.rms_abs);  // ...the measure used takes it out
        CHECK(l.denoised_max_abs <= l.max_abs);
        CHECK(l.denoised_max_rel <= l.max_rel);
    }
    CHECK_FALSE(p.variance_unseen);
    // What the explicit axes predict for the spec as written is the sum of
    // the noise-free maxima (relative, the default).
    PlanTarget target;
    std::string why;
    const auto as_written = predict_as_written(spec, {p}, target, {}, why);
    REQUIRE(as_written);
    CHECK(as_written->tables[0].interpolation_max ==
          doctest::Approx(p.linear[0].levels[0].denoised_max_rel + p.linear[1].levels[0].denoised_max_rel));
}

// The estimator with cosine sampling returns the albedo itself: every sample
// equal, stderr exactly 0 at every budget.  Such a pilot (like one that saw
// too few rare events) has no noise measurement to take out: the line errors
// are kept as measured.
TEST_CASE("pilot: a budget without variance keeps the line errors as measured") {
    const TablePilot p = explicit_axes_pilot("cosine", "[0.0, 40.0, 80.0]");
    CHECK(p.variance_unseen);
    for (const AxisFit& f : p.linear) {
        REQUIRE(f.levels.size() == 1);
        // Exact values, linear in albedo, constant in theta_i: no error at all.
        CHECK(f.levels[0].max_abs < 1e-15);
        CHECK(f.levels[0].denoised_max_abs == f.levels[0].max_abs);
        CHECK(f.levels[0].denoised_max_rel == f.levels[0].max_rel);
    }
}
