// test_plan_cost.cpp — the planner's cost-model terms (host/plan/plan.h,
// "cost model terms"): the engine's work layout and launch sizes, checked
// against the engine itself (a backend that records what it is asked to run),
// the large-grid and HDF5 write terms of the predicted time.  No test reads a
// clock: every expected number is worked out from the inputs.
#include <doctest/doctest.h>

#include <cmath>
#include <map>
#include <string>
#include <vector>

#include "host/engine/engine.h"
#include "host/engine/evaluate.h"
#include "host/models/registry.h"
#include "host/plan/certify.h"
#include "host/plan/plan.h"

using namespace brdftab;

namespace {

// Runs nothing: records each launch's work items and samples per item, and
// returns zeros, so the engine's slab grows as fast as it can (4x a launch).
class RecordingBackend : public Backend {
public:
    std::vector<std::size_t> sizes;
    std::vector<std::uint32_t> batch_sizes;
    std::string device_name() const override { return "recording"; }
    Precision precision() const override { return Precision::Double; }
    std::size_t preferred_slab() const override { return 1u << 17; }
    void run(const BatchLaunch& l, std::vector<double>& mean, std::vector<double>& m2) override {
        sizes.push_back(l.cells.size());
        batch_sizes.push_back(l.batch_size);
        mean.assign(l.cells.size(), 0.0);
        m2.assign(l.cells.size(), 0.0);
    }
};

// `cells` copies of one valid kernel point of rough-dielectric's `quantity`.
std::vector<double> repeated_points(const std::string& quantity, std::size_t cells) {
    const ModelInfo& model = find_model("rough-dielectric");
    const QuantityInfo& q = model.quantity(quantity);
    std::map<std::string, double> point = {{"theta_i", 30.0}, {"alpha", 0.3}, {"eta", 1.5}};
    if (quantity == "brdf") point["theta_o"] = 40.0, point["phi_d"] = 0.0;
    const std::vector<double> one =
        build_kernel_points(model, q, {point}, [](std::size_t) { return std::string("point"); });
    std::vector<double> out;
    for (std::size_t c = 0; c < cells; ++c) out.insert(out.end(), one.begin(), one.end());
    return out;
}

struct Recorded {
    std::vector<std::size_t> sizes;
    std::uint32_t batch_size = 0;
    std::size_t items = 0;
};

Recorded record(const std::string& quantity, Method method, std::uint64_t samples, std::size_t cells) {
    const ModelInfo& model = find_model("rough-dielectric");
    const QuantityInfo& q = model.quantity(quantity);
    RecordingBackend b;
    IntegrationSettings s;
    s.method = method;
    s.samples = samples;
    (void)estimate_at(b, model, q, resolve_options(model, {{"distribution", "ggx"}}, "test"),
                      repeated_points(quantity, cells), s);
    Recorded r;
    r.sizes = b.sizes;
    r.batch_size = b.batch_sizes.empty() ? 0 : b.batch_sizes.front();
    for (std::size_t n : b.sizes) r.items += n;
    return r;
}

}  // namespace

TEST_CASE("work shape: the engine's work items per cell and samples per item") {
    struct Case {
        const char* quantity;
        Method method;
        std::uint64_t samples;
    };
    // MC batches of min(N, 4096); RQMC of floor_pow2(N / 8) in [1, 8192], at
    // least 4; quadrature two one-sample items; closed form one.
    for (const Case& c : {Case{"brdf", Method::ClosedForm, 0}, Case{"albedo_t", Method::Quadrature, 0},
                          Case{"albedo_t", Method::Rqmc, 2}, Case{"albedo_t", Method::Rqmc, 16384},
                          Case{"albedo_t", Method::Rqmc, 100000}, Case{"albedo_t", Method::MonteCarlo, 10000},
                          Case{"albedo_t", Method::MonteCarlo, 1024}}) {
        CAPTURE(c.quantity);
        CAPTURE(c.samples);
        const std::size_t cells = 37;
        const Recorded r = record(c.quantity, c.method, c.samples, cells);
        const WorkShape w = work_shape(c.method, c.samples);
        CHECK(double(r.items) == doctest::Approx(double(cells) * w.items_per_cell));
        CHECK(double(r.batch_size) == w.samples_per_item);
    }
    // Worked by hand: RQMC at 2 samples is 4 one-sample items (micrograin-
    // brdf-conductor), at 100000 samples 13 items of 8192.
    CHECK(work_shape(Method::Rqmc, 2).items_per_cell == 4);
    CHECK(work_shape(Method::Rqmc, 2).samples_per_item == 1);
    CHECK(work_shape(Method::Rqmc, 100000).items_per_cell == 13);
    CHECK(work_shape(Method::MonteCarlo, 10000).items_per_cell == 3);
}

TEST_CASE("launch sizes: as the engine grows its slabs") {
    // Free work items: the slab grows 4x a launch up to the preferred 131072.
    for (std::size_t cells : {100u, 300u, 21760u, 87296u, 200000u, 300000u}) {
        CAPTURE(cells);
        const Recorded r = record("brdf", Method::ClosedForm, 0, cells);
        const EngineLaunches l = engine_launch_sizes(double(cells), 0.0, 0.0, 1u << 17);
        CHECK(l.first == r.sizes);
        CHECK(l.count == double(r.sizes.size()));
    }
    // RQMC at 2 samples, 28160 cells (the micrograin preset shrunk by
    // plan-check): 112640 items, of which a launch of 65536.
    const Recorded mg = record("albedo_t", Method::Rqmc, 2, 28160);
    CHECK(mg.sizes == std::vector<std::size_t>{256, 1024, 4096, 16384, 65536, 25344});
    CHECK(engine_launch_sizes(112640, 0.0, 0.0, 1u << 17).first == mg.sizes);

    // Items of 10 us: launches aim at 0.5 s = 50000 items, floor to a multiple
    // of 256 = 49920, after 256, 1024, 4096, 16384 (each at most 4x the last).
    const EngineLaunches slow = engine_launch_sizes(1e6, 1e-5, 0.0, 1u << 17);
    REQUIRE(slow.first.size() >= 6);
    CHECK(std::vector<std::size_t>(slow.first.begin(), slow.first.begin() + 6) ==
          std::vector<std::size_t>{256, 1024, 4096, 16384, 49920, 49920});
    CHECK(slow.largest == 49920);
    // 1e6 - 21760 = 978240 = 19 x 49920 + 29760: 4 + 19 + 1 launches.
    CHECK(slow.count == 24);
    // Items of 1 ms: 256 stays (0.5 s / 1 ms = 500 rounds down to 256).
    const EngineLaunches slower = engine_launch_sizes(1e5, 1e-3, 0.0, 1u << 17);
    CHECK(slower.largest == 256);
    CHECK(slower.count == std::ceil(1e5 / 256));
    // 2^32 - 1 cells predicted without simulating 32768 launches one by one.
    const EngineLaunches huge = engine_launch_sizes(4294967295.0, 0.0, 0.0, 1u << 17);
    CHECK(huge.first.size() == 32);
    CHECK(huge.count == 5 + std::ceil((4294967295.0 - 87296) / 131072));
}

TEST_CASE("large grid: PoCL's second kernel variant from 65536 work items (groups of 64)") {
    EngineLaunches l;
    l.largest = 65472;  // 1023 groups: measured small-grid
    CHECK_FALSE(reaches_large_grid(l));
    l.largest = 65473;  // rounded up to 1024 groups
    CHECK(reaches_large_grid(l));
    CHECK(reaches_large_grid(engine_launch_sizes(112640, 0.0, 0.0, 1u << 17)));
    CHECK_FALSE(reaches_large_grid(engine_launch_sizes(21760 + 65472, 0.0, 0.0, 1u << 17)));
    CHECK_FALSE(reaches_large_grid(engine_launch_sizes(1e6, 1e-5, 0.0, 1u << 17)));
}

TEST_CASE("engine seconds: per-item overhead and the large-grid load, worked by hand") {
    TablePilot p;
    p.startup_seconds = 0.1, p.overhead_seconds = 0.002;
    IntegrationFit f;
    f.method = Method::Rqmc;
    f.seconds_per_sample = 1e-6;
    f.item_overhead_seconds = 2e-6;
    f.large_grid_load_seconds = 0.3;
    // 28160 cells x 2 samples: 112640 one-sample items of 3 us = 0.338 s,
    // launches 256 ... 65536: the large grid's load too.
    CHECK(engine_seconds(p, f, 28160, 2) == doctest::Approx(0.1 + 0.002 + 112640 * 3e-6 + 0.3));
    // 100 cells: 400 items, launches 256 and 144: no large grid.
    CHECK(engine_seconds(p, f, 100, 2) == doctest::Approx(0.1 + 0.002 + 400 * 3e-6));
    // 16384 samples: 8 items of 2048 samples each, the overhead per item.
    CHECK(engine_seconds(p, f, 10, 16384) == doctest::Approx(0.1 + 0.002 + 80 * (2e-6 + 2048e-6)));
    // Not measured (0): nothing added.
    f.large_grid_load_seconds = 0;
    CHECK(engine_seconds(p, f, 28160, 2) == doctest::Approx(0.1 + 0.002 + 112640 * 3e-6));
    // Closed form: the measured cost per cell, one item per cell.
    IntegrationFit c;
    c.method = Method::ClosedForm;
    c.seconds_per_cell = 4e-7;
    c.large_grid_load_seconds = 0.2;
    CHECK(engine_seconds(p, c, 1e6, 0) == doctest::Approx(0.1 + 0.002 + 1e6 * 4e-7 + 0.2));
    CHECK(engine_seconds(p, c, 1000, 0) == doctest::Approx(0.1 + 0.002 + 1000 * 4e-7));
}

TEST_CASE("write seconds: linear in the cells, per dataset written") {
    for (StoredType t : {StoredType::Float16, StoredType::Float32, StoredType::Float64})
        for (int compression : {0, 6}) {
            CAPTURE(int(t));
            CAPTURE(compression);
            const double one = write_seconds(1e5, t, compression, false, false);
            CHECK(one > 0);
            CHECK(write_seconds(0, t, compression, false, false) == 0);
            CHECK(write_seconds(3e5, t, compression, false, false) == doctest::Approx(3 * one));
            // stderr: a second dataset of the same type.
            CHECK(write_seconds(1e5, t, compression, true, false) == doctest::Approx(2 * one));
            CHECK(write_seconds(1e5, t, compression, true, true) > 2 * one);
        }
    // Deflate costs more than storing raw, and more the wider the type.
    CHECK(write_seconds(1e5, StoredType::Float32, 6, false, false) >
          write_seconds(1e5, StoredType::Float32, 0, false, false));
    CHECK(write_seconds(1e5, StoredType::Float64, 6, false, false) >
          write_seconds(1e5, StoredType::Float16, 6, false, false));
}

TEST_CASE("predicted table time: engine run plus the write generate makes") {
    TablePilot p;
    p.kind = QuantityKind::ClosedForm;
    p.axes.resize(1);
    AxisFit a;  // exact interpolation: only the time matters here
    a.axis = "x";
    a.levels.resize(1);
    p.linear = p.cubic = {a};
    IntegrationFit f;
    f.method = Method::ClosedForm;
    f.seconds_per_cell = 1e-6;
    p.integration = {f};
    PlanTarget t;
    const TablePlan tp = predict_table(p, t, {1000}, Method::ClosedForm, 0, StoredType::Float16);
    // A closed form stores no stderr and no samples (generate.cpp).
    CHECK(tp.seconds == doctest::Approx(1000 * 1e-6 + write_seconds(1000, StoredType::Float16, 6, false, false)));
    // The same table twice the size: twice the work and twice the write.
    const TablePlan t2 = predict_table(p, t, {2000}, Method::ClosedForm, 0, StoredType::Float16);
    CHECK(t2.seconds == doctest::Approx(2 * tp.seconds));
    // keep_stderr = false and compression 0 ([output]) as the pilot took them.
    p.kind = QuantityKind::Integral;
    IntegrationFit mc;
    mc.method = Method::MonteCarlo;
    mc.samples = {1024};
    mc.seconds_per_sample = 1e-8;
    mc.cell_abs = mc.cell_rel = {1e-3};
    mc.max_abs = mc.max_rel = mc.rms_abs = mc.rms_rel = {1e-3};
    p.integration = {mc};
    p.keep_stderr = false;
    p.compression = 0;
    const TablePlan ti = predict_table(p, t, {1000}, Method::MonteCarlo, 1024, StoredType::Float32);
    CHECK(ti.seconds == doctest::Approx(1000 * 1024 * 1e-8 + write_seconds(1000, StoredType::Float32, 0, false, true)));
}

TEST_CASE("shared kernels: one process loads each kernel program once") {
    auto plan = [](const std::string& kernel, double load, double large) {
        TablePlan t;
        t.kernel = kernel;
        t.kernel_load_seconds = load;
        t.large_grid_load_seconds = large;
        return t;
    };
    // Three tables of one program (micrograin's three beta tables: beta is a
    // parameter, not an option) and one of another: the first three load once,
    // at the costliest of their measured loads.
    const std::vector<TablePlan> tables = {plan("a", 0.10, 0.3), plan("a", 0.20, 0.0), plan("a", 0.15, 0.4),
                                           plan("b", 0.50, 0.2), plan("", 0.7, 0.7)};
    CHECK(shared_kernel_saving(tables) == doctest::Approx((0.45 - 0.20) + (0.7 - 0.4)));
    CHECK(shared_kernel_saving({plan("a", 0.1, 0.3), plan("b", 0.1, 0.3)}) == 0);
    CHECK(shared_kernel_saving({}) == 0);
}

// The cost guard of `generate --accuracy` (excessive_plan_cost): counts and
// times are inputs, so every expected verdict is arithmetic.
TEST_CASE("a plan beyond 10 minutes, or 100x the spec's cells and 10^6 cells, is excessive") {
    Spec spec;
    TableSpec t;
    t.axes = {make_axis("x", "1", 0, 1, 10, Spacing::Linear), make_axis("y", "1", 0, 1, 10, Spacing::Linear)};
    spec.tables = {t};  // 100 cells
    auto plan = [](std::size_t nx, std::size_t ny, double seconds) {
        Candidate c;
        TablePlan tp;
        tp.counts = {nx, ny};
        c.tables = {tp};
        c.seconds = seconds;
        return c;
    };
    CHECK(plan_cells(plan(30, 40, 1)) == 1200);
    CHECK(spec_table_cells(spec) == 100);
    CHECK(excessive_plan_cost(plan(10, 10, 600), spec).empty());          // at the limit
    CHECK(excessive_plan_cost(plan(10, 10, 601), spec).find("predicted time") != std::string::npos);
    // 900 x 900 = 810000 cells: 8100x the spec, but under 10^6 cells.
    CHECK(excessive_plan_cost(plan(900, 900, 1), spec).empty());
    // 2000 x 2000 = 4e6 cells: 40000x the spec and over 10^6.
    const std::string why = excessive_plan_cost(plan(2000, 2000, 1), spec);
    CHECK(why.find("4e+06 cells, 40000x the spec's own 100") != std::string::npos);
    CHECK(why.find("predicted time") == std::string::npos);
    // A spec of 10^5 cells: 10^7 cells is exactly 100x (not above), 1.0001e7 is.
    spec.tables[0].axes = {make_axis("x", "1", 0, 1, 100, Spacing::Linear), make_axis("y", "1", 0, 1, 1000, Spacing::Linear)};
    CHECK(excessive_plan_cost(plan(10000, 1000, 1), spec).empty());
    CHECK(!excessive_plan_cost(plan(10001, 1000, 1), spec).empty());
}
