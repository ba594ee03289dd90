// Sample-parallel launches (kernels/common/estimator.h,
// kernels/common/sample_parallel.cl; host/engine/launch/sample_parallel.cpp): a batch's
// samples as work items of one kernel, merged by a second, must give the very
// bits of the usual kernel, whose work item loops over the samples itself.
// The oracle is that usual kernel (an independent code path: one loop,
// no scratch buffer, no sub-launches), on every Monte Carlo / RQMC quantity
// of the models whose integrals the engine runs sample-parallel.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <unistd.h>
#include <map>
#include <string>
#include <vector>

#include "host/engine/engine.h"
#include "scoped_tuning.h"
#include "test_launch_support.h"
#include "test_support.h"
#include "host/models/registry.h"

using namespace brdftab;

namespace {

using brdftab::test::check_same_bits;
using brdftab::test::estimate_cells;
using brdftab::test::ScopedTuning;

// A few cells of a quantity: directions spread over the hemisphere, every
// parameter at its default or in the middle of its range.
std::vector<std::map<std::string, double>> test_cells(const ModelInfo& m, const QuantityInfo& q,
                                                      std::size_t count) {
    std::vector<std::map<std::string, double>> cells;
    for (std::size_t c = 0; c < count; ++c) {
        std::map<std::string, double> v;
        for (const auto& d : q.directions) {
            if (d == "theta_i") v["theta_i"] = 10.0 + 27.0 * static_cast<double>(c);
            if (d == "theta_o") v["theta_o"] = 70.0 - 19.0 * static_cast<double>(c);
            if (d == "phi_o") v["phi_d"] = -150.0 + 110.0 * static_cast<double>(c);
        }
        for (const auto& p : m.parameters)
            v[p.name] = p.default_value ? *p.default_value
                                        : 0.5 * (p.min + std::min(p.max, p.min + 2.0));
        cells.push_back(v);
    }
    return cells;
}

}  // namespace

TEST_CASE("sample-parallel launches give the usual kernel's bits on every MC/RQMC quantity") {
    auto device = make_backend("", Precision::Double);
    for (const char* model_name :
         {"rough-dielectric", "interfaced-lambertian", "micrograin", "lambert-sphere"}) {
        const ModelInfo& m = find_model(model_name);
        for (const QuantityInfo& q : m.quantities) {
            if (q.kind == QuantityKind::ClosedForm) continue;
            // Every quantity by Monte Carlo; RQMC (the other sampler, same
            // kernel structure) on rough-dielectric only, unless
            // BRDFTAB_TEST_ALL_METHODS is set: each (quantity, method) builds two
            // programs, and the full matrix took ~170 s on a cold PoCL cache.
            const bool all_methods = std::getenv("BRDFTAB_TEST_ALL_METHODS") != nullptr ||
                                     std::string(model_name) == "rough-dielectric";
            std::vector<Method> methods{Method::MonteCarlo};
            if (all_methods) methods.push_back(Method::Rqmc);
            for (Method method : methods) {
                const std::string method_name = to_string(method);
                CAPTURE(model_name);
                CAPTURE(q.name);
                CAPTURE(method_name);
                const auto cells = test_cells(m, q, 3);
                IntegrationSettings s;
                s.method = method;
                s.samples = 64;
                s.batch_size = 16;  // 4 batches per cell, 12 work items
                s.seed = 11;
                EstimateResult usual, parallel, split, over_cap;
                {
                    ScopedTuning off(*device, &EngineTuning::sample_parallel, LaunchChoice::Off);
                    usual = estimate_cells(*device, m, q, cells, s);
                }
                {
                    ScopedTuning on(*device, &EngineTuning::sample_parallel, LaunchChoice::On);
                    parallel = estimate_cells(*device, m, q, cells, s);
                    // Sub-launches of 2 work items (40 samples / 16): 6 of them.
                    ScopedTuning cap(*device, &EngineTuning::sample_parallel_scratch_samples, 40);
                    split = estimate_cells(*device, m, q, cells, s);
                }
                check_same_bits(usual, parallel);
                check_same_bits(usual, split);
                for (std::size_t c = 0; c < usual.value.size(); ++c)
                    CHECK(usual.samples[c] == 64u);
            }
        }
    }
}

TEST_CASE("fixed-step searches: every unfinished sample is redone, the bits are the usual kernel's") {
    // interfaced-lambertian's body with Beckmann visible normals runs its
    // sample-parallel kernels with microfacet.h's fixed-step search
    // (BT_MF_SOLVE_STEPS) and a redo kernel for the samples whose search had
    // not ended.  With one step each (fixed_solver_steps_x/y = 1) nearly
    // every sample takes the redo; with the defaults (4, 3) a few do.  Both
    // must give the bits of the usual kernel, which always runs the loop.
    // vcavity runs the same search as the first of its two stages
    // (QuantityInfo::staged; a stage redo kernel): the same checks, at all
    // orders and at order 3, in both interreflection modes.
    auto device = make_backend("", Precision::Double);
    const ModelInfo& m = find_model("interfaced-lambertian");
    struct Case {
        const char* quantity;
        const char* distribution;
        const char* interreflection;
        double order;
    };
    for (const Case& c : {Case{"body", "beckmann-smith", "full", 0}, Case{"body", "beckmann-ts", "full", 0},
                          Case{"vcavity", "beckmann-smith", "full", 0},
                          Case{"vcavity", "beckmann-ts", "body", 3}}) {
        const QuantityInfo& q = m.quantity(c.quantity);
        const char* distribution = c.distribution;
        for (Method method : {Method::MonteCarlo, Method::Rqmc}) {
            const std::string method_name = to_string(method);
            CAPTURE(c.quantity);
            CAPTURE(distribution);
            CAPTURE(method_name);
            auto cells = test_cells(m, q, 4);
            if (std::string(c.quantity) == "vcavity")
                for (auto& cell : cells) cell["order"] = c.order;
            IntegrationSettings s;
            s.method = method;
            s.samples = 256;
            s.batch_size = 64;
            s.seed = 5;
            nlohmann::json given = {{"distribution", distribution}, {"sampling", "visible"}};
            if (std::string(c.quantity) == "vcavity") given["interreflection"] = c.interreflection;
            EstimateResult usual;
            {
                ScopedTuning off(*device, &EngineTuning::sample_parallel, LaunchChoice::Off);
                usual = estimate_cells(*device, m, q, cells, s, given);
            }
            ScopedTuning on(*device, &EngineTuning::sample_parallel, LaunchChoice::On);
            // (x, y) steps; 0, 0: microfacet.h's defaults.
            for (const std::pair<int, int> steps : {std::pair{1, 1}, std::pair{2, 1}, std::pair{0, 0}}) {
                const int x = steps.first, y = steps.second;
                CAPTURE(x);
                CAPTURE(y);
                ScopedTuning steps_x(*device, &EngineTuning::fixed_solver_steps_x, x);
                ScopedTuning steps_y(*device, &EngineTuning::fixed_solver_steps_y, y);
                check_same_bits(usual, estimate_cells(*device, m, q, cells, s, given));
            }
        }
    }
}

TEST_CASE("staged samples in float (no fixed-step build): the usual float kernel's bits") {
    // vcavity's stage and rest kernels from the usual float build (the
    // fixed-step search is a double-only build), forced on: every value and
    // error estimate must be the usual float kernel's.
    auto device = make_backend("", Precision::Float);
    const ModelInfo& m = find_model("interfaced-lambertian");
    const QuantityInfo& q = m.quantity("vcavity");
    REQUIRE(q.staged.enabled());
    for (Method method : {Method::MonteCarlo, Method::Rqmc}) {
        const std::string method_name = to_string(method);
        CAPTURE(method_name);
        IntegrationSettings s;
        s.method = method;
        s.samples = 128;
        s.batch_size = 32;
        s.seed = 3;
        const auto cells = test_cells(m, q, 4);
        EstimateResult usual;
        {
            ScopedTuning off(*device, &EngineTuning::sample_parallel, LaunchChoice::Off);
            usual = estimate_cells(*device, m, q, cells, s);
        }
        ScopedTuning on(*device, &EngineTuning::sample_parallel, LaunchChoice::On);
        check_same_bits(usual, estimate_cells(*device, m, q, cells, s));
    }
}

TEST_CASE("fixed-step searches: without the redo kernel, unfinished samples show (the test bites)") {
    // The same kernels from a copy of kernels/ whose redo kernel does
    // nothing: with one step per search many samples are unfinished (NaN),
    // and so are the values of the cells that hold one.  Shows that the launches above do take
    // the fixed-step path and that the redo kernel is what repairs it.
    namespace fs = std::filesystem;
    const fs::path dir = fs::temp_directory_path() / ("bt_test_redo_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::copy(fs::path(BT_SOURCE_DIR) / "kernels", dir, fs::copy_options::recursive);
    {
        const fs::path kernels = dir / "common" / "sample_parallel.cl";
        std::ifstream in(kernels);
        std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
        const std::string guard = "if (scratch[gid] == scratch[gid]) return;";
        const auto at = text.find(guard);
        REQUIRE(at != std::string::npos);
        text.replace(at, guard.size(), "return;");
        std::ofstream(kernels) << text;
    }
    auto device = make_backend("", Precision::Double, dir.string());
    const ModelInfo& m = find_model("interfaced-lambertian");
    const QuantityInfo& q = m.quantity("body");
    IntegrationSettings s;
    s.method = Method::MonteCarlo;
    s.samples = 256;
    s.batch_size = 64;
    ScopedTuning on(*device, &EngineTuning::sample_parallel, LaunchChoice::On);
    ScopedTuning steps_x(*device, &EngineTuning::fixed_solver_steps_x, 1);
    ScopedTuning steps_y(*device, &EngineTuning::fixed_solver_steps_y, 1);
    const EstimateResult r = estimate_cells(*device, m, q, test_cells(m, q, 4), s);
    std::size_t nan_cells = 0;
    for (double v : r.value) nan_cells += std::isnan(v) ? 1 : 0;
    CHECK(nan_cells > 0);  // 3 of the 4 cells, measured
    fs::remove_all(dir);
}

TEST_CASE("sample-parallel: splits, odd batch sizes, caps below a batch and adaptive runs") {
    // rough-dielectric albedo_r: MC batches of 37 samples (a group of 64
    // work items spans two cells), many sub-launch sizes, and a cap below one
    // batch (the usual kernel runs then).
    auto device = make_backend("", Precision::Double);
    const ModelInfo& m = find_model("rough-dielectric");
    const QuantityInfo& q = m.quantity("albedo_r");
    const auto cells = test_cells(m, q, 3);
    IntegrationSettings s;
    s.method = Method::MonteCarlo;
    s.samples = 37 * 5;
    s.batch_size = 37;
    s.slab_work_items = 7;  // launches of 7 work items, the last one shorter
    EstimateResult usual;
    {
        ScopedTuning off(*device, &EngineTuning::sample_parallel, LaunchChoice::Off);
        usual = estimate_cells(*device, m, q, cells, s);
    }
    ScopedTuning on(*device, &EngineTuning::sample_parallel, LaunchChoice::On);
    for (const std::size_t cap : {36, 37, 74, 100, 259, 4194304}) {
        CAPTURE(cap);
        ScopedTuning scratch(*device, &EngineTuning::sample_parallel_scratch_samples, cap);
        check_same_bits(usual, estimate_cells(*device, m, q, cells, s));
    }
    // Adaptive RQMC: rounds of different batch counts per cell.
    IntegrationSettings a;
    a.method = Method::Rqmc;
    a.samples = 256;
    a.tolerance = 1e-3;
    a.max_samples = 1 << 14;
    EstimateResult adaptive_usual;
    {
        ScopedTuning off(*device, &EngineTuning::sample_parallel, LaunchChoice::Off);
        adaptive_usual = estimate_cells(*device, m, q, cells, a);
    }
    check_same_bits(adaptive_usual, estimate_cells(*device, m, q, cells, a));
}

TEST_CASE("sample-parallel defaults name existing Monte Carlo / RQMC quantities and options") {
    // A typo in the engine's table would silently turn a default off; a
    // closed form or quadrature method would never run sample-parallel.
    REQUIRE_FALSE(sample_parallel_default_cases().empty());
    for (const SampleParallelCase& c : sample_parallel_default_cases()) {
        CAPTURE(c.model);
        CAPTURE(c.quantity);
        const ModelInfo& m = find_model(c.model);       // throws on an unknown model
        const QuantityInfo& q = m.quantity(c.quantity);  // ... or quantity
        CHECK(q.kind != QuantityKind::ClosedForm);
        CHECK((c.method == Method::MonteCarlo || c.method == Method::Rqmc));
        nlohmann::json given = nlohmann::json::object();
        for (const auto& [name, choice] : c.options) {
            const OptionInfo* o = m.find_option(name);
            REQUIRE(o != nullptr);
            CHECK(o->index_of(choice) >= 0);
            given[name] = choice;
        }
        const std::vector<int> options = resolve_options(m, given, "test");
        CHECK(sample_parallel_by_default(m, q, c.method, options));
        // The other method is on only where the table lists it too.
        const Method other = c.method == Method::MonteCarlo ? Method::Rqmc : Method::MonteCarlo;
        bool other_listed = false;
        for (const SampleParallelCase& d : sample_parallel_default_cases())
            other_listed |= d.model == c.model && d.quantity == c.quantity && d.method == other &&
                            d.options == c.options;
        CHECK(sample_parallel_by_default(m, q, other, options) == other_listed);
    }
    // Measured slower, so not by default (docs/benchmarks.md).
    const ModelInfo& rd = find_model("rough-dielectric");
    CHECK_FALSE(sample_parallel_by_default(rd, rd.quantity("albedo_r"), Method::MonteCarlo,
                                           resolve_options(rd, {{"distribution", "beckmann"}}, "")));
    CHECK_FALSE(sample_parallel_by_default(rd, rd.quantity("albedo_r"), Method::Rqmc,
                                           resolve_options(rd, {{"distribution", "beckmann"}}, "")));
    // RQMC by default where its sampler vectorises across work items (GGX).
    CHECK(sample_parallel_by_default(rd, rd.quantity("albedo_t"), Method::Rqmc,
                                     resolve_options(rd, {{"distribution", "ggx"}}, "")));
    // interfaced-lambertian's body: its defaults (Beckmann-Smith, visible
    // normals) and GGX-Smith, not the other pairs (measured slower).
    const ModelInfo& il = find_model("interfaced-lambertian");
    const QuantityInfo& body = il.quantity("body");
    CHECK(sample_parallel_by_default(il, body, Method::Rqmc,
                                     resolve_options(il, nlohmann::json::object(), "")));
    CHECK_FALSE(sample_parallel_by_default(il, body, Method::Rqmc,
                                           resolve_options(il, {{"sampling", "distribution"}}, "")));
    CHECK(sample_parallel_by_default(il, body, Method::MonteCarlo,
                                     resolve_options(il, {{"distribution", "ggx-smith"}, {"sampling", "distribution"}}, "")));
    for (const char* other : {"beckmann-ts", "gaussian-ts"})
        CHECK_FALSE(sample_parallel_by_default(il, body, Method::MonteCarlo,
                                               resolve_options(il, {{"distribution", other}}, "")));
    // vcavity, staged: Beckmann-Smith and Beckmann-TS with visible normals (the
    // fixed-step search), not GGX-Smith (staged measured slower).
    const QuantityInfo& vcavity = il.quantity("vcavity");
    for (const char* beckmann : {"beckmann-smith", "beckmann-ts"})
        for (Method method : {Method::MonteCarlo, Method::Rqmc})
            CHECK(sample_parallel_by_default(il, vcavity, method,
                                             resolve_options(il, {{"distribution", beckmann}}, "")));
    CHECK_FALSE(sample_parallel_by_default(il, vcavity, Method::Rqmc,
                                           resolve_options(il, {{"distribution", "ggx-smith"}}, "")));
    CHECK_FALSE(sample_parallel_by_default(il, vcavity, Method::Rqmc,
                                           resolve_options(il, {{"sampling", "distribution"}}, "")));
    const ModelInfo& mg = find_model("micrograin");
    CHECK_FALSE(sample_parallel_by_default(mg, mg.quantity("brdf"), Method::Rqmc,
                                           resolve_options(mg, nlohmann::json::object(), "")));
}
