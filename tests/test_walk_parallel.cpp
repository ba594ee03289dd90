// Walk-parallel launches (kernels/common/walk_parallel.h, host/engine/launch/walk_parallel.cpp):
// a random walk advanced one collision per round of a work group, with a
// batch's next sample started as soon as a walk ends, must give the very bits
// of the usual kernel, whose work item runs each walk to its end in a loop.
// The oracle is that usual kernel (walk_parallel false: one nested loop,
// no barrier, no regeneration), over lambert-sphere brdf_mc's orders,
// truncation remainder, Fourier modes, phase functions, albedos (Russian
// roulette below c^k = 0.05).  Monte Carlo only: RQMC launches run the usual
// kernel (host/engine/launch/usual.cpp).
#include <doctest/doctest.h>

#include <cmath>
#include <map>
#include <string>
#include <vector>

#include "host/engine/engine.h"
#include "host/models/registry.h"
#include "scoped_tuning.h"
#include "test_launch_support.h"
#include "test_support.h"

using namespace brdftab;

namespace {

using brdftab::test::estimate_cells;
using brdftab::test::ScopedTuning;

// The shared bit-for-bit comparison, and every value finite (no NaN or
// infinity in these tables, so == is a bitwise test).
void check_same_bits(const EstimateResult& a, const EstimateResult& b) {
    for (std::size_t c = 0; c < a.value.size(); ++c) {
        CAPTURE(c);
        CHECK(std::isfinite(a.value[c]));
    }
    brdftab::test::check_same_bits(a, b);
}

// Cells over the hemisphere (theta_i up to 85 degrees, both sides of phi_d),
// every parameter at its default, then `over`.
std::vector<std::map<std::string, double>> cells_with(const std::map<std::string, double>& over) {
    std::vector<std::map<std::string, double>> cells;
    for (int c = 0; c < 5; ++c) {
        std::map<std::string, double> v;
        v["theta_i"] = 5.0 + 20.0 * c;
        v["theta_o"] = 80.0 - 17.0 * c;
        v["phi_d"] = -170.0 + 80.0 * c;
        for (const auto& [k, x] : over) v[k] = x;
        cells.push_back(v);
    }
    return cells;
}

}  // namespace

TEST_CASE("walk-parallel launches give the usual kernel's bits on lambert-sphere brdf_mc") {
    auto device = make_backend("", Precision::Double);
    const ModelInfo& m = find_model("lambert-sphere");
    const QuantityInfo& q = m.quantity("brdf_mc");
    struct Case {
        const char* name;
        std::map<std::string, double> params;
        const char* phase;
    };
    const std::vector<Case> cases = {
        {"all orders, c = 1, max_order 1000", {{"c", 1.0}}, "exact"},
        {"all orders, c = 0.6 (Russian roulette)", {{"c", 0.6}}, "exact"},
        {"multiple scattering only", {{"c", 0.9}, {"order", -1}}, "exact"},
        {"order 3 alone", {{"c", 0.8}, {"order", 3}}, "exact"},
        {"truncation remainder", {{"c", 1.0}, {"order", -2}, {"max_order", 4}, {"tail_order", 40}},
         "exact"},
        {"Fourier mode 1", {{"c", 0.95}, {"mode", 1}}, "exact"},
        {"Fourier mode 0, short truncation", {{"c", 1.0}, {"mode", 0}, {"max_order", 7}}, "exact"},
        {"three-term phase function", {{"c", 0.7}}, "three-term"},
    };
    for (const Case& k : cases) {
        {
            const Method method = Method::MonteCarlo;
            CAPTURE(k.name);
            const auto cells = cells_with(k.params);
            const nlohmann::json options = {{"phase_mc", k.phase}};
            IntegrationSettings s;
            s.method = method;
            s.samples = 3 * 37;
            s.batch_size = 37;  // odd: groups of 64 work items span cells
            s.seed = 5;
            EstimateResult usual;
            {
                ScopedTuning off(*device, &EngineTuning::walk_parallel, false);
                usual = estimate_cells(*device, m, q, cells, s, options);
            }
            ScopedTuning on(*device, &EngineTuning::walk_parallel, true);
            check_same_bits(usual, estimate_cells(*device, m, q, cells, s, options));
            for (std::size_t c = 0; c < usual.value.size(); ++c) CHECK(usual.samples[c] == 111u);
        }
    }
}

TEST_CASE("walk-parallel: launches of a few work items, one-sample batches, adaptive runs") {
    auto device = make_backend("", Precision::Double);
    const ModelInfo& m = find_model("lambert-sphere");
    const QuantityInfo& q = m.quantity("brdf_mc");
    const auto cells = cells_with({{"c", 0.9}});
    const nlohmann::json options = nlohmann::json::object();
    std::vector<IntegrationSettings> settings(3);
    settings[0].samples = 64;
    settings[0].batch_size = 16;
    settings[0].slab_work_items = 3;  // launches of 3 work items: mostly padding
    settings[1].samples = 5;
    settings[1].batch_size = 1;
    settings[2].samples = 64;
    settings[2].batch_size = 32;
    settings[2].tolerance = 1e-2;
    settings[2].max_samples = 1 << 12;  // rounds of different batch counts per cell
    for (std::size_t k = 0; k < settings.size(); ++k) {
        CAPTURE(k);
        settings[k].method = Method::MonteCarlo;
        EstimateResult usual;
        {
            ScopedTuning off(*device, &EngineTuning::walk_parallel, false);
            usual = estimate_cells(*device, m, q, cells, settings[k], options);
        }
        ScopedTuning on(*device, &EngineTuning::walk_parallel, true);
        check_same_bits(usual, estimate_cells(*device, m, q, cells, settings[k], options));
    }
}

TEST_CASE("walk-parallel cases name existing Monte Carlo quantities") {
    // A typo in the engine's table would silently turn the launch off.  Every
    // case must be a quantity that Monte Carlo integrates.
    REQUIRE_FALSE(walk_parallel_cases().empty());
    for (const WalkParallelCase& c : walk_parallel_cases()) {
        CAPTURE(c.model);
        CAPTURE(c.quantity);
        const ModelInfo& m = find_model(c.model);       // throws on an unknown model
        const QuantityInfo& q = m.quantity(c.quantity);  // ... or quantity
        CHECK(q.kind != QuantityKind::ClosedForm);
        CHECK_FALSE(c.state.empty());
    }
}
