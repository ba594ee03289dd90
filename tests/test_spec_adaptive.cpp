// test_spec_adaptive.cpp — the spec keys of adaptive tables: [output]
// representation, [adaptive] and a [[tables]] entry's `adaptive`
// (docs/spec.md "Adaptive tables"), and how they combine with the command
// line's options (host/plan/adaptive_plan.h, adaptive_generate_options).
//
// Oracles: hand-written specs whose meaning is known (the values typed are
// the expected ones), and for each rejected spec the line of the offending
// key, known by construction (the specs are built line by line).
#include <doctest/doctest.h>

#include <filesystem>
#include <initializer_list>
#include <string>

#include "host/core/error.h"
#include "host/plan/adaptive_plan.h"
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

void expect_error(const std::string& text, int line, const std::string& key, const std::string& needle) {
    try {
        parse_spec_string(text, "spec.toml");
        FAIL_CHECK("no InputError for:\n" << text);
    } catch (const InputError& e) {
        const std::string m = e.what();
        CAPTURE(m);
        CHECK(m.rfind("spec.toml:" + std::to_string(line) + ":", 0) == 0);
        CHECK(m.find("key '" + key + "'") != std::string::npos);
        CHECK(m.find(needle) != std::string::npos);
    }
}

// Lines 1-12: a two-axis albedo spec (mu_i critical, eta log) with one table.
#define BODY                                                                                                  \
    "model = \"rough-dielectric\"", "[parameters]", "alpha = 0.3", "[[axes]]", "name = \"mu_i\"",            \
        "range = [-1.0, -0.02]", "count = 9", "spacing = \"critical\"", "[[axes]]", "name = \"eta\"",       \
        "range = [1.2, 2.0]", "count = 3"
#define TABLE "[[tables]]", "quantity = \"albedo_t\""

}  // namespace

TEST_CASE("[output] representation: tensor by default, adaptive, auto; anything else refused") {
    const Spec plain = parse_spec_string(lines({BODY, TABLE}), "spec.toml");
    CHECK(plain.output.representation == "tensor");
    CHECK(!plain.output.representation_given);
    for (const char* r : {"tensor", "adaptive", "auto"}) {
        const std::string line = std::string("representation = \"") + r + "\"";
        const Spec s = parse_spec_string(lines({BODY, TABLE, "[output]", line.c_str()}), "spec.toml");
        CHECK(s.output.representation == r);
        CHECK(s.output.representation_given);
    }
    expect_error(lines({BODY, TABLE, "[output]", "representation = \"octree\""}), 16, "output.representation",
                 "allowed: tensor, adaptive, auto");
}

TEST_CASE("[adaptive] keys are read as typed") {
    const Spec s = parse_spec_string(
        lines({BODY, TABLE, "[adaptive]", "accuracy = 2e-3", "measure = \"absolute\"", "max_values = 5000",
               "patch_nodes = 5", "patch_order = 2", "breakpoints = { eta = [1.5, 1.7] }", "jumps = { eta = 1.9 }",
               "initial_level = { mu_i = 2 }"}),
        "spec.toml");
    const AdaptiveSpecSettings& a = s.adaptive;
    CHECK(a.accuracy == 2e-3);
    CHECK(a.absolute == true);
    CHECK(a.max_values == std::size_t(5000));
    CHECK(a.patch_nodes == std::size_t(5));
    CHECK(a.patch_order == 2);
    REQUIRE(a.breakpoints.size() == 2);
    CHECK(a.breakpoints[0] == std::pair<std::string, double>("eta", 1.5));
    CHECK(a.breakpoints[1] == std::pair<std::string, double>("eta", 1.7));
    CHECK(a.breakpoints_given);
    REQUIRE(a.jumps.size() == 1);
    CHECK(a.jumps[0].second == 1.9);
    CHECK(a.initial_level.at("mu_i") == 2);
    CHECK(!s.tables[0].adaptive.max_values);  // the table sets nothing of its own
}

TEST_CASE("[adaptive] and a table's adaptive key: bad values name the file, line, key and the allowed range") {
    expect_error(lines({BODY, TABLE, "[adaptive]", "accuracy = 0"}), 16, "adaptive.accuracy", "allowed: a finite number > 0");
    expect_error(lines({BODY, TABLE, "[adaptive]", "measure = \"rms\""}), 16, "adaptive.measure",
                 "allowed: relative, absolute");
    expect_error(lines({BODY, TABLE, "[adaptive]", "max_values = 1"}), 16, "adaptive.max_values",
                 "allowed: integer 2 .. 2147483648");
    expect_error(lines({BODY, TABLE, "[adaptive]", "patch_nodes = 4"}), 16, "adaptive.patch_nodes", "allowed: 3, 5, 9");
    expect_error(lines({BODY, TABLE, "[adaptive]", "patch_order = 3"}), 16, "adaptive.patch_order", "allowed: 1");
    expect_error(lines({BODY, TABLE, "[adaptive]", "breakpoints = { eta = [2.5] }"}), 16, "adaptive.breakpoints.eta",
                 "allowed: 1.2 < x < 2");
    expect_error(lines({BODY, TABLE, "[adaptive]", "jumps = { alpha = 0.5 }"}), 16, "adaptive.jumps.alpha",
                 "allowed: mu_i, eta");
    // The critical axis' warp follows eta: a fixed mu_i is no plane of t.
    expect_error(lines({BODY, TABLE, "[adaptive]", "breakpoints = { mu_i = -0.5 }"}), 16,
                 "adaptive.breakpoints.mu_i", "follows 'eta'");
    expect_error(lines({BODY, TABLE, "[adaptive]", "initial_level = { eta = 17 }"}), 16,
                 "adaptive.initial_level.eta", "integer 0 .. 16");
    expect_error(lines({BODY, TABLE, "[adaptive]", "patch_size = 3"}), 16, "adaptive.patch_size", "unknown key");
    // A table's own settings: the same checks; accuracy and measure are spec-wide.
    expect_error(lines({BODY, TABLE, "adaptive = { max_values = 0 }"}), 15, "tables[0].adaptive.max_values",
                 "allowed: integer 2");
    expect_error(lines({BODY, TABLE, "adaptive = { accuracy = 1e-3 }"}), 15, "tables[0].adaptive.accuracy",
                 "unknown key");
}

TEST_CASE("adaptive settings: defaults < [adaptive] < the table's < the command line") {
    const Spec s = parse_spec_string(
        lines({BODY, "[[tables]]", "name = \"t\"", "quantity = \"albedo_t\"",
               "adaptive = { max_values = 700, breakpoints = { eta = 1.6 } }", "[[tables]]", "name = \"r\"",
               "quantity = \"albedo_r\"", "[adaptive]", "max_values = 5000", "patch_order = 2",
               "breakpoints = { eta = 1.5 }", "initial_level = { eta = 1 }"}),
        "spec.toml");
    const AdaptiveSpecSettings none;
    // Table t: its own max_values and breakpoints, [adaptive]'s order and level.
    AdaptiveGenerateOptions t = adaptive_generate_options(s, 0, none, 1e-2, true, 0);
    CHECK(t.build.target == 1e-2);
    CHECK(t.build.absolute);
    CHECK(t.build.max_values == 700);
    CHECK(t.build.patch_order == 2);
    CHECK(t.build.patch_nodes == 3);  // the default
    REQUIRE(t.breakpoints.size() == 1);
    CHECK(t.breakpoints[0].axis == "eta");
    CHECK(t.breakpoints[0].x == 1.6);
    CHECK(!t.breakpoints[0].jump);
    CHECK(t.build.initial_level == std::vector<int>{0, 1});
    // Table r: [adaptive] throughout.
    AdaptiveGenerateOptions r = adaptive_generate_options(s, 1, none, 1e-2, true, 0);
    CHECK(r.build.max_values == 5000);
    REQUIRE(r.breakpoints.size() == 1);
    CHECK(r.breakpoints[0].x == 1.5);
    // The command line wins over both.
    AdaptiveSpecSettings cli;
    cli.max_values = 900;
    cli.patch_order = 1;
    cli.patch_nodes = 5;
    cli.jumps = {{"eta", 1.8}};
    cli.jumps_given = true;
    cli.initial_level["eta"] = 3;
    t = adaptive_generate_options(s, 0, cli, 1e-2, false, 0);
    CHECK(t.build.max_values == 900);
    CHECK(t.build.patch_order == 1);
    CHECK(t.build.patch_nodes == 5);
    CHECK(!t.build.absolute);
    CHECK(t.build.initial_level == std::vector<int>{0, 3});
    REQUIRE(t.breakpoints.size() == 2);  // the table's breakpoint and the command line's jump
    CHECK(t.breakpoints[1].jump);
    CHECK(t.breakpoints[1].x == 1.8);
    // Defaults without any settings.
    const Spec plain = parse_spec_string(lines({BODY, TABLE}), "spec.toml");
    const AdaptiveGenerateOptions d = adaptive_generate_options(plain, 0, none, 1e-3, false, 0);
    CHECK(d.build.max_values == kAdaptiveDefaultMaxValues);
    CHECK(d.build.patch_nodes == 3);
    CHECK(d.build.patch_order == 1);
    CHECK(d.breakpoints.empty());
}

TEST_CASE("the adaptive presets carry their settings as spec keys") {
    namespace fs = std::filesystem;
    const fs::path dir = fs::path(BT_SOURCE_DIR) / "tables";
    struct Want {
        const char* file;
        double accuracy;
    };
    for (const Want& w : {Want{"rough-dielectric-albedo-inside-adaptive.toml", 1e-3},
                          Want{"rough-dielectric-rdielprec-adaptive.toml", 1e-4}}) {
        CAPTURE(w.file);
        const Spec s = parse_spec_file((dir / w.file).string());
        CHECK(s.output.representation == "adaptive");
        CHECK(s.adaptive.accuracy == w.accuracy);
        CHECK(s.adaptive.absolute == true);
        CHECK(s.adaptive.patch_order == 2);
        CHECK(s.adaptive.max_values == std::size_t(65536));
    }
}
