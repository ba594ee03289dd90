// test_plan_adaptive.cpp — the planner's adaptive prediction and the choice
// of representation (host/plan/adaptive_plan.h), and the warning for plans
// above 10^8 cells.
//
// Oracles: pilot runs made from an exact power law values = c E^-p (the fit
// must return p and the law's value at E), budgets and plans built by hand
// (the expected choice follows from the counts), and candidate plans whose
// cells and largest axis are known by construction.
#include <doctest/doctest.h>

#include <cmath>
#include <string>

#include "host/plan/adaptive_plan.h"
#include "host/plan/certify.h"

using namespace brdftab;

namespace {

AdaptivePilotRun run(double target, std::size_t values, double seconds, bool budget = false) {
    AdaptivePilotRun r;
    r.target = target;
    r.values = values;
    r.evaluations = 4 * values;
    r.seconds = seconds;
    r.budget_hit = budget;
    return r;
}

Candidate plan_of(std::vector<std::vector<std::size_t>> counts) {
    Candidate c;
    for (std::size_t i = 0; i < counts.size(); ++i) {
        TablePlan t;
        t.table = "t" + std::to_string(i);
        t.counts = counts[i];
        c.tables.push_back(t);
    }
    return c;
}

}  // namespace

TEST_CASE("extrapolate_adaptive: an exact power law is fitted and extrapolated exactly") {
    // values = 10 E^-1.5 at E = 0.16, 0.08, 0.04: 156.25, 441.9, 1250.
    const double p = 1.5, c = 10;
    std::vector<AdaptivePilotRun> runs;
    for (double e : {0.16, 0.08, 0.04})
        runs.push_back(run(e, std::size_t(std::llround(c * std::pow(e, -p))), 0.001 * c * std::pow(e, -p)));
    const AdaptiveTablePrediction t = extrapolate_adaptive("a", runs, 0.01, 100000);
    CHECK(t.exponent == doctest::Approx(1.5).epsilon(2e-3));  // rounding of the values to integers
    CHECK(t.values == doctest::Approx(c * std::pow(0.01, -p)).epsilon(3e-3));  // 10000
    CHECK(t.evaluations == doctest::Approx(4 * t.values).epsilon(1e-9));
    CHECK(t.seconds == doctest::Approx(0.001 * c * std::pow(0.01, -p)).epsilon(3e-3));
    CHECK(t.within_budget);
    // The same runs against a budget below the prediction.
    CHECK(!extrapolate_adaptive("a", runs, 0.01, 9000).within_budget);
}

TEST_CASE("extrapolate_adaptive: one run, equal values, a pilot at its budget") {
    // One run: no slope; the exponent is the lower bound (0: the run's values).
    const AdaptiveTablePrediction one = extrapolate_adaptive("a", {run(0.04, 300, 1)}, 0.01, 65536);
    CHECK(one.exponent == 0);
    CHECK(one.values == 300);
    // An exact function: the values do not grow.
    const AdaptiveTablePrediction flat = extrapolate_adaptive("a", {run(0.16, 15, 1), run(0.08, 15, 1)}, 0.01, 65536);
    CHECK(flat.exponent == doctest::Approx(0).epsilon(1e-12).scale(1));
    CHECK(flat.values == doctest::Approx(15).epsilon(1e-12));
    // A pilot that stopped at its budget: the table at E cannot fit.
    const AdaptiveTablePrediction full =
        extrapolate_adaptive("a", {run(0.16, 100, 1), run(0.08, 1000, 1, true)}, 0.01, 1000);
    CHECK(!full.within_budget);
}

TEST_CASE("choose_representation: the plan that meets the target with fewer values") {
    AdaptivePlan a;
    a.meets = true;
    a.values = 500;
    const std::optional<Candidate> tensor = plan_of({{36, 8, 6}});  // 1728 cells
    RepresentationChoice c = choose_representation(tensor, &a);
    CHECK(c.any);
    CHECK(c.adaptive);
    CHECK(c.why.find("1728 tensor cells") != std::string::npos);
    a.values = 2000;
    c = choose_representation(tensor, &a);
    CHECK(c.any);
    CHECK(!c.adaptive);
    a.values = 1728;  // a tie: tensor
    CHECK(!choose_representation(tensor, &a).adaptive);
    // An adaptive plan that does not meet the target loses whatever its size.
    a.values = 10;
    a.meets = false;
    a.why = "over budget";
    c = choose_representation(tensor, &a);
    CHECK(!c.adaptive);
    CHECK(c.why.find("over budget") != std::string::npos);
    // No tensor plan: adaptive when it meets the target, none otherwise.
    CHECK(!choose_representation(std::nullopt, &a).any);
    a.meets = true;
    c = choose_representation(std::nullopt, &a);
    CHECK(c.any);
    CHECK(c.adaptive);
    CHECK(choose_representation(tensor, nullptr).any);
    CHECK(!choose_representation(tensor, nullptr).adaptive);
}

TEST_CASE("large_plan_warning: above 10^8 cells it names the table and its axis with the most nodes") {
    TablePilot p;
    for (const char* n : {"theta_i", "theta_o", "phi_d"}) {
        Axis a;
        a.name = n;
        p.axes.push_back(a);
    }
    // 376 x 416 x 2072 = 324 087 808 cells; phi_d needs the most nodes.
    const Candidate big = plan_of({{376, 416, 2072}});
    const std::string w = large_plan_warning(big, {p});
    CAPTURE(w);
    CHECK(w.find("3.24e+08 cells") != std::string::npos);
    CHECK(w.find("axis 'phi_d'") != std::string::npos);
    CHECK(w.find("2072") != std::string::npos);
    CHECK(w.find("--representation adaptive") != std::string::npos);
    // Exactly 10^8 cells is not above the limit; one more node is.
    CHECK(large_plan_warning(plan_of({{10000, 10000}}), {}).empty());
    CHECK(!large_plan_warning(plan_of({{10000, 10001}}), {}).empty());
    // Several tables: the one holding the most cells.
    const std::string two = large_plan_warning(plan_of({{100, 100}, {5000, 30000}}), {});
    CHECK(two.find("table 't1'") != std::string::npos);
    CHECK(two.find("'#1'") != std::string::npos);  // unnamed axes: their index
}

TEST_CASE("large_plan_warning of a spec: its tables at their own counts (a scene's sets)") {
    auto spec = [](int phi_count) {
        return parse_spec_string(
            "model = \"rough-dielectric\"\n[parameters]\nalpha = 0.3\neta = 1.5\n"
            "[[axes]]\nname = \"theta_i\"\nrange = [0, 80]\ncount = 1000\n"
            "[[axes]]\nname = \"theta_o\"\nrange = [0, 80]\ncount = 1000\n"
            "[[axes]]\nname = \"phi_d\"\nrange = [0, 180]\ncount = " + std::to_string(phi_count) + "\n"
            "[[tables]]\nname = \"r\"\nquantity = \"brdf\"\n",
            "spec.toml");
    };
    CHECK(large_plan_warning(spec(100)).empty());  // exactly 10^8 cells
    const std::string w = large_plan_warning(spec(1500));
    CAPTURE(w);
    CHECK(w.find("1.5e+09 cells") != std::string::npos);
    CHECK(w.find("table 'r'") != std::string::npos);
    CHECK(w.find("axis 'phi_d'") != std::string::npos);
}
