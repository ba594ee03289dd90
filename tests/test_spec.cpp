// test_spec.cpp — the TOML table-spec parser.
//
// Oracles: hand-written specs whose intended meaning is known (values typed
// into the spec are the expected values; node positions follow from the
// spacing definitions), and for every rejected spec the line number where the
// offending key was typed (the specs are built line by line, so the expected
// line is known by construction).  The presets in tables/ must all parse.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <initializer_list>
#include <string>

#include "host/core/error.h"
#include "host/spec/spec.h"
#include "test_support.h"

using namespace brdftab;

namespace {

std::string lines(std::initializer_list<const char*> ls) {
    std::string s;
    for (const char* l : ls) {
        s += l;
        s += '\n';
    }
    return s;
}

// Expect an InputError from parsing `text` as "spec.toml", whose message has
// the position prefix with `line`, names `key` and contains `needle`.
void expect_error(const std::string& text, int line, const std::string& key,
                  const std::string& needle = "") {
    try {
        parse_spec_string(text, "spec.toml");
        FAIL_CHECK("no InputError for:\n" << text);
    } catch (const InputError& e) {
        const std::string m = e.what();
        CAPTURE(m);
        CHECK(m.rfind("spec.toml:" + std::to_string(line) + ":", 0) == 0);
        CHECK(m.find("key '" + key + "'") != std::string::npos);
        if (!needle.empty()) CHECK(m.find(needle) != std::string::npos);
    }
}

const Axis* find_axis(const TableSpec& t, const std::string& name) {
    for (const Axis& a : t.axes)
        if (a.name == name) return &a;
    return nullptr;
}

// A minimal valid header: model and the two required parameters.
#define HEADER "model = \"rough-dielectric\"", "[parameters]", "alpha = 0.3", "eta = 1.5"

}  // namespace

TEST_CASE("a complete spec parses to the expected structures") {
    const std::string text = lines({
        "model = \"rough-dielectric\"",            // 1
        "description = \"test spec\"",              // 2
        "[parameters]",                             // 3
        "distribution = \"beckmann\"",              // 4
        "eta = 1.5",                                // 5
        "theta_o = 30",                             // 6 (ignored by albedo_r)
        "[[axes]]",                                 // 7
        "name = \"theta_i\"",                       // 8
        "range = [0.0, 80]",                        // 9
        "count = 9",                                // 10
        "[[axes]]",                                 // 11
        "name = \"alpha\"",                         // 12
        "range = [0.01, 1.0]",                      // 13
        "count = 3",                                // 14
        "spacing = \"log\"",                        // 15
        "[[tables]]",                               // 16
        "quantity = \"brdf\"",                      // 17
        "description = \"reflection\"",             // 18
        "[[tables]]",                               // 19
        "name = \"E_r\"",                           // 20
        "quantity = \"albedo_r\"",                  // 21
        "[tables.parameters]",                      // 22
        "g1 = \"walter-fit\"",                      // 23
        "[integration]",                            // 24
        "method = \"rqmc\"",                        // 25
        "samples = 1024",                           // 26
        "tolerance = 1e-3",                         // 27
        "abs_floor = 1e-7",                         // 28
        "max_samples = 65536",                      // 29
        "seed = 7",                                 // 30
        "batch_size = 128",                         // 31
        "[output]",                                 // 32
        "path = \"out/x.h5\"",                      // 33
        "type = \"float16\"",                       // 34
        "compression = 0",                          // 35
        "keep_stderr = false",                      // 36
    });
    const Spec s = parse_spec_string(text, "dir/some-spec.toml");
    CHECK(s.file == "dir/some-spec.toml");
    CHECK(s.text == text);
    CHECK(s.model == "rough-dielectric");
    CHECK(s.description == "test spec");
    REQUIRE(s.tables.size() == 2);

    const TableSpec& b = s.tables[0];
    CHECK(b.name == "brdf");
    CHECK(b.quantity == "brdf");
    CHECK(b.description == "reflection");
    CHECK(b.fixed.size() == 3);  // eta, theta_o and nodes (its default)
    CHECK(b.fixed.at("eta") == 1.5);
    CHECK(b.fixed.at("theta_o") == 30);
    CHECK(b.options.at("distribution") == "beckmann");
    // Options not given are recorded with the model's defaults.
    CHECK(b.options.at("g1") == "smith");
    CHECK(b.options.at("shadowing") == "separable");
    REQUIRE(b.axes.size() == 2);
    CHECK(b.axes[0].name == "theta_i");
    CHECK(b.axes[0].unit == "deg");
    CHECK(b.axes[0].spacing == Spacing::Linear);
    CHECK(b.axes[0].count == 9);
    CHECK(b.axes[0].values[0] == 0.0);
    CHECK(b.axes[0].values[1] == doctest::Approx(10.0));
    CHECK(b.axes[0].values[8] == 80.0);
    CHECK(b.axes[1].name == "alpha");
    CHECK(b.axes[1].unit == "1");
    CHECK(b.axes[1].spacing == Spacing::Log);
    CHECK(b.axes[1].values[1] == doctest::Approx(0.1));  // geometric mean of 0.01 and 1

    const TableSpec& e = s.tables[1];
    CHECK(e.name == "E_r");
    CHECK(e.quantity == "albedo_r");
    // theta_o is irrelevant for an albedo and is dropped from the shared values.
    CHECK(e.fixed.count("theta_o") == 0);
    CHECK(e.fixed.at("eta") == 1.5);
    CHECK(e.options.at("g1") == "walter-fit");
    CHECK(e.options.at("distribution") == "beckmann");
    CHECK(e.axes.size() == 2);

    CHECK(s.integration.method == Method::Rqmc);
    CHECK(s.integration.samples == 1024);
    CHECK(s.integration.tolerance == 1e-3);
    CHECK(s.integration.abs_floor == 1e-7);
    CHECK(s.integration.max_samples == 65536);
    CHECK(s.integration.seed == 7);
    CHECK(s.integration.batch_size == 128);
    CHECK(s.output.path == "dir/out/x.h5");  // relative to the spec's directory
    CHECK(s.output.stored_type == StoredType::Float16);
    CHECK(s.output.compression == 0);
    CHECK(s.output.keep_stderr == false);
}

TEST_CASE("output.path: relative to the spec file's directory (issue #15)") {
    auto with_path = [](const char* path) {
        return lines({HEADER, "theta_o = 10", "[[axes]]", "name = \"theta_i\"", "range = [0, 45]",
                      "count = 2", "[[tables]]", "quantity = \"brdf\"", "[output]"}) +
               "path = \"" + path + "\"\n";
    };
    CHECK(parse_spec_string(with_path("x.h5"), "some/dir/s.toml").output.path == "some/dir/x.h5");
    CHECK(parse_spec_string(with_path("out/x.h5"), "/abs/s.toml").output.path == "/abs/out/x.h5");
    // ".." is resolved lexically against the spec's directory ...
    CHECK(parse_spec_string(with_path("../x.h5"), "some/dir/s.toml").output.path == "some/x.h5");
    CHECK(parse_spec_string(with_path("../../../x.h5"), "some/dir/s.toml").output.path ==
          "../x.h5");
    // ... an absolute path is kept, and a spec in the current directory (or
    // parsed from a string) keeps the path as written.
    CHECK(parse_spec_string(with_path("/tmp/x.h5"), "some/dir/s.toml").output.path == "/tmp/x.h5");
    CHECK(parse_spec_string(with_path("../x.h5"), "s.toml").output.path == "../x.h5");
    CHECK(parse_spec_string(with_path("x.h5"), "<string>").output.path == "x.h5");
}

TEST_CASE("defaults: output path from the spec file stem, integration and output settings") {
    const std::string text = lines({HEADER, "theta_o = 10", "[[axes]]", "name = \"theta_i\"",
                                    "range = [0, 45]", "count = 2", "[[tables]]",
                                    "quantity = \"brdf\""});
    const Spec s = parse_spec_string(text, "some/dir/my-table.toml");
    CHECK(s.output.path == "my-table.h5");
    const IntegrationSettings def;
    CHECK(s.integration.method == def.method);
    CHECK(s.integration.samples == def.samples);
    CHECK(s.integration.tolerance == def.tolerance);
    CHECK(s.integration.seed == def.seed);
    const OutputSettings odef;
    CHECK(s.output.stored_type == odef.stored_type);
    CHECK(s.output.compression == odef.compression);
    CHECK(s.output.keep_stderr == odef.keep_stderr);
    REQUIRE(s.tables.size() == 1);
    CHECK(s.tables[0].name == "brdf");
    CHECK(s.tables[0].options.at("distribution") == "ggx");
}

TEST_CASE("samples above the default cap raise max_samples with it") {
    const std::string text = lines({HEADER, "[[axes]]", "name = \"theta_i\"", "range = [0, 45]",
                                    "count = 2", "[[tables]]", "quantity = \"albedo_r\"",
                                    "[integration]", "samples = 8388608"});
    const Spec s = parse_spec_string(text, "spec.toml");
    CHECK(s.integration.samples == 8388608u);
    CHECK(s.integration.max_samples >= 8388608u);
}

TEST_CASE("per-table overrides of parameters and axes") {
    // Lines 1-11: global alpha, eta and theta_i, a theta_o axis, a second axis.
    const std::string head = lines({
        "model = \"rough-dielectric\"",  // 1
        "[parameters]",                  // 2
        "alpha = 0.3",                   // 3
        "eta = 1.5",                     // 4
        "theta_i = 20",                  // 5
        "[[axes]]",                      // 6
        "name = \"theta_o\"",            // 7
        "range = [0, 180]",              // 8
        "count = 5",                     // 9
        "spacing = \"cos\"",             // 10
        "[[axes]]",                      // 11
    });
    const std::string text = head + lines({
        "name = \"eta\"",  // line 12: also a global fixed value
        "range = [1.1, 2.0]",
        "count = 4",
    });
    // A global value and a global axis of the same name contradict each other.
    expect_error(text + lines({"[[tables]]", "quantity = \"brdf\""}), 12, "axes[1].name",
                 "eta");

    const std::string ok = head + lines({
        "name = \"alpha\"",  // 12 (global alpha is fixed: not allowed)
        "range = [0.1, 0.5]",
        "count = 3",
    });
    expect_error(ok + lines({"[[tables]]", "quantity = \"brdf\""}), 12, "axes[1].name",
                 "alpha");

    const std::string good = head + lines({
        "name = \"phi_d\"",
        "range = [0, 180]",
        "count = 3",
        "[[tables]]",  // inherits everything
        "quantity = \"bsdf\"",
        "[[tables]]",  // overrides a value
        "name = \"bsdf_water\"",
        "quantity = \"bsdf\"",
        "[tables.parameters]",
        "eta = 1.33",
        "distribution = \"phong\"",
        "[[tables]]",  // own axes replace the global ones; an axis over a globally fixed value
        "name = \"albedo\"",
        "quantity = \"albedo_t\"",
        "[[tables.axes]]",
        "name = \"mu_i\"",  // overrides the global theta_i (same direction)
        "range = [0.0, 1.0]",
        "count = 11",
        "[[tables.axes]]",
        "name = \"alpha\"",  // overrides the global alpha value
        "range = [0.05, 1.0]",
        "count = 4",
        "spacing = \"quadratic\"",
        "[[tables]]",  // a table-level value slices an inherited global axis away
        "name = \"slice\"",
        "quantity = \"brdf\"",
        "[tables.parameters]",
        "phi_d = 180",
    });
    const Spec s = parse_spec_string(good, "spec.toml");
    REQUIRE(s.tables.size() == 4);

    const TableSpec& t0 = s.tables[0];
    CHECK(t0.fixed.at("eta") == 1.5);
    CHECK(t0.fixed.at("theta_i") == 20);
    CHECK(t0.options.at("distribution") == "ggx");
    REQUIRE(t0.axes.size() == 2);
    CHECK(t0.axes[1].name == "phi_d");
    CHECK(t0.axes[1].values[1] == doctest::Approx(90.0));
    const Axis& th = t0.axes[0];
    CHECK(th.spacing == Spacing::Cos);
    // Uniform in cos: 1, 0.5, 0, -0.5, -1 -> 0, 60, 90, 120, 180 degrees.
    CHECK(th.values[1] == doctest::Approx(60.0));
    CHECK(th.values[2] == doctest::Approx(90.0));
    CHECK(th.values[3] == doctest::Approx(120.0));

    const TableSpec& t1 = s.tables[1];
    CHECK(t1.name == "bsdf_water");
    CHECK(t1.fixed.at("eta") == 1.33);
    CHECK(t1.fixed.at("alpha") == 0.3);
    CHECK(t1.options.at("distribution") == "phong");

    const TableSpec& t2 = s.tables[2];
    CHECK(t2.quantity == "albedo_t");
    REQUIRE(t2.axes.size() == 2);
    CHECK(t2.axes[0].name == "mu_i");
    CHECK(t2.axes[0].unit == "1");
    CHECK(t2.axes[1].name == "alpha");
    CHECK(t2.axes[1].spacing == Spacing::Quadratic);
    CHECK(t2.fixed.count("theta_i") == 0);  // replaced by the mu_i axis
    CHECK(t2.fixed.count("alpha") == 0);    // replaced by the alpha axis
    CHECK(t2.fixed.at("eta") == 1.5);
    CHECK(find_axis(t2, "theta_o") == nullptr);

    const TableSpec& t3 = s.tables[3];
    REQUIRE(t3.axes.size() == 1);
    CHECK(t3.axes[0].name == "theta_o");
    CHECK(t3.fixed.at("phi_d") == 180);
}

// A valid body after HEADER (lines 1-4): axes on lines 5-12, a brdf table on 13-14.
#define BODY                                                                            \
    "[[axes]]", "name = \"theta_i\"", "range = [0, 80]", "count = 5", "[[axes]]",       \
        "name = \"theta_o\"", "range = [0, 180]", "count = 7", "[[tables]]",            \
        "quantity = \"brdf\""

TEST_CASE("the error-case baseline is valid") {
    const Spec s = parse_spec_string(lines({HEADER, BODY}), "spec.toml");
    REQUIRE(s.tables.size() == 1);
    CHECK(s.tables[0].axes.size() == 2);
}

TEST_CASE("TOML syntax errors carry toml++'s position") {
    try {
        parse_spec_string(lines({HEADER, "[[axes]]", "name = \"theta_i", "count = 3"}),
                          "spec.toml");
        FAIL("no exception");
    } catch (const InputError& e) {
        const std::string m = e.what();
        CAPTURE(m);
        CHECK(m.rfind("spec.toml:6:", 0) == 0);
        CHECK(m.find("TOML") != std::string::npos);
    }
}

TEST_CASE("unknown keys are rejected with the list of allowed keys") {
    expect_error(lines({"model = \"rough-dielectric\"", "colour = 3", "[parameters]",
                        "alpha = 0.3", "eta = 1.5", BODY}),
                 2, "colour", "allowed: model");
    // In [parameters] an unknown name is an unknown parameter.
    expect_error(lines({HEADER, "colour = 3", BODY}), 5, "parameters.colour", "alpha, eta");
    expect_error(lines({HEADER, BODY, "[integration]", "sample = 3"}), 16, "integration.sample",
                 "max_samples");
    expect_error(lines({HEADER, BODY, "[output]", "format = \"h5\""}), 16, "output.format",
                 "keep_stderr");
    expect_error(lines({HEADER, BODY, "quantiy = \"btdf\""}), 15, "tables[0].quantiy",
                 "quantity");
    expect_error(lines({HEADER, "[[axes]]", "name = \"theta_i\"", "range = [0, 80]",
                        "count = 5", "step = 2", "[[tables]]", "quantity = \"albedo_r\""}),
                 9, "axes[0].step", "spacing");
}

TEST_CASE("wrong value types") {
    expect_error(lines({"model = 3", "[[tables]]", "quantity = \"brdf\""}), 1, "model",
                 "string");
    expect_error(lines({HEADER, "[[axes]]", "name = \"theta_i\"", "range = [0, 80]",
                        "count = 5.0", "[[tables]]", "quantity = \"albedo_r\""}),
                 8, "axes[0].count", "integer");
    expect_error(lines({HEADER, "[[axes]]", "name = \"theta_i\"", "range = \"0..80\"",
                        "count = 5", "[[tables]]", "quantity = \"albedo_r\""}),
                 7, "axes[0].range", "two numbers");
    expect_error(lines({HEADER, "[[axes]]", "name = \"theta_i\"", "range = [0, 10, 80]",
                        "count = 5", "[[tables]]", "quantity = \"albedo_r\""}),
                 7, "axes[0].range", "two numbers");
    expect_error(lines({HEADER, BODY, "[output]", "keep_stderr = \"yes\""}), 16,
                 "output.keep_stderr", "true or false");
    expect_error(lines({HEADER, BODY, "[integration]", "seed = 1.5"}), 16, "integration.seed",
                 "integer");
    expect_error(lines({"model = \"rough-dielectric\"", "[parameters]", "alpha = \"rough\"",
                        "eta = 1.5", BODY}),
                 3, "parameters.alpha", "number");
    expect_error(lines({HEADER, "distribution = 2", BODY}), 5, "parameters.distribution",
                 "beckmann");
    expect_error(lines({"model = \"rough-dielectric\"", "parameters = 3", BODY}), 2,
                 "parameters", "table");
    expect_error(lines({HEADER, BODY, "parameters = 4"}), 15, "tables[0].parameters", "table");
}

TEST_CASE("model and quantity names") {
    expect_error(lines({"description = \"no model\"", "[[tables]]", "quantity = \"brdf\""}), 1,
                 "model", "rough-dielectric");
    expect_error(lines({"model = \"glass\"", "[[tables]]", "quantity = \"brdf\""}), 1, "model",
                 "allowed: rough-dielectric");
    expect_error(lines({HEADER, "[[axes]]", "name = \"theta_i\"", "range = [0, 80]",
                        "count = 5", "[[tables]]", "quantity = \"brdf_r\""}),
                 10, "tables[0].quantity", "albedo_avg");
    // Missing quantity: reported at the [[tables]] header.
    expect_error(lines({HEADER, "[[axes]]", "name = \"theta_i\"", "range = [0, 80]",
                        "count = 5", "[[tables]]", "name = \"x\""}),
                 9, "tables[0].quantity", "brdf");
    expect_error(lines({HEADER, "[[axes]]", "name = \"theta_i\"", "range = [0, 80]",
                        "count = 5"}),
                 1, "tables", "[[tables]]");
    expect_error(lines({HEADER, BODY, "name = \"my table\""}), 15, "tables[0].name",
                 "letters, digits");
}

TEST_CASE("parameter names, option choices and value ranges") {
    expect_error(lines({HEADER, "roughness = 0.2", BODY}), 5, "parameters.roughness",
                 "alpha, eta, nodes (parameters)");
    expect_error(lines({"model = \"rough-dielectric\"", "[parameters]", "alpha = 0.3",
                        "eta = 0", BODY}),
                 4, "parameters.eta", "(0, 100]");
    expect_error(lines({"model = \"rough-dielectric\"", "[parameters]", "alpha = 4.5",
                        "eta = 1.5", BODY}),
                 3, "parameters.alpha", "(0, 4]");
    expect_error(lines({HEADER, "phi_i = 400", BODY}), 5, "parameters.phi_i", "[-360, 360]");
    expect_error(lines({HEADER, "mu_o = -1.5", "[[axes]]", "name = \"theta_i\"",
                        "range = [0, 80]", "count = 5", "[[tables]]", "quantity = \"brdf\""}),
                 5, "parameters.mu_o", "[-1, 1]");
    expect_error(lines({HEADER, "distribution = \"gauss\"", BODY}), 5,
                 "parameters.distribution", "beckmann, ggx, phong");
    expect_error(lines({HEADER, BODY, "[tables.parameters]", "lobe = \"diffuse\""}), 16,
                 "tables[0].parameters.lobe", "reflection");
    // theta and mu of the same direction in one block.
    expect_error(lines({HEADER, "theta_o = 10", "mu_o = 0.5", "[[axes]]", "name = \"theta_i\"",
                        "range = [0, 80]", "count = 5", "[[tables]]", "quantity = \"brdf\""}),
                 6, "parameters.mu_o", "same direction");
}

TEST_CASE("axis definitions") {
    auto axis_spec = [](const char* a, const char* b, const char* c) {
        return lines({HEADER, "theta_o = 10", "[[axes]]", a, b, c, "[[tables]]",
                      "quantity = \"brdf\""});
    };
    // Line numbers: axis keys are on lines 7, 8, 9.
    expect_error(axis_spec("name = \"theta_i\"", "range = [0, 80]", "count = 1"), 9,
                 "axes[0].count", "2 ..");
    expect_error(axis_spec("name = \"theta_i\"", "range = [40, 40]", "count = 3"), 8,
                 "axes[0].range", "less than");
    expect_error(axis_spec("name = \"theta_i\"", "range = [50, 40]", "count = 3"), 8,
                 "axes[0].range", "less than");
    expect_error(axis_spec("name = \"alpha\"", "range = [0.0, 1.0]", "count = 3"), 8,
                 "axes[0].range[0]", "(0, 4]");
    expect_error(axis_spec("name = \"alpha\"", "range = [0.1, 5.0]", "count = 3"), 8,
                 "axes[0].range[1]", "(0, 4]");
    expect_error(axis_spec("name = \"theta_i\"", "range = [0, 190]", "count = 3"), 8,
                 "axes[0].range[1]", "[0, 180]");
    expect_error(axis_spec("name = \"theta_i\"", "range = [0, 80]", "spacing = \"log\""), 8,
                 "axes[0].range", "min > 0");
    expect_error(axis_spec("name = \"theta_i\"", "range = [0, 80]", "spacing = \"sqrt\""), 9,
                 "axes[0].spacing", "quadratic");
    expect_error(axis_spec("name = \"mu_i\"", "range = [0, 1]", "spacing = \"cos\""), 9,
                 "axes[0].spacing", "angle");
    expect_error(axis_spec("name = \"theta_i\"", "count = 3", "spacing = \"linear\""), 6,
                 "axes[0].range", "missing");
    expect_error(axis_spec("range = [0, 80]", "count = 3", "spacing = \"linear\""), 6,
                 "axes[0].name", "missing");
    expect_error(axis_spec("name = \"roughness\"", "range = [0, 80]", "count = 3"), 7,
                 "axes[0].name", "alpha, eta");
    expect_error(axis_spec("name = \"distribution\"", "range = [0, 80]", "count = 3"), 7,
                 "axes[0].name", "categorical");
    expect_error(axis_spec("name = \"theta_i\"", "spacing = \"explicit\"", "range = [0, 80]"),
                 9, "axes[0].range", "explicit");
    expect_error(axis_spec("name = \"theta_i\"", "spacing = \"explicit\"", "count = 3"), 9,
                 "axes[0].count", "explicit");
    expect_error(axis_spec("name = \"theta_i\"", "spacing = \"explicit\"", "# no values"), 6,
                 "axes[0].values", "missing");
    expect_error(axis_spec("name = \"theta_i\"", "spacing = \"explicit\"", "values = [0, 20, 10]"),
                 9, "axes[0].values", "increasing");
    expect_error(axis_spec("name = \"theta_i\"", "spacing = \"explicit\"", "values = [0, 200]"),
                 9, "axes[0].values[1]", "[0, 180]");
    expect_error(axis_spec("name = \"theta_i\"", "values = [0, 20]", "count = 3"), 8,
                 "axes[0].values", "explicit");

    // Explicit nodes are taken as given.
    const Spec s = parse_spec_string(
        axis_spec("name = \"theta_i\"", "spacing = \"explicit\"", "values = [0, 15, 60, 89]"),
        "spec.toml");
    const Axis& a = s.tables[0].axes.at(0);
    CHECK(a.spacing == Spacing::Explicit);
    CHECK(a.values == std::vector<double>{0, 15, 60, 89});
    CHECK(a.count == 4);
}

TEST_CASE("axis combinations") {
    // Duplicate axis (second one on line 13).
    expect_error(lines({HEADER, "theta_o = 10", "[[axes]]", "name = \"theta_i\"",
                        "range = [0, 80]", "count = 5", "[[axes]]", "name = \"theta_i\"",
                        "range = [0, 40]", "count = 3", "[[tables]]", "quantity = \"brdf\""}),
                 11, "axes[1].name", "duplicate");
    // mu_i together with theta_i.
    expect_error(lines({HEADER, "theta_o = 10", "[[axes]]", "name = \"theta_i\"",
                        "range = [0, 80]", "count = 5", "[[axes]]", "name = \"mu_i\"",
                        "range = [0, 1]", "count = 3", "[[tables]]", "quantity = \"brdf\""}),
                 11, "axes[1].name", "same direction");
    // phi_d together with phi_o: both axes ...
    expect_error(lines({HEADER, BODY, "[[axes]]", "name = \"phi_o\"", "range = [0, 180]",
                        "count = 3", "[[axes]]", "name = \"phi_d\"", "range = [0, 180]",
                        "count = 3"}),
                 20, "axes[3].name", "same direction");
    // ... both fixed ...
    expect_error(lines({HEADER, "phi_d = 10", "phi_o = 20", BODY}), 6, "parameters.phi_o",
                 "same direction");
    // ... or one fixed, the other an axis at the same level.
    expect_error(lines({HEADER, "phi_o = 10", BODY, "[[axes]]", "name = \"phi_d\"",
                        "range = [0, 180]", "count = 3"}),
                 17, "axes[2].name", "fixed value");
    // An axis also given as a fixed value (global level).
    expect_error(lines({HEADER, "theta_i = 10", BODY}), 7, "axes[0].name", "fixed value");
    // ... and at table level.
    expect_error(lines({HEADER, BODY, "[tables.parameters]", "theta_o = 20", "[[tables.axes]]",
                        "name = \"theta_o\"", "range = [0, 90]", "count = 3"}),
                 18, "tables[0].axes[0].name", "fixed value");
    // An axis the quantity does not depend on, inherited from the global axes.
    expect_error(lines({HEADER, BODY, "[[tables]]", "quantity = \"albedo_r\""}), 10,
                 "axes[1].name", "[[tables.axes]]");
    // ... and given by the table itself.
    expect_error(lines({HEADER, "[[tables]]", "quantity = \"albedo_avg\"", "[[tables.axes]]",
                        "name = \"mu_i\"", "range = [0, 1]", "count = 3"}),
                 8, "tables[0].axes[0].name", "does not depend on 'mu_i'");
    // A table-level fixed direction the quantity ignores.
    expect_error(lines({HEADER, "[[axes]]", "name = \"theta_i\"", "range = [0, 80]",
                        "count = 5", "[[tables]]", "quantity = \"albedo_r\"",
                        "[tables.parameters]", "theta_o = 30"}),
                 12, "tables[0].parameters.theta_o", "does not depend");
    // No axes at all.
    expect_error(lines({HEADER, "[[tables]]", "quantity = \"albedo_avg\""}), 5, "tables[0].axes",
                 "no axes");
}

TEST_CASE("required directions and parameters") {
    // brdf needs theta_o: reported at the [[tables]] header (line 9).
    expect_error(lines({HEADER, "[[axes]]", "name = \"theta_i\"", "range = [0, 80]",
                        "count = 5", "[[tables]]", "quantity = \"brdf\""}),
                 9, "tables[0]", "needs 'theta_o'");
    // phi directions default to 0: no error without them.
    CHECK_NOTHROW(parse_spec_string(lines({HEADER, BODY}), "spec.toml"));
    // alpha has no default.
    expect_error(lines({"model = \"rough-dielectric\"", "[parameters]", "eta = 1.5", BODY}), 12,
                 "tables[0]", "needs parameter 'alpha'");
    // eta is a global axis; the second table has its own axes without eta and
    // nothing fixes it, so only that table is missing it.
    const std::string two = lines({
        "model = \"rough-dielectric\"",  // 1
        "[parameters]",                  // 2
        "alpha = 0.2",                   // 3
        "[[axes]]",                      // 4
        "name = \"eta\"",                // 5
        "range = [1.1, 2]",              // 6
        "count = 3",                     // 7
        "[[tables]]",                    // 8
        "quantity = \"albedo_avg\"",     // 9
        "[[tables]]",                    // 10
        "quantity = \"albedo_r\"",       // 11
        "[tables.parameters]",           // 12
        "theta_i = 45",                  // 13
        "[[tables.axes]]",               // 14
        "name = \"alpha\"",              // 15  (overrides the global alpha)
        "range = [0.1, 1]",              // 16
        "count = 3",                     // 17
    });
    expect_error(two, 10, "tables[1]", "needs parameter 'eta'");
}

TEST_CASE("table names, integration and output settings") {
    expect_error(lines({HEADER, BODY, "[[tables]]", "quantity = \"brdf\""}), 15,
                 "tables[1].name", "duplicate");
    expect_error(lines({HEADER, BODY, "name = \"t\"", "[[tables]]", "name = \"t\"",
                        "quantity = \"btdf\""}),
                 17, "tables[1].name", "duplicate");
    auto with = [](const char* section, const char* line) {
        return lines({HEADER, BODY, section, line});
    };
    expect_error(with("[output]", "type = \"float8\""), 16, "output.type",
                 "float64, float32, float16");
    expect_error(with("[output]", "compression = 10"), 16, "output.compression", "0 .. 9");
    expect_error(with("[output]", "compression = -1"), 16, "output.compression", "0 .. 9");
    expect_error(with("[output]", "path = \"\""), 16, "output.path", "empty");
    expect_error(with("[integration]", "method = \"simpson\""), 16, "integration.method",
                 "auto, closed-form, quadrature, mc, rqmc");
    expect_error(with("[integration]", "seed = -1"), 16, "integration.seed", ">= 0");
    expect_error(with("[integration]", "samples = 0"), 16, "integration.samples",
                 "[1, 4294967295]");
    // Issue #15: counts above 2^32 - 1 were truncated (2^44 ran 0 samples).
    expect_error(with("[integration]", "samples = 17592186044416"), 16, "integration.samples",
                 "integers in [1, 4294967295]");
    expect_error(with("[integration]", "samples = 4294967296"), 16, "integration.samples",
                 "[1, 4294967295]");
    expect_error(with("[integration]", "max_samples = 17592186044416"), 16,
                 "integration.max_samples", "[1, 4294967295]");
    CHECK(parse_spec_string(with("[integration]", "samples = 4294967295"), "spec.toml")
              .integration.samples == 4294967295u);
    expect_error(with("[integration]", "tolerance = 1.5"), 16, "integration.tolerance",
                 "(0, 1)");
    expect_error(with("[integration]", "tolerance = 0"), 16, "integration.tolerance", "(0, 1)");
    expect_error(with("[integration]", "abs_floor = 0"), 16, "integration.abs_floor", "> 0");
    expect_error(with("[integration]", "batch_size = 0"), 16, "integration.batch_size",
                 "1 .. 65536");
    expect_error(with("[integration]", "batch_size = 65537"), 16, "integration.batch_size",
                 "1 .. 65536");
    expect_error(lines({HEADER, BODY, "[integration]", "samples = 1000", "max_samples = 999"}),
                 17, "integration.max_samples", ">= samples");
    // Closed-form method for an integral quantity.
    expect_error(lines({HEADER, "[[axes]]", "name = \"theta_i\"", "range = [0, 80]",
                        "count = 5", "[[tables]]", "quantity = \"albedo_r\"", "[integration]",
                        "method = \"closed-form\""}),
                 12, "integration.method", "mc, rqmc");
    // samples and tolerance together are allowed.
    const Spec s = parse_spec_string(
        lines({HEADER, BODY, "[integration]", "samples = 256", "tolerance = 0.01"}), "spec.toml");
    CHECK(s.integration.samples == 256);
    CHECK(s.integration.tolerance == 0.01);
}

TEST_CASE("too many cells for 32-bit cell indices") {
    expect_error(lines({HEADER, "[[axes]]", "name = \"theta_i\"", "range = [0, 80]",
                        "count = 100000", "[[axes]]", "name = \"theta_o\"", "range = [0, 80]",
                        "count = 100000", "[[tables]]", "quantity = \"brdf\""}),
                 13, "tables[0]", "cells");
}

TEST_CASE("spec files: missing file, and every preset in tables/ parses") {
    CHECK_THROWS_AS(parse_spec_file("/nonexistent/dir/spec.toml"), InputError);

    namespace fs = std::filesystem;
    const fs::path dir = fs::path(BT_SOURCE_DIR) / "tables";
    REQUIRE(fs::is_directory(dir));
    int n = 0;
    for (const auto& entry : fs::directory_iterator(dir)) {
        if (entry.path().extension() != ".toml") continue;
        CAPTURE(entry.path().string());
        Spec s;
        CHECK_NOTHROW(s = parse_spec_file(entry.path().string()));
        CHECK(!s.tables.empty());
        CHECK(s.output.path.size() > 3);
        ++n;
    }
    CHECK(n >= 2);

    const Spec bsdf = parse_spec_file((dir / "rough-dielectric-bsdf.toml").string());
    REQUIRE(bsdf.tables.size() == 1);
    CHECK(bsdf.tables[0].quantity == "bsdf");
    std::vector<std::string> names;
    for (const Axis& a : bsdf.tables[0].axes) names.push_back(a.name);
    CHECK(names == std::vector<std::string>{"theta_i", "theta_o", "phi_d", "alpha", "eta"});

    const Spec alb = parse_spec_file((dir / "rough-dielectric-albedo.toml").string());
    std::vector<std::string> qs;
    for (const TableSpec& t : alb.tables) qs.push_back(t.quantity);
    CHECK(qs == std::vector<std::string>{"albedo_r", "albedo_t", "albedo_r", "albedo_t",
                                         "albedo_avg", "albedo_avg"});
    // Light from inside: the *_inside tables take mu_i < 0 (theta_i > 90 deg).
    REQUIRE(alb.tables.size() == 6);
    CHECK(alb.tables[2].name == "albedo_r_inside");
    CHECK(alb.tables[2].axes.at(0).name == "mu_i");
    CHECK(alb.tables[2].axes.at(0).max < 0);
    CHECK(alb.tables[5].options["side"] == "inside");
}

TEST_CASE("the annotated example in docs/spec.md parses as documented") {
    namespace fs = std::filesystem;
    std::ifstream in(fs::path(BT_SOURCE_DIR) / "docs" / "spec.md");
    REQUIRE(in.good());
    std::stringstream ss;
    ss << in.rdbuf();
    const std::string md = ss.str();
    const std::size_t begin = md.find("```toml\n");
    REQUIRE(begin != std::string::npos);
    const std::size_t end = md.find("```", begin + 8);
    REQUIRE(end != std::string::npos);
    const Spec s = parse_spec_string(md.substr(begin + 8, end - begin - 8), "dir/example.toml");
    REQUIRE(s.tables.size() == 2);
    CHECK(s.tables[0].name == "brdf");
    CHECK(s.tables[0].fixed.at("theta_o") == 30.0);
    REQUIRE(s.tables[0].axes.size() == 2);
    CHECK(s.tables[0].axes[1].values == std::vector<double>{0.05, 0.1, 0.2, 0.4, 0.8});
    CHECK(s.tables[1].name == "E_r");
    CHECK(s.tables[1].options.at("g1") == "walter-fit");
    CHECK(s.tables[1].fixed.count("theta_o") == 0);
    CHECK(s.output.path == "dir/glass.h5");
    CHECK(s.integration.tolerance == 1e-3);
}

// Two tables (brdf, btdf) on one 3 x 4 grid, the base of the derived-table
// cases; the expected line numbers below count on its 16 lines.
std::string two_tables() {
    std::string text = test::fixture_text("rough_dielectric_brdf_btdf.toml");
    REQUIRE(std::count(text.begin(), text.end(), '\n') == 16);
    return text;
}

TEST_CASE("[[recombined]]: recipe parsed; terms must exist and share their axes") {
    const std::string base = two_tables();
    const Spec s = parse_spec_string(base + R"([[recombined]]
name = "sum"
parameter = "w"
range = [0.0, 2.0]
[[recombined.terms]]
table = "brdf"
coeffs = [1.0]
[[recombined.terms]]
table = "btdf"
coeffs = [0.0, 1]
)",
                                     "spec.toml");
    REQUIRE(s.recombined.size() == 1);
    const RecombinedSpec& r = s.recombined[0];
    CHECK(r.name == "sum");
    CHECK(r.parameter == "w");
    REQUIRE(r.range.has_value());
    CHECK(r.range->second == 2.0);
    CHECK(r.stored_at == 2.0);  // default: the range's max
    REQUIRE(r.terms.size() == 2);
    CHECK(r.terms[1].first == "btdf");
    CHECK(r.terms[1].second == std::vector<double>{0.0, 1.0});

    // Line numbers: base has 16 lines, the [[recombined]] header is line 17.
    expect_error(base + "[[recombined]]\nname = \"x\"\nparameter = \"w\"\n[[recombined.terms]]\n"
                        "table = \"nope\"\ncoeffs = [1.0]\n",
                 21, "recombined[0].terms[0].table", "allowed: brdf, btdf");
    expect_error(base + "[[recombined]]\nname = \"brdf\"\nparameter = \"w\"\n", 18,
                 "recombined[0].name", "duplicate");
    expect_error(base + "[[recombined]]\nname = \"x\"\n", 17, "recombined[0].parameter",
                 "missing");
    expect_error(base + "[[recombined]]\nname = \"x\"\nparameter = \"w\"\nrange = [0.0, 1.0]\n"
                        "stored_at = 3.0\n[[recombined.terms]]\ntable = \"brdf\"\ncoeffs = [1.0]\n",
                 21, "recombined[0].stored_at", "outside range");
    expect_error(base + "[[recombined]]\nname = \"x\"\nparameter = \"w\"\n[[recombined.terms]]\n"
                        "table = \"brdf\"\ncoeffs = []\n",
                 22, "recombined[0].terms[0].coeffs", "non-empty");
    expect_error(base + "[[recombined]]\nname = \"x\"\nparameter = \"w\"\nbogus = 1\n", 20,
                 "recombined[0].bogus");
    // Terms on different axes cannot be added cell by cell.
    expect_error(base + "[[tables]]\nname = \"b2\"\nquantity = \"brdf\"\n[[tables.axes]]\n"
                        "name = \"theta_i\"\nrange = [0.0, 80.0]\ncount = 4\n[[tables.axes]]\n"
                        "name = \"theta_o\"\nrange = [0.0, 80.0]\ncount = 3\n"
                        "[[recombined]]\nname = \"x\"\nparameter = \"w\"\n[[recombined.terms]]\n"
                        "table = \"brdf\"\ncoeffs = [1.0]\n[[recombined.terms]]\n"
                        "table = \"b2\"\ncoeffs = [1.0]\n",
                 35, "recombined[0].terms[1].table", "share every axis");
}

TEST_CASE("[[errors]]: recipe parsed; compared tables must exist, differ and share axes and units") {
    const std::string base = two_tables();  // 16 lines: [[errors]] below starts at line 17
    const Spec s = parse_spec_string(base + R"([[errors]]
name = "e"
table = "btdf"
reference = "brdf"
by = "theta_o"
floor = 0.01
[[errors]]
name = "d"
table = "brdf"
reference = "btdf"
measure = "absolute"
)",
                                     "spec.toml");
    REQUIRE(s.errors.size() == 2);
    CHECK(s.errors[0].name == "e");
    CHECK(s.errors[0].table == "btdf");
    CHECK(s.errors[0].reference == "brdf");
    CHECK(s.errors[0].relative);  // the default measure
    CHECK(s.errors[0].floor == 0.01);
    CHECK(s.errors[0].by == "theta_o");
    CHECK_FALSE(s.errors[1].relative);
    CHECK(s.errors[1].by.empty());

    const std::string head = base + "[[errors]]\nname = \"x\"\n";  // lines 17-18
    expect_error(head + "reference = \"brdf\"\n", 17, "errors[0].table", "missing");
    expect_error(head + "table = \"brdf\"\n", 17, "errors[0].reference", "missing");
    expect_error(head + "table = \"nope\"\nreference = \"brdf\"\n", 19, "errors[0].table",
                 "allowed: brdf, btdf");
    expect_error(head + "table = \"brdf\"\nreference = \"brdf\"\n", 20, "errors[0].reference",
                 "different reference");
    expect_error(head + "table = \"brdf\"\nreference = \"btdf\"\nmeasure = \"ratio\"\n", 21,
                 "errors[0].measure", "allowed: relative, absolute");
    expect_error(head + "table = \"brdf\"\nreference = \"btdf\"\nfloor = -1.0\n", 21,
                 "errors[0].floor", ">= 0");
    expect_error(head + "table = \"brdf\"\nreference = \"btdf\"\nmeasure = \"absolute\"\n"
                        "floor = 1.0\n",
                 22, "errors[0].floor", "\"relative\" only");
    expect_error(head + "table = \"brdf\"\nreference = \"btdf\"\nby = \"alpha\"\n", 21,
                 "errors[0].by", "allowed: theta_i, theta_o");
    expect_error(head + "table = \"brdf\"\nreference = \"btdf\"\nbogus = 1\n", 21,
                 "errors[0].bogus", "unknown key");
    expect_error(base + "[[errors]]\nname = \"brdf\"\ntable = \"brdf\"\nreference = \"btdf\"\n",
                 18, "errors[0].name", "duplicate");
    // Another grid, and another unit (an albedo is in 1, a BRDF in 1/sr).
    expect_error(base + "[[tables]]\nname = \"b2\"\nquantity = \"brdf\"\n[[tables.axes]]\n"
                        "name = \"theta_i\"\nrange = [0.0, 80.0]\ncount = 4\n[[tables.axes]]\n"
                        "name = \"theta_o\"\nrange = [0.0, 80.0]\ncount = 3\n"
                        "[[errors]]\nname = \"x\"\ntable = \"brdf\"\nreference = \"b2\"\n",
                 31, "errors[0].reference", "share every axis");
    expect_error("model = \"rough-dielectric\"\n[parameters]\nalpha = 0.3\neta = 1.5\n"
                 "theta_o = 10.0\n[[axes]]\nname = \"theta_i\"\nrange = [0.0, 80.0]\ncount = 3\n"
                 "[[tables]]\nquantity = \"brdf\"\n[[tables]]\nquantity = \"albedo_r\"\n"
                 "[[errors]]\nname = \"x\"\ntable = \"brdf\"\nreference = \"albedo_r\"\n",
                 17, "errors[0].reference", "same units");
}

TEST_CASE("[[inverted]]: a 1-D source and a free value axis") {
    const std::string base = R"(model = "lambert-sphere"
[[tables]]
name = "kd"
quantity = "kd_fit"
[[tables.axes]]
name = "c"
range = [0.0, 1.0]
count = 11
[[tables]]
name = "two"
quantity = "brdf_single"
[[axes]]
name = "theta_i"
range = [0.0, 80.0]
count = 3
[[axes]]
name = "theta_o"
range = [0.0, 80.0]
count = 3
)";  // 19 lines: the [[inverted]] header below is line 20
    const Spec s = parse_spec_string(base + R"([[inverted]]
name = "c_of_kd"
table = "kd"
[inverted.axis]
name = "kd"
range = [0.0, 0.8]
count = 9
)",
                                     "spec.toml");
    REQUIRE(s.inverted.size() == 1);
    CHECK(s.inverted[0].table == "kd");
    CHECK(s.inverted[0].axis.name == "kd");
    CHECK(s.inverted[0].axis.unit == "1");  // the source's units
    CHECK(s.inverted[0].axis.count == 9);
    CHECK(s.inverted[0].axis.values.back() == 0.8);

    const std::string head = base + "[[inverted]]\nname = \"x\"\n";  // lines 20-21
    expect_error(head + "table = \"two\"\n[inverted.axis]\nname = \"y\"\nrange = [0.0, 1.0]\n"
                        "count = 3\n",
                 22, "inverted[0].table", "only a table with one axis");
    expect_error(head + "table = \"nope\"\n", 22, "inverted[0].table", "allowed: kd, two");
    expect_error(head + "table = \"kd\"\n", 20, "inverted[0].axis", "missing");
    expect_error(head + "table = \"kd\"\n[inverted.axis]\nname = \"c\"\nrange = [0.0, 1.0]\n"
                        "count = 3\n",
                 24, "inverted[0].axis.name", "is the axis of 'kd'");
    expect_error(head + "table = \"kd\"\n[inverted.axis]\nname = \"kd\"\nrange = [0.5, 0.1]\n"
                        "count = 3\n",
                 25, "inverted[0].axis.range", "min must be less than max");
    expect_error(head + "table = \"kd\"\nextra = 1\n", 23, "inverted[0].extra", "unknown key");
}
