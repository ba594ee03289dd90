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
