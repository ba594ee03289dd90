// The model contract (host/models/registry.h): every registered model keeps
// it, and ModelBuilder refuses descriptions that break it.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <stdexcept>
#include <string>

#include "host/core/error.h"
#include "host/engine/engine.h"
#include "host/engine/kernel_sources.h"
#include "host/models/registry.h"
#include "kernels/common/estimator.h"  // BT_MAX_POINT, BT_MAX_OPTIONS

using namespace brdftab;

namespace {

// A value every parameter accepts: its default, or the middle of its range
// (an integer for integer-valued parameters is not needed: none lacks a default).
double usable_value(const ParameterInfo& p) {
    if (p.default_value) return *p.default_value;
    return 0.5 * (p.min + p.max);
}

std::map<std::string, double> default_point(const ModelInfo& m, const QuantityInfo& q) {
    std::map<std::string, double> values;
    for (const auto& d : q.directions) {
        if (d == "theta_i") values["theta_i"] = 30;
        if (d == "theta_o") values["theta_o"] = 50;
        if (d == "phi_o") values["phi_d"] = 120;
    }
    for (const auto& p : m.parameters) values[p.name] = usable_value(p);
    return values;
}

// A description that keeps the contract, for the negative tests to break.
ModelBuilder valid_builder() {
    ModelBuilder b("contract-probe", 0);
    b.citation("none").description("a test description");
    b.kernel("models/rough_dielectric.h", "rough_dielectric_sample", find_model("rough-dielectric").host_fn);
    b.counts(2, 1, 2);
    b.parameter(kDirectionSlots + 0, parameter_info("a", "1", "first", 0, 1, 0.5));
    b.parameter(kDirectionSlots + 1, parameter_info("b", "1", "second", 0, 1, 0.5));
    b.option(0, OptionInfo{"mode", "a mode", {"x", "y"}, "x"});
    b.quantity(QuantityInfo{"q0", 0, "first", "1", QuantityKind::ClosedForm, {"theta_i"}, {"mode"},
                            "none", Method::ClosedForm, 0});
    b.quantity(QuantityInfo{"q1", 1, "second", "1", QuantityKind::ClosedForm, {}, {}, "none",
                            Method::ClosedForm, 0});
    return b;
}

}  // namespace

TEST_CASE("every registered model keeps the contract") {
    const auto& models = all_models();
    REQUIRE(models.size() >= 6);
    const auto files = embedded_kernel_files();
    std::set<std::string> model_names;
    for (const auto& m : models) {
        CAPTURE(m.name);
        CHECK(model_names.insert(m.name).second);
        CHECK(!m.citation.empty());
        CHECK(!m.description.empty());
        CHECK(static_cast<bool>(m.host_fn));
        CHECK(std::find(files.begin(), files.end(), m.kernel_header) != files.end());
        CHECK(m.point_stride() <= static_cast<std::size_t>(BT_MAX_POINT));
        CHECK(m.options.size() <= static_cast<std::size_t>(BT_MAX_OPTIONS));
        std::set<int> ids;
        std::set<std::string> names;
        for (const auto& q : m.quantities) {
            CHECK(ids.insert(q.id).second);
            CHECK(names.insert(q.name).second);
            CHECK(q.id >= 0);
            CHECK(q.id < static_cast<int>(m.quantities.size()));
        }
        std::set<std::string> parameters;
        for (const auto& p : m.parameters) {
            CHECK(parameters.insert(p.name).second);
            CHECK(!is_direction_coordinate(p.name));
        }
    }
    // The listing order is the documented one (docs: rough-dielectric first).
    CHECK(models.front().name == "rough-dielectric");
}

TEST_CASE("every quantity of every model evaluates at its default parameters") {
    auto host = make_backend("host", Precision::Double);
    auto device = make_backend("", Precision::Double);
    IntegrationSettings settings;
    settings.samples = 64;
    settings.seed = 3;
    for (const auto& m : all_models()) {
        const std::vector<int> options = resolve_options(m, nullptr, "test");
        for (const auto& q : m.quantities) {
            CAPTURE(m.name);
            CAPTURE(q.name);
            const auto values = default_point(m, q);
            std::vector<double> point(m.point_stride());
            PointBuilder(m, q).build(values, point.data());
            auto point_of = [&](std::size_t, double* out) {
                std::copy(point.begin(), point.end(), out);
            };
            const EstimateResult h = estimate(*host, m, q, options, 1, point_of, settings);
            const EstimateResult d = estimate(*device, m, q, options, 1, point_of, settings);
            // Not NaN; infinite only where the quantity is (H_inf at c = 1).
            CHECK(!std::isnan(h.value[0]));
            // Same samples, same kernel source: the device agrees with the
            // host up to the rounding of a different compiler.
            if (std::isfinite(h.value[0]))
                CHECK(d.value[0] == doctest::Approx(h.value[0]).epsilon(1e-9).scale(1e-12));
            else
                CHECK(d.value[0] == h.value[0]);
        }
    }
}

TEST_CASE("ModelBuilder accepts a valid description and fills ids and slots") {
    const ModelInfo m = valid_builder().build();
    CHECK(m.point_stride() == kDirectionSlots + 2);
    CHECK(m.parameters[0].name == "a");
    CHECK(m.quantities[1].id == 1);
}

TEST_CASE("ModelBuilder puts parameters in slot order whatever the call order") {
    ModelBuilder b("order-probe", 0);
    b.citation("none").description("d");
    b.kernel("models/rough_dielectric.h", "rough_dielectric_sample",
             find_model("rough-dielectric").host_fn);
    b.counts(2, 0, 1);
    b.parameter(kDirectionSlots + 1, parameter_info("second", "1", "", 0, 1, 0.5));
    b.parameter(kDirectionSlots + 0, parameter_info("first", "1", "", 0, 1, 0.5));
    b.quantity(QuantityInfo{"q", 0, "", "1", QuantityKind::ClosedForm, {}, {}, "", Method::ClosedForm, 0});
    const ModelInfo m = b.build();
    CHECK(m.parameters[0].name == "first");
    CHECK(m.parameters[1].name == "second");
}

TEST_CASE("ModelBuilder refuses descriptions that break the contract") {
    auto refuses = [](ModelBuilder b, const char* why) {
        CAPTURE(why);
        CHECK_THROWS_AS(b.build(), std::logic_error);
    };
    {
        ModelBuilder b = valid_builder();
        b.counts(3, 1, 2);  // the header declares a parameter nobody describes
        refuses(b, "parameter count");
    }
    {
        ModelBuilder b = valid_builder();
        b.counts(2, 1, 3);
        refuses(b, "quantity count");
    }
    {
        ModelBuilder b = valid_builder();
        b.counts(3, 1, 2);
        b.parameter(kDirectionSlots + 1, parameter_info("c", "1", "dup slot", 0, 1, 0.5));
        refuses(b, "slot used twice");
    }
    {
        ModelBuilder b = valid_builder();
        b.counts(3, 1, 2);
        b.parameter(kDirectionSlots + 3, parameter_info("c", "1", "gap", 0, 1, 0.5));
        refuses(b, "slot outside the dense range");
    }
    {
        // A point beyond BT_MAX_POINT would overflow the kernels' p[] array.
        ModelBuilder b = valid_builder();
        const int extra = BT_MAX_POINT - kDirectionSlots - 2 + 1;
        b.counts(2 + extra, 1, 2);
        for (int k = 0; k < extra; ++k)
            b.parameter(kDirectionSlots + 2 + k,
                        parameter_info("x" + std::to_string(k), "1", "", 0, 1, 0.5));
        refuses(b, "beyond BT_MAX_POINT");
    }
    {
        ModelBuilder b = valid_builder();
        b.counts(2, 1 + BT_MAX_OPTIONS, 2);
        for (int k = 1; k <= BT_MAX_OPTIONS; ++k)
            b.option(k, OptionInfo{"o" + std::to_string(k), "", {"x"}, "x"});
        refuses(b, "beyond BT_MAX_OPTIONS");
    }
    {
        ModelBuilder b = valid_builder();
        b.counts(2, 1, 3);
        b.quantity(QuantityInfo{"q2", 1, "", "1", QuantityKind::ClosedForm, {}, {}, "", Method::ClosedForm, 0});
        refuses(b, "quantity id used twice");
    }
    {
        ModelBuilder b = valid_builder();
        b.counts(2, 1, 3);
        b.quantity(QuantityInfo{"q0", 2, "", "1", QuantityKind::ClosedForm, {}, {}, "", Method::ClosedForm, 0});
        refuses(b, "quantity name used twice");
    }
    {
        ModelBuilder b = valid_builder();
        b.counts(2, 1, 3);
        b.quantity(QuantityInfo{"q2", 2, "", "1", QuantityKind::ClosedForm, {}, {"colour"}, "",
                                Method::ClosedForm, 0});
        refuses(b, "unknown option");
    }
    {
        ModelBuilder b = valid_builder();
        b.counts(2, 1, 3);
        b.quantity(QuantityInfo{"q2", 2, "", "1", QuantityKind::ClosedForm, {"phi_d"}, {}, "",
                                Method::ClosedForm, 0});
        refuses(b, "direction that is not a slot");
    }
    {
        ModelBuilder b = valid_builder();
        b.counts(3, 1, 2);
        b.parameter(kDirectionSlots + 2, parameter_info("c", "1", "", 0, 1, 2.0));
        refuses(b, "default outside the range");
    }
    {
        ModelBuilder b = valid_builder();
        b.counts(3, 1, 2);
        b.parameter(kDirectionSlots + 2, parameter_info("theta_i", "1", "", 0, 1, 0.5));
        refuses(b, "parameter named like a direction");
    }
    {
        ModelBuilder b = valid_builder();
        b.counts(2, 2, 2);
        b.option(1, OptionInfo{"other", "", {"x", "y"}, "z"});
        refuses(b, "default choice missing");
    }
    {
        ModelBuilder b = valid_builder();
        b.kernel("", "f", nullptr);
        refuses(b, "no kernel");
    }
    {
        ModelBuilder b = valid_builder();
        b.counts(2, 1, 3);
        b.quantity(QuantityInfo{"q2", 2, "", "1", QuantityKind::ClosedForm, {}, {}, "",
                                Method::Rqmc, 0});
        refuses(b, "default method that does not suit the kind");
    }
    // Launch preferences and bench cases name what the model has.
    {
        ModelBuilder b = valid_builder();
        b.quantity_by_id(0).sample_parallel.push_back({Method::Rqmc, {{"colour", "x"}}});
        refuses(b, "sample-parallel rule naming an unknown option");
    }
    {
        ModelBuilder b = valid_builder();
        b.quantity_by_id(0).sample_parallel.push_back({Method::MonteCarlo, {{"mode", "z"}}});
        refuses(b, "sample-parallel rule naming an unknown choice");
    }
    {
        ModelBuilder b = valid_builder();
        b.quantity_by_id(0).sample_parallel.push_back({Method::Quadrature, {}});
        refuses(b, "sample-parallel rule for a method without samples");
    }
    {
        ModelBuilder b = valid_builder();
        b.quantity_by_id(1).fixed_step_solver = {{"mode", "w"}};
        refuses(b, "fixed-step solver under an unknown choice");
    }
    {
        ModelBuilder b = valid_builder();
        b.bench({"q9"});
        refuses(b, "bench case of an unknown quantity");
    }
    {
        ModelBuilder b = valid_builder();
        b.bench({"q0", false, 0, 89, Method::Auto, true});
        b.bench({"q1", false, 0, 89, Method::Auto, true});
        refuses(b, "two headline bench cases");
    }
    {
        ModelBuilder b = valid_builder();
        CHECK_THROWS_AS(b.float_vs_double(7, 1e-6), std::logic_error);  // no quantity 7
    }
    {
        // The same preferences with existing names are accepted and kept.
        ModelBuilder b = valid_builder();
        b.quantity_by_id(0).sample_parallel.push_back({Method::Rqmc, {{"mode", "y"}}});
        b.quantity_by_id(0).fixed_step_solver = {{"mode", "x"}};
        b.force_inline().float_vs_double(1, 2.5e-7, "note").bench({"q1", true});
        const ModelInfo m = b.build();
        CHECK(m.force_inline);
        REQUIRE(m.quantities[0].sample_parallel.size() == 1);
        CHECK(m.quantities[0].sample_parallel[0].options[0].choice == "y");
        CHECK(m.quantities[1].float_max_rel_diff == 2.5e-7);
        CHECK(m.quantities[1].float_note == "note");
        REQUIRE(m.bench.size() == 1);
        CHECK(m.bench[0].per_cell);
    }
}

TEST_CASE("the bench cases come from the models, with one headline") {
    // default_bench_cases() (host/engine/bench.h) reads ModelInfo::bench;
    // the headline is the device rate the bench's targets judge.
    int headlines = 0;
    std::size_t cases = 0;
    for (const auto& m : all_models())
        for (const auto& c : m.bench) {
            CAPTURE(m.name);
            CAPTURE(c.quantity);
            const QuantityInfo& q = m.quantity(c.quantity);  // throws on an unknown one
            // Quadratures report cells per second.
            if (c.per_cell) CHECK(q.default_method == Method::Quadrature);
            headlines += c.headline ? 1 : 0;
            ++cases;
        }
    CHECK(headlines == 1);
    CHECK(cases >= all_models().size());  // every model has a case
}

TEST_CASE("integer parameters refuse fractions (the kernels would round them)") {
    const ModelInfo& ls = find_model("lambert-sphere");
    const QuantityInfo& q = ls.quantity("brdf_mc");
    PointBuilder builder(ls, q);
    CHECK(builder.check("order", 2.0).empty());
    CHECK(builder.check("order", 2.5).find("integers in [-2, 100000]") != std::string::npos);
    CHECK(builder.check("mode", 0.5) != "");
    CHECK(builder.check("c", 0.5).empty());  // continuous
    for (const char* model : {"hfunction", "oren-nayar", "interfaced-lambertian"}) {
        CAPTURE(model);
        const ModelInfo& m = find_model(model);
        int integers = 0;
        for (const auto& p : m.parameters) integers += p.integer ? 1 : 0;
        CHECK(integers == 1);  // n, nodes, order
    }
    std::vector<double> point(ls.point_stride());
    CHECK_THROWS_AS(builder.build({{"theta_i", 10}, {"theta_o", 20}, {"order", 1.5}}, point.data()),
                    InputError);
}

TEST_CASE("float accuracy per quantity: the docs/precision.md measurements reach every listed quantity") {
    // docs/precision.md "Float against double" lists 34 (model, quantity) rows;
    // a renamed quantity would silently drop out of `brdftab models`.
    int measured = 0;
    for (const auto& m : all_models())
        for (const auto& q : m.quantities)
            if (q.float_measured()) {
                ++measured;
                CHECK(q.float_max_rel_diff <= 1.0);
                // The storage verdicts follow the stored types' precision.
                CHECK(q.float_enough_for_float32() == (q.float_max_rel_diff <= std::ldexp(1.0, -24)));
                CHECK(q.float_enough_for_float16() == (q.float_max_rel_diff <= std::ldexp(1.0, -11)));
            }
    CHECK(measured == 34);
    const QuantityInfo& bsdf = find_model("rough-dielectric").quantity("bsdf");
    CHECK_FALSE(bsdf.float_enough_for_float16());
    CHECK_FALSE(bsdf.float_note.empty());
    const QuantityInfo& h = find_model("hfunction").quantity("H");
    CHECK(h.float_enough_for_float16());
    CHECK_FALSE(h.float_enough_for_float32());
    CHECK(find_model("interfaced-lambertian").quantity("ri").float_enough_for_float32());
}
