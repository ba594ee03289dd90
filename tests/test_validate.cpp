// test_validate.cpp — the library behind `brdftab eval` and `brdftab
// validate` (host/engine/evaluate.h, host/generate/validate.h), on the host
// (serial C++) backend.
//
// Oracles: percentiles of hand-made samples; a table of zeros, whose error at
// every point is minus the reference, so each relative error is exactly -1;
// the reference at each drawn point evaluated again, alone, through eval's
// path; the axis ranges the points must lie in; the messages by hand.
#include <doctest/doctest.h>

#include "test_support.h"

#include <cmath>
#include <string>
#include <vector>

#include "host/core/error.h"
#include "host/engine/evaluate.h"
#include "host/generate/validate.h"
#include "host/io/table_io.h"

namespace fs = std::filesystem;
using namespace brdftab;

namespace {

// A closed-form rough-dielectric BRDF table over (theta_i, theta_o, phi_d),
// every value 0, written to a scratch file.
std::string zero_table_file(const std::string& sub, nlohmann::json extra_parameters = {},
                            const std::string& method = "closed-form") {
    TableData t;
    t.name = "brdf";
    t.model = "rough-dielectric";
    t.quantity = "brdf";
    t.units = "1/sr";
    t.parameters = {{"alpha", 0.5}, {"eta", 1.5}, {"distribution", "ggx"}};
    if (extra_parameters.is_object()) t.parameters.update(extra_parameters);
    t.axes = {test::axis("theta_i", "deg", 0, 80, 3),
              test::axis("theta_o", "deg", 0, 80, 4),
              test::axis("phi_d", "deg", 0, 180, 5)};
    t.value.assign(t.cell_count(), 0.0);
    set_method_attribute(t, method);  // "closed-form", or a derived kind such as "error"
    t.stored_type = StoredType::Float64;
    const fs::path p = test::scratch_dir(BT_BINARY_DIR, "test_validate", sub) / "t.h5";
    write_tables(p.string(), {t});
    return p.string();
}

}  // namespace

TEST_CASE("error_stats: nearest-rank percentiles of |x|") {
    std::vector<double> x;
    double sum2 = 0;
    for (int k = 1; k <= 100; ++k) {
        x.push_back(k % 2 ? -double(k) : double(k));  // signs must not matter
        sum2 += double(k) * k;
    }
    const ErrorStats s = error_stats(x);
    CHECK(s.max == 100);
    CHECK(s.p50 == 50);
    CHECK(s.p95 == 95);
    CHECK(s.p99 == 99);
    CHECK(s.rms == doctest::Approx(std::sqrt(sum2 / 100)).epsilon(1e-15));
    CHECK(error_stats({}).max == 0);
}

TEST_CASE("NamedInputs: options by name, numbers checked, messages name the argument") {
    const ModelInfo& m = find_model("rough-dielectric");
    const QuantityInfo& q = m.quantity("brdf");
    NamedInputs in(m, q, "argument");
    in.add("theta_i", "30");
    in.add("distribution", "beckmann");
    CHECK(in.values() == std::map<std::string, double>{{"theta_i", 30.0}});
    CHECK(test::input_error([&] { in.add("alpha", "x"); }) ==
          "argument 'alpha': 'x' is not a finite number");
    const std::string range = test::input_error([&] { in.add("alpha", "9"); });
    CHECK(range.rfind("argument 'alpha=9': ", 0) == 0);
    NamedInputs bad(m, q, "argument");
    bad.add("distribution", "nope");
    CHECK(test::input_error([&] { bad.options(); }) != "");
    // A point the builder rejects (no theta_o) is labelled by the caller.
    const std::string missing = test::input_error([&] {
        build_kernel_points(m, q, {{{"theta_i", 30.0}, {"alpha", 0.3}, {"eta", 1.5}}},
                            [](std::size_t k) { return "row " + std::to_string(k + 1); });
    });
    CHECK(missing.rfind("row 1: ", 0) == 0);
}

TEST_CASE("validate a table of zeros: errors are minus the reference") {
    const std::string file = zero_table_file("zeros");
    ValidateOptions o;
    o.points = 50;
    o.seed = 7;
    o.worst = 4;
    const ValidationPlan plan(file, "brdf", o);
    CHECK_FALSE(plan.integral());
    auto host = make_backend("host", Precision::Double);
    const ValidationReport r = plan.run(*host);

    CHECK(r.points == 50);
    CHECK_FALSE(r.noisy);
    CHECK_FALSE(r.has_table_stderr);  // closed form: no stderr stored
    CHECK_FALSE(r.recombination_skipped);
    CHECK(r.max_abs_table_value == 0);
    REQUIRE(r.axes.size() == 3);
    REQUIRE(r.coords.size() == 150);

    const ModelInfo& m = find_model("rough-dielectric");
    const QuantityInfo& q = m.quantity("brdf");
    NamedInputs in(m, q, "test");
    in.add("alpha", "0.5");
    in.add("eta", "1.5");
    in.add("distribution", "ggx");
    for (std::size_t k = 0; k < r.points; ++k) {
        for (std::size_t a = 0; a < 3; ++a) {
            CHECK(r.coord(k, a) >= r.axes[a].min);
            CHECK(r.coord(k, a) <= r.axes[a].max);
        }
        // The reference at point k, evaluated again on its own.
        std::map<std::string, double> p = in.values();
        for (std::size_t a = 0; a < 3; ++a) p[r.axes[a].name] = r.coord(k, a);
        const auto kp = build_kernel_points(m, q, {p}, [](std::size_t) { return "point"; });
        const EstimateResult alone = estimate_at(*host, m, q, in.options(), kp, IntegrationSettings{});
        CHECK(alone.value[0] == r.reference.value[k]);
        REQUIRE(r.reference.value[k] > 0);  // the lobe is positive above the surface
        for (const InterpolationErrors& e : r.results) {
            CHECK(e.value[k] == 0);
            CHECK(e.abs[k] == -r.reference.value[k]);
            CHECK(e.rel[k] == -1);
        }
    }
    for (const InterpolationErrors& e : r.results) {
        CHECK(e.rel_stats.max == 1);
        CHECK(e.rel_stats.p50 == 1);
        REQUIRE(e.worst.size() == 4);
        CHECK(e.significant == 0);  // counted only against a noisy reference
    }
    CHECK(std::string(r.results[0].name) == "linear");
    CHECK(std::string(r.results[1].name) == "cubic");

    // Same seed, same points; another seed, other points.
    const ValidationReport again = ValidationPlan(file, "brdf", o).run(*host);
    CHECK(again.coords == r.coords);
    o.seed = 8;
    CHECK(ValidationPlan(file, "brdf", o).run(*host).coords != r.coords);

    const nlohmann::json j = to_json(r);
    CHECK(j["points"] == 50);
    CHECK(j["linear"]["rel"]["max"] == 1.0);
    CHECK(j["linear"]["worst"].size() == 4);
}

TEST_CASE("validate: a recombination recipe is set aside, derived tables are refused") {
    const std::string recombined = zero_table_file(
        "recombined",
        {{"recombine", {{"parameter", "c"}, {"terms", {{{"table", "brdf"}, {"coeffs", {0, 1}}}}}}}});
    ValidateOptions o;
    o.points = 5;
    auto host = make_backend("host", Precision::Double);
    const ValidationReport r = ValidationPlan(recombined, "brdf", o).run(*host);
    CHECK(r.recombination_skipped);
    CHECK(r.axes.size() == 3);  // the recipe's parameter is not a coordinate here

    const std::string error_table = zero_table_file(
        "error", {{"comparison", {{"table", "approx"}, {"reference", "exact"}}}}, "error");
    const std::string msg = test::input_error([&] { ValidationPlan(error_table, "brdf", o); });
    CHECK(msg.find("is an error table") != std::string::npos);
    CHECK(msg.find("'approx' and 'exact'") != std::string::npos);

    const std::string file = zero_table_file("missing");
    CHECK(test::input_error([&] { ValidationPlan(file, "nope", o); }).find("no table 'nope'") !=
          std::string::npos);
    o.points = 0;
    CHECK(test::input_error([&] { ValidationPlan(file, "brdf", o); }) != "");
    o.points = 5;
    o.rel_floor = 1;
    CHECK(test::input_error([&] { ValidationPlan(file, "brdf", o); }) != "");
}
