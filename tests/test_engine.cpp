// Integration engine: OpenCL device vs host reference, float vs double,
// determinism across slab sizes, adaptive tolerance, and honesty of the
// reported standard errors.
#include <doctest/doctest.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <random>

#include "host/engine/engine.h"
#include "kernels/common/sampler.h"
#include "host/core/error.h"
#include "host/models/registry.h"
#include "test_support.h"

using namespace brdftab;

namespace {

using brdftab::test::fresnel_sp;
using brdftab::test::kPi;

struct Fixture {
    const ModelInfo& model = find_model("rough-dielectric");
    std::vector<int> options(const std::string& distribution = "ggx") const {
        return resolve_options(model, {{"distribution", distribution}}, "test");
    }
    // A spread of cells: (theta_i, theta_o, phi_d, alpha, eta) from a fixed RNG.
    std::vector<std::map<std::string, double>> random_points(std::size_t n, bool transmission) {
        std::mt19937 rng(7);
        std::uniform_real_distribution<double> u(0, 1);
        std::vector<std::map<std::string, double>> pts;
        for (std::size_t k = 0; k < n; ++k) {
            const double theta_o = transmission ? 90 + 89.5 * u(rng) : 89.5 * u(rng);
            pts.push_back({{"theta_i", 89.5 * u(rng)},
                           {"theta_o", theta_o},
                           {"phi_d", 360 * u(rng) - 180},
                           {"alpha", 0.02 + 0.8 * u(rng)},
                           {"eta", 1.05 + u(rng)}});
        }
        return pts;
    }
    EstimateResult run(Backend& b, const std::string& quantity,
                       const std::vector<std::map<std::string, double>>& pts,
                       const IntegrationSettings& s, const std::string& dist = "ggx") {
        const QuantityInfo& q = model.quantity(quantity);
        PointBuilder builder(model, q);
        return estimate(
            b, model, q, options(dist), pts.size(),
            [&](std::size_t c, double* out) { builder.build(pts[c], out); }, s);
    }
};

std::unique_ptr<Backend> device(Precision p = Precision::Double) {
    return make_backend("", p);
}

}  // namespace

TEST_CASE("closed forms: OpenCL device agrees with the host reference") {
    Fixture f;
    auto dev = device();
    auto host = make_backend("host", Precision::Double);
    for (const char* dist : {"beckmann", "ggx", "phong"}) {
        for (bool trans : {false, true}) {
            auto pts = f.random_points(300, trans);
            IntegrationSettings s;
            auto a = f.run(*dev, "bsdf", pts, s, dist);
            auto b = f.run(*host, "bsdf", pts, s, dist);
            REQUIRE(a.method == Method::ClosedForm);
            for (std::size_t k = 0; k < pts.size(); ++k) {
                CAPTURE(dist);
                CAPTURE(k);
                // PoCL contracts a*b+c into FMA; the host build does not, so
                // the last bits differ: allow 1e-10 relative.
                CHECK(std::isfinite(a.value[k]));
                CHECK(a.value[k] == doctest::Approx(b.value[k]).epsilon(1e-10));
                CHECK(a.stderr_[k] == 0.0);
            }
        }
    }
}

TEST_CASE("integrals: device and host draw the same samples") {
    Fixture f;
    auto dev = device();
    auto host = make_backend("host", Precision::Double);
    std::vector<std::map<std::string, double>> pts = {
        {{"theta_i", 10}, {"alpha", 0.2}, {"eta", 1.5}},
        {{"theta_i", 60}, {"alpha", 0.5}, {"eta", 1.33}},
        {{"theta_i", 85}, {"alpha", 0.05}, {"eta", 2.0}},
    };
    for (Method method : {Method::MonteCarlo, Method::Rqmc}) {
        IntegrationSettings s;
        s.method = method;
        s.samples = 512;
        auto a = f.run(*dev, "albedo_r", pts, s);
        auto b = f.run(*host, "albedo_r", pts, s);
        for (std::size_t k = 0; k < pts.size(); ++k) {
            const std::string method_name = to_string(method);
            CAPTURE(method_name);
            CHECK(a.samples[k] == b.samples[k]);
            CHECK(a.value[k] == doctest::Approx(b.value[k]).epsilon(1e-9));
            CHECK(a.stderr_[k] == doctest::Approx(b.stderr_[k]).epsilon(1e-6));
        }
    }
}

TEST_CASE("float precision agrees with double") {
    Fixture f;
    auto dbl = device(Precision::Double);
    auto flt = device(Precision::Float);
    auto pts = f.random_points(200, false);
    IntegrationSettings s;
    auto a = f.run(*dbl, "bsdf", pts, s);
    auto b = f.run(*flt, "bsdf", pts, s);
    for (std::size_t k = 0; k < pts.size(); ++k) {
        CAPTURE(k);
        // Single precision carries ~7 digits; the microfacet terms amplify
        // rounding of the half vector near the specular peak, so 1e-3
        // relative (plus a tiny absolute floor) is the stated agreement.
        CHECK(std::fabs(a.value[k] - b.value[k]) <= 1e-3 * std::fabs(a.value[k]) + 1e-6);
    }
    // Integrals: different random bits (24 vs 32), so compare within errors.
    std::vector<std::map<std::string, double>> apts = {
        {{"theta_i", 30}, {"alpha", 0.3}, {"eta", 1.5}},
        {{"theta_i", 75}, {"alpha", 0.6}, {"eta", 1.2}}};
    IntegrationSettings si;
    si.samples = 1 << 14;
    si.method = Method::MonteCarlo;
    auto ia = f.run(*dbl, "albedo_t", apts, si);
    auto ib = f.run(*flt, "albedo_t", apts, si);
    for (std::size_t k = 0; k < apts.size(); ++k) {
        const double se = std::hypot(ia.stderr_[k], ib.stderr_[k]);
        CHECK(std::fabs(ia.value[k] - ib.value[k]) < 5 * se + 1e-5);
    }
}

TEST_CASE("determinism: same seed identical, slab size irrelevant, seed matters") {
    Fixture f;
    auto dev = device();
    std::vector<std::map<std::string, double>> pts;
    for (int k = 0; k < 37; ++k)
        pts.push_back({{"theta_i", 2.4 * k}, {"alpha", 0.05 + 0.02 * k}, {"eta", 1.5}});
    for (Method method : {Method::MonteCarlo, Method::Rqmc}) {
        for (bool adaptive : {false, true}) {
            const std::string method_name = to_string(method);
            CAPTURE(method_name);
            CAPTURE(adaptive);
            IntegrationSettings s;
            s.method = method;
            s.samples = 256;
            s.seed = 42;
            if (adaptive) {
                s.tolerance = 3e-3;
                s.max_samples = 1 << 15;
            }
            s.slab_work_items = 1000000;
            auto a = f.run(*dev, "albedo_r", pts, s);
            auto b = f.run(*dev, "albedo_r", pts, s);
            s.slab_work_items = 7;  // cells' batches straddle launches
            auto c = f.run(*dev, "albedo_r", pts, s);
            CHECK(a.value == b.value);
            CHECK(a.value == c.value);
            CHECK(a.stderr_ == c.stderr_);
            CHECK(a.samples == c.samples);
            s.seed = 43;
            auto d = f.run(*dev, "albedo_r", pts, s);
            CHECK(a.value != d.value);
        }
    }
}

TEST_CASE("adaptive tolerance: every cell meets it, easy cells stop early") {
    Fixture f;
    auto dev = device();
    // An easy cell (near-normal incidence on a smooth surface: the visible-
    // normal weight is almost constant) and hard ones (grazing) together.
    std::vector<std::map<std::string, double>> pts = {
        {{"theta_i", 20}, {"alpha", 0.02}, {"eta", 1.5}},
        {{"theta_i", 88}, {"alpha", 0.02}, {"eta", 1.5}},
        {{"theta_i", 60}, {"alpha", 0.3}, {"eta", 1.1}},
    };
    IntegrationSettings s;
    s.method = Method::Rqmc;
    s.tolerance = 2e-4;
    s.samples = 1024;
    s.max_samples = 1 << 22;
    auto r = f.run(*dev, "albedo_t", pts, s);
    CHECK(r.cells_unconverged == 0);
    for (std::size_t k = 0; k < pts.size(); ++k) {
        CAPTURE(k);
        CHECK(r.stderr_[k] <= std::max(s.tolerance * std::fabs(r.value[k]), s.abs_floor));
    }
    CHECK(r.tolerance_achieved <= s.tolerance);
    // The smooth cell must not have paid for the hard one.
    CHECK(r.samples[0] < r.samples[1]);
}

TEST_CASE("albedo_r at tiny roughness equals the Fresnel reflectance (oracle)") {
    Fixture f;
    auto dev = device();
    for (double theta : {0.0, 30.0, 60.0, 80.0}) {
        for (double eta : {1.5, 1.0 / 1.5}) {
            std::vector<std::map<std::string, double>> pts = {
                {{"theta_i", theta}, {"alpha", 1e-4}, {"eta", eta}}};
            IntegrationSettings s;
            s.samples = 4096;
            auto r = f.run(*dev, "albedo_r", pts, s, "beckmann");
            CAPTURE(theta);
            CAPTURE(eta);
            const double expected = fresnel_sp(std::cos(theta * kPi / 180), eta);
            // alpha = 1e-4 blurs the mirror by ~1e-4 rad: negligible next to 1e-3.
            CHECK(r.value[0] == doctest::Approx(expected).epsilon(1e-3));
        }
    }
}

TEST_CASE("reported standard errors are honest (coverage over independent seeds)") {
    Fixture f;
    auto dev = device();
    std::vector<std::map<std::string, double>> pts = {
        {{"theta_i", 45}, {"alpha", 0.4}, {"eta", 1.5}}};
    // Reference: a long run, its own error 30x below the runs under test.
    IntegrationSettings ref_s;
    ref_s.method = Method::MonteCarlo;
    ref_s.samples = 1 << 21;
    ref_s.seed = 999;
    const double ref = f.run(*dev, "albedo_t", pts, ref_s).value[0];
    for (Method method : {Method::MonteCarlo, Method::Rqmc}) {
        int inside = 0;
        const int runs = 60;
        for (int seed = 1; seed <= runs; ++seed) {
            IntegrationSettings s;
            s.method = method;
            s.samples = 2048;
            s.seed = static_cast<std::uint64_t>(seed) * 1000003ull;
            auto r = f.run(*dev, "albedo_t", pts, s);
            if (std::fabs(r.value[0] - ref) <= 2 * r.stderr_[0]) ++inside;
        }
        const std::string method_name = to_string(method);
        CAPTURE(method_name);
        CAPTURE(inside);
        // Nominal 95 %; with 60 runs, fewer than 46 inside has probability
        // < 1e-4 if the errors are right.  RQMC with 8 replicates uses a
        // t-like estimate, so its coverage is a little lower: same bound.
        CHECK(inside >= 46);
    }
}

TEST_CASE("method resolution and errors") {
    Fixture f;
    CHECK(resolve_method(f.model.quantity("brdf"), Method::Auto) == Method::ClosedForm);
    CHECK(resolve_method(f.model.quantity("albedo_r"), Method::Auto) == Method::Quadrature);
    CHECK_THROWS_AS(resolve_method(f.model.quantity("brdf"), Method::MonteCarlo), InputError);
    CHECK_THROWS_AS(resolve_method(f.model.quantity("albedo_r"), Method::ClosedForm), InputError);
    CHECK_THROWS_AS(parse_method("simpson"), InputError);
    CHECK(resolve_table_method(f.model.quantity("brdf"), Method::Rqmc) == Method::ClosedForm);
    CHECK(resolve_table_method(f.model.quantity("albedo_r"), Method::MonteCarlo) ==
          Method::MonteCarlo);
    CHECK_THROWS_AS(resolve_table_method(f.model.quantity("albedo_r"), Method::ClosedForm),
                    InputError);
    CHECK_THROWS_AS(make_backend("host", Precision::Float), InputError);
    CHECK_THROWS_AS(make_backend("no-such-device-xyz", Precision::Double), InputError);
}

namespace {

// Counts launches, computing nothing: a refusal must come before the first.
class CountingBackend final : public Backend {
public:
    std::string device_name() const override { return "counting"; }
    Precision precision() const override { return Precision::Double; }
    std::size_t preferred_slab() const override { return 1024; }
    void run(const BatchLaunch& l, std::vector<double>& mean, std::vector<double>& m2) override {
        ++launches;
        mean.assign(l.cells.size(), 0.5);
        m2.assign(l.cells.size(), 0.0);
    }
    int launches = 0;
};

std::string input_error_text(const std::function<void()>& f) {
    try {
        f();
    } catch (const InputError& e) {
        return e.what();
    }
    return "";
}

}  // namespace

TEST_CASE("settings out of range are refused before any launch (issue #15, defect 4)") {
    // Counts above 2^32 - 1 were truncated to 32 bits (2^44 ran 0 samples and
    // reported value 0, stderr null, exit 0).
    IntegrationSettings s;
    s.samples = 17592186044416ull;  // 2^44
    CHECK(input_error_text([&] { check_settings(s); }) ==
          "samples 17592186044416 is out of range; allowed: integers in [1, 4294967295]");
    s.samples = 4294967296ull;
    CHECK_THROWS_AS(check_settings(s), InputError);
    s.samples = 4294967295ull;  // the largest count: accepted
    CHECK_NOTHROW(check_settings(s));
    s = IntegrationSettings{};
    s.max_samples = 0;
    CHECK(input_error_text([&] { check_settings(s); }).find("max_samples 0 is out of range") == 0);
    s.max_samples = 17592186044416ull;
    CHECK_THROWS_AS(check_settings(s), InputError);
    s = IntegrationSettings{};
    for (double tol : {1.0, -0.1, 2.0, std::nan("")}) {
        s.tolerance = tol;
        CAPTURE(tol);
        CHECK(input_error_text([&] { check_settings(s); }).find("allowed: (0, 1)") !=
              std::string::npos);
    }
    s.tolerance = 0.5;
    CHECK_NOTHROW(check_settings(s));
    s = IntegrationSettings{};
    s.abs_floor = 0;
    CHECK_THROWS_AS(check_settings(s), InputError);

    // estimate() runs the check itself: nothing reaches the backend.
    Fixture f;
    CountingBackend counting;
    IntegrationSettings big;
    big.method = Method::MonteCarlo;
    big.samples = 17592186044416ull;
    CHECK_THROWS_AS(f.run(counting, "albedo_r", {{{"theta_i", 30}, {"alpha", 0.3}, {"eta", 1.5}}},
                          big),
                    InputError);
    CHECK(counting.launches == 0);
}

TEST_CASE("Phong needs alpha < 1: every cell checked before any launch (issue #15, defect 5)") {
    // Walter's alpha_p = 2/alpha^2 - 2 is <= 0 from alpha = 1 on (oracle: the
    // formula by hand); the albedos were 1.04 at alpha = 1 and 7.8e30 at 4.
    Fixture f;
    REQUIRE(static_cast<bool>(f.model.check_cell));
    const QuantityInfo& q = f.model.quantity("albedo_avg");
    IntegrationSettings s;
    s.method = Method::MonteCarlo;
    s.samples = 16;
    auto cells = [](std::initializer_list<double> alphas) {
        std::vector<std::map<std::string, double>> pts;
        for (double a : alphas) pts.push_back({{"alpha", a}, {"eta", 1.5}});
        return pts;
    };
    for (double bad : {1.0, 1.5, 4.0}) {
        CountingBackend counting;
        CAPTURE(bad);
        // The bad cell is last: the check must still come before the first launch.
        const std::string m = input_error_text(
            [&] { f.run(counting, q.name, cells({0.5, 0.9, bad}), s, "phong"); });
        CHECK(m.find("alpha = ") == 0);
        CHECK(m.find("is out of range for distribution = phong; allowed: (0, 1)") !=
              std::string::npos);
        CHECK(counting.launches == 0);
    }
    CHECK(input_error_text([&] {
              CountingBackend c;
              f.run(c, q.name, cells({1.0}), s, "phong");
          }).find("alpha = 1 ") == 0);
    // Closed-form quantities too (the distribution is the same).
    {
        CountingBackend counting;
        CHECK_THROWS_AS(f.run(counting, "brdf",
                              {{{"theta_i", 30}, {"theta_o", 30}, {"alpha", 1.0}, {"eta", 1.5}}},
                              IntegrationSettings{}, "phong"),
                        InputError);
        CHECK(counting.launches == 0);
    }
    // Below 1, and for the other distributions up to 4, the cells run.
    for (const char* dist : {"phong", "ggx", "beckmann"}) {
        CountingBackend counting;
        const double top = std::string(dist) == "phong" ? 0.999 : 4.0;
        CHECK_NOTHROW(f.run(counting, q.name, cells({0.1, 0.5, top}), s, dist));
        CHECK(counting.launches > 0);
    }
    // The hook sees the kernel point and the option indices directly.
    std::vector<double> point(f.model.point_stride(), 0.0);
    const std::size_t alpha_slot =
        kDirectionSlots + static_cast<std::size_t>(f.model.find_parameter("alpha") -
                                                   f.model.parameters.data());
    point[alpha_slot] = 0.5;
    CHECK(f.model.check_cell(q, point.data(), f.options("phong")).empty());
    point[alpha_slot] = 1.0;
    CHECK_FALSE(f.model.check_cell(q, point.data(), f.options("phong")).empty());
    CHECK(f.model.check_cell(q, point.data(), f.options("ggx")).empty());
}

TEST_CASE("closed forms: a bad cell past the first launches stops the run, launches in flight") {
    // Closed forms without a checkpoint check each cell as its launch is built
    // (estimate.cpp, the direct pipeline), while the device computes the launch
    // before it (Backend::start/finish).  A bad cell far into the table must
    // still end the run with the model's message, wait for the launches in
    // flight, and leave the backend usable: the next run gives the bits of
    // a fresh backend (and, on the host, of the serial path).
    Fixture f;
    const QuantityInfo& q = f.model.quantity("brdf");
    std::vector<std::map<std::string, double>> pts;
    for (int k = 0; k < 300; ++k)
        pts.push_back({{"theta_i", 0.29 * k}, {"theta_o", 40}, {"alpha", 0.2 + 0.002 * k}, {"eta", 1.5}});
    auto bad = pts;
    bad[250]["alpha"] = 1.0;  // Phong needs alpha < 1
    IntegrationSettings s;
    s.slab_work_items = 16;  // cell 250 is in the 16th launch
    auto dev = device();
    auto host = make_backend("host", Precision::Double);
    for (Backend* backend : {dev.get(), host.get()}) {
        CAPTURE(backend->device_name());
        const std::string m = input_error_text([&] { f.run(*backend, q.name, bad, s, "phong"); });
        CHECK(m.find("alpha = 1 ") == 0);
    }
    const EstimateResult after = f.run(*dev, q.name, pts, s, "phong");
    auto fresh = device();
    const EstimateResult reference = f.run(*fresh, q.name, pts, s, "phong");
    CHECK(after.value == reference.value);
    // A large launch next (the backend's buffers grow) is still right.
    const EstimateResult one_launch = f.run(*dev, q.name, pts, IntegrationSettings{}, "phong");
    CHECK(one_launch.value == reference.value);
    // The host's values, which the device's match to rounding (closed forms
    // above), are nonzero: the cells ran.
    const EstimateResult on_host = f.run(*host, q.name, pts, s, "phong");
    for (std::size_t c = 0; c < pts.size(); ++c) {
        CHECK(on_host.value[c] > 0);
        CHECK(after.value[c] == doctest::Approx(on_host.value[c]).epsilon(1e-9));
    }
}

TEST_CASE("host-threads: bit-identical to the serial host for any thread count") {
    Fixture f;
    auto serial = make_backend("host", Precision::Double);
    std::vector<std::map<std::string, double>> pts;
    for (int k = 0; k < 29; ++k)
        pts.push_back({{"theta_i", 3.0 * k}, {"alpha", 0.05 + 0.02 * k}, {"eta", 1.4}});
    for (const char* selector : {"host-threads", "host-threads:1", "host-threads:3",
                                 "host-threads:64"}) {
        CAPTURE(selector);
        auto threaded = make_backend(selector, Precision::Double);
        for (Method method : {Method::MonteCarlo, Method::Rqmc}) {
            IntegrationSettings s;
            s.method = method;
            s.samples = 96;
            s.batch_size = 16;  // several batches per cell, split across threads
            s.slab_work_items = 37;
            auto a = f.run(*serial, "albedo_t", pts, s);
            auto b = f.run(*threaded, "albedo_t", pts, s);
            CHECK(a.value == b.value);
            CHECK(a.stderr_ == b.stderr_);
            CHECK(a.samples == b.samples);
        }
        auto closed_pts = f.random_points(101, true);
        auto a = f.run(*serial, "bsdf", closed_pts, IntegrationSettings{});
        auto b = f.run(*threaded, "bsdf", closed_pts, IntegrationSettings{});
        CHECK(a.value == b.value);
    }
    CHECK_THROWS_AS(make_backend("host-threads:0", Precision::Double), InputError);
    CHECK_THROWS_AS(make_backend("host-threads:x", Precision::Double), InputError);
    CHECK_THROWS_AS(make_backend("host-threads", Precision::Float), InputError);
}

TEST_CASE("progress is reported from within a round, launch by launch") {
    // 20000 closed-form cells are one round; the backend's preferred slab
    // (1024) caps every launch, so the round takes 20 launches, each of which
    // reports progress: cells done grows within the round.
    Fixture f;
    CountingBackend counting;  // preferred slab 1024
    std::vector<Progress> seen;
    const QuantityInfo& q = f.model.quantity("bsdf");
    PointBuilder builder(f.model, q);
    std::vector<double> point(f.model.point_stride());
    builder.build({{"theta_i", 20}, {"theta_o", 30}, {"phi_d", 10}, {"alpha", 0.3}, {"eta", 1.5}},
                  point.data());
    estimate(
        counting, f.model, q, f.options(), 20000,
        [&](std::size_t, double* out) { std::copy(point.begin(), point.end(), out); },
        IntegrationSettings{}, [&](const Progress& p) { seen.push_back(p); });
    CHECK(counting.launches >= 19);
    REQUIRE(seen.size() >= 3);
    for (std::size_t k = 1; k < seen.size(); ++k) {
        CHECK(seen[k].cells_done >= seen[k - 1].cells_done);
        CHECK(seen[k].fraction >= seen[k - 1].fraction);
    }
    CHECK(seen.front().cells_done > 0);
    CHECK(seen.front().cells_done < 20000);
    CHECK(seen.back().cells_done == 20000);
    CHECK(seen.back().fraction == 1.0);
}

TEST_CASE("closed forms and quadratures: the direct path equals the general one") {
    // Without a checkpoint, closed forms and quadratures skip the per-cell
    // estimator state (estimate.cpp, run_direct); with a checkpoint they run the
    // general rounds.  Both must give the same bits, the same sample counts
    // and the same error figures, on the device and on the host, whether a
    // quadrature cell's two batches share a launch or not (slab 7 splits
    // them).
    Fixture f;
    const ModelInfo& on = find_model("oren-nayar");
    struct Case {
        const ModelInfo* model;
        const char* quantity;
        std::vector<std::map<std::string, double>> points;
    };
    std::vector<Case> cases;
    cases.push_back({&f.model, "bsdf", f.random_points(41, false)});
    {
        auto t = f.random_points(23, true);
        cases.push_back({&f.model, "bsdf", t});
    }
    std::vector<std::map<std::string, double>> on_points;
    for (int k = 0; k < 19; ++k)
        on_points.push_back({{"theta_i", 4.5 * k},
                             {"theta_o", 89 - 4.3 * k},
                             {"phi_d", 19.0 * k - 170},
                             {"sigma", 5 + 2.0 * k}});
    cases.push_back({&on, "brdf", on_points});
    auto dev = device();
    auto host = make_backend("host", Precision::Double);
    for (Backend* backend : {dev.get(), host.get()}) {
        for (const Case& c : cases) {
            const QuantityInfo& q = c.model->quantity(c.quantity);
            const std::vector<int> options = resolve_options(*c.model, nlohmann::json::object(), "t");
            PointBuilder builder(*c.model, q);
            auto point_of = [&](std::size_t cell, double* out) { builder.build(c.points[cell], out); };
            for (std::size_t slab : {std::size_t(0), std::size_t(7)}) {
                CAPTURE(c.model->name);
                CAPTURE(slab);
                IntegrationSettings s;
                s.slab_work_items = slab;
                std::size_t direct_calls = 0, general_calls = 0;
                const EstimateResult direct =
                    estimate(*backend, *c.model, q, options, c.points.size(), point_of, s,
                             [&](const Progress&) { ++direct_calls; });
                EstimateCheckpoint with_state;
                std::size_t saves = 0;
                with_state.save = [&](const EstimateState&, bool) { ++saves; };
                const EstimateResult general =
                    estimate(*backend, *c.model, q, options, c.points.size(), point_of, s,
                             [&](const Progress&) { ++general_calls; }, &with_state);
                CHECK(saves > 0);  // the general path ran
                CHECK(direct.method == general.method);
                CHECK(direct.value == general.value);
                CHECK(direct.stderr_ == general.stderr_);
                CHECK(direct.samples == general.samples);
                CHECK(direct.total_samples == general.total_samples);
                CHECK(direct.tolerance_achieved == general.tolerance_achieved);
                CHECK(direct.cells_unconverged == general.cells_unconverged);
                CHECK(direct_calls == general_calls);
                if (q.name == "brdf") CHECK(direct.method == Method::Quadrature);
            }
        }
    }
}

TEST_CASE("cell_base: a run over a table's tail draws the samples of the whole table's cells") {
    // Cells [base, n) of one run over all n cells equal a run over those
    // cells alone with settings.cell_base = base (what a chunk of a table
    // does), for Monte Carlo and RQMC; without cell_base they differ.
    Fixture f;
    auto dev = device();
    auto pts = f.random_points(29, false);
    for (auto& p : pts) p.erase("theta_o"), p.erase("phi_d");
    const std::size_t base = 11;
    const std::vector<std::map<std::string, double>> tail(pts.begin() + base, pts.end());
    for (Method method : {Method::MonteCarlo, Method::Rqmc}) {
        CAPTURE(to_string(method));
        IntegrationSettings s;
        s.method = method;
        s.samples = 256;
        s.slab_work_items = 5;
        const EstimateResult whole = f.run(*dev, "albedo_r", pts, s);
        const EstimateResult plain = f.run(*dev, "albedo_r", tail, s);
        s.cell_base = base;
        const EstimateResult shifted = f.run(*dev, "albedo_r", tail, s);
        REQUIRE(shifted.value.size() == tail.size());
        for (std::size_t c = 0; c < tail.size(); ++c) {
            CHECK(shifted.value[c] == whole.value[base + c]);
            CHECK(shifted.stderr_[c] == whole.stderr_[base + c]);
        }
        CHECK(plain.value[0] != whole.value[base]);
        s.cell_base = 0xFFFFFFFFull - tail.size() + 1;  // one past the last cell id
        CHECK_THROWS_AS(f.run(*dev, "albedo_r", tail, s), InputError);
    }
}

TEST_CASE("staged launches: inputs built in the backend's memory give run()'s bits") {
    // Backend::stage lends memory for the next start()'s inputs (on PoCL's
    // CPU device the launch's buffers are that memory: no copy).  Launches
    // staged and started in turn (two in flight, the buffer sets
    // alternating, the memory growing), with their means read into a
    // caller's array (BatchLaunch::mean_out), must give the bits of the same
    // launches run from BatchLaunch's vectors; a float backend and the host
    // lend nothing.
    Fixture f;
    const QuantityInfo& q = f.model.quantity("bsdf");
    const auto pts = f.random_points(700, true);
    PointBuilder builder(f.model, q);
    const std::size_t stride = f.model.point_stride();
    BatchLaunch base;
    base.model = &f.model;
    base.quantity = q.id;
    base.options = f.options("beckmann");
    base.method = BT_METHOD_CLOSED;
    base.key0 = 3;
    base.stride = stride;
    base.need_m2 = false;
    // Launch k: cells [first, first + size) of pts, in vectors or staged.
    auto fill = [&](double* points, std::uint32_t* cells, std::uint32_t* batches,
                    std::size_t first, std::size_t size) {
        for (std::size_t w = 0; w < size; ++w) {
            builder.build(pts[first + w], points + w * stride);
            cells[w] = static_cast<std::uint32_t>(first + w);
            batches[w] = 0;
        }
    };
    const std::vector<std::pair<std::size_t, std::size_t>> launches = {
        {0, 5}, {5, 64}, {69, 3}, {72, 300}, {372, 328}};
    auto dev = device();
    std::vector<double> expected(pts.size());
    for (const auto& [first, size] : launches) {
        BatchLaunch l = base;
        l.points.resize(size * stride);
        l.cells.resize(size);
        l.batches.resize(size);
        fill(l.points.data(), l.cells.data(), l.batches.data(), first, size);
        std::vector<double> mean, m2;
        dev->run(l, mean, m2);
        REQUIRE(mean.size() == size);
        std::copy(mean.begin(), mean.end(), expected.begin() + static_cast<std::ptrdiff_t>(first));
    }
    auto staged_dev = device();
    std::vector<double> got(pts.size(), -1.0);
    BatchLaunch slots[2] = {base, base};
    std::vector<double> unused_mean[2], m2[2];
    std::size_t in_flight = 0, next = 0;
    for (const auto& [first, size] : launches) {
        if (in_flight == 2) {
            staged_dev->finish();
            --in_flight;
        }
        BatchLaunch& l = slots[next];
        LaunchStaging to;
        REQUIRE(staged_dev->stage(l, size, to));
        fill(to.points, to.cells, to.batches, first, size);
        l.staged = true;
        l.staged_items = size;
        l.mean_out = got.data() + first;
        staged_dev->start(l, unused_mean[next], m2[next]);
        ++in_flight;
        next ^= 1;
    }
    while (in_flight > 0) {
        staged_dev->finish();
        --in_flight;
    }
    CHECK(got == expected);
    CHECK(unused_mean[0].empty());  // the means went to mean_out only
    CHECK(unused_mean[1].empty());
    LaunchStaging to;
    CHECK_FALSE(make_backend("host", Precision::Double)->stage(base, 4, to));
    CHECK_FALSE(device(Precision::Float)->stage(base, 4, to));
}

namespace {

// Kernel points of `pts`, one after another (model.point_stride() each).
std::vector<double> flat_points(const ModelInfo& model, const QuantityInfo& q,
                                const std::vector<std::map<std::string, double>>& pts) {
    const PointBuilder builder(model, q);
    const std::size_t stride = model.point_stride();
    std::vector<double> out(pts.size() * stride);
    for (std::size_t k = 0; k < pts.size(); ++k) builder.build(pts[k], &out[k * stride]);
    return out;
}

std::size_t alpha_slot_of(const ModelInfo& model) {
    return kDirectionSlots +
           static_cast<std::size_t>(model.find_parameter("alpha") - model.parameters.data());
}

}  // namespace

TEST_CASE("points a span of cells at a time (PointsFn) give the per-cell form's bits") {
    // The oracle is the per-cell form (PointFn), the engine's interface
    // before spans: the same cells must get the same points, so every
    // result bit, sample count and figure must match, on the device (direct
    // path: a launch's points asked for in one call), the host and the
    // threaded host, for a closed form without and with a checkpoint (the
    // general rounds) and for a Monte Carlo quantity.
    Fixture f;
    auto reflection = f.random_points(700, false);
    const auto transmission = f.random_points(600, true);
    reflection.insert(reflection.end(), transmission.begin(), transmission.end());
    std::vector<std::map<std::string, double>> albedo_points;
    for (int k = 0; k < 90; ++k)
        albedo_points.push_back({{"theta_i", 0.95 * k}, {"alpha", 0.05 + 0.01 * k}, {"eta", 1.3}});
    struct Case {
        const char* quantity;
        Method method;
        const std::vector<std::map<std::string, double>>* points;
        bool with_checkpoint;
    };
    const Case cases[] = {{"bsdf", Method::ClosedForm, &reflection, false},
                          {"bsdf", Method::ClosedForm, &reflection, true},
                          {"albedo_r", Method::MonteCarlo, &albedo_points, false}};
    auto dev = device();
    auto host = make_backend("host", Precision::Double);
    auto threads = make_backend("host-threads:2", Precision::Double);
    for (Backend* backend : {dev.get(), host.get(), threads.get()}) {
        for (const Case& c : cases) {
            CAPTURE(backend->device_name());
            CAPTURE(c.quantity);
            CAPTURE(c.with_checkpoint);
            const QuantityInfo& q = f.model.quantity(c.quantity);
            const std::size_t stride = f.model.point_stride();
            const std::vector<double> points = flat_points(f.model, q, *c.points);
            const std::size_t n = c.points->size();
            IntegrationSettings s;
            s.method = c.method;
            s.samples = 64;
            s.seed = 11;
            auto run = [&](const auto& feed) {
                EstimateCheckpoint checkpoint;
                checkpoint.save = [](const EstimateState&, bool) {};
                return estimate(*backend, f.model, q, f.options(), n, feed, s, nullptr,
                                c.with_checkpoint ? &checkpoint : nullptr);
            };
            const PointFn point_of = [&](std::size_t cell, double* out) {
                REQUIRE(cell < n);
                std::copy_n(&points[cell * stride], stride, out);
            };
            // The spans asked for, in order: in the direct path of a closed
            // form they are whole launches and cover every cell once in order.
            std::vector<std::pair<std::size_t, std::size_t>> spans;
            const PointsFn points_of = [&](std::size_t first, std::size_t count, double* out) {
                REQUIRE(first + count <= n);
                spans.emplace_back(first, count);
                std::copy_n(&points[first * stride], count * stride, out);
            };
            const EstimateResult per_cell = run(point_of);
            const EstimateResult by_span = run(points_of);
            CHECK(by_span.value == per_cell.value);
            CHECK(by_span.stderr_ == per_cell.stderr_);
            CHECK(by_span.samples == per_cell.samples);
            CHECK(by_span.total_samples == per_cell.total_samples);
            CHECK(by_span.tolerance_achieved == per_cell.tolerance_achieved);
            CHECK(by_span.method == c.method);
            if (c.method == Method::ClosedForm && !c.with_checkpoint) {
                std::size_t next = 0, widest = 0;
                for (const auto& span : spans) {
                    CHECK(span.first == next);
                    next = span.first + span.second;
                    widest = std::max(widest, span.second);
                }
                CHECK(next == n);
                CHECK(widest >= 256);  // the first launch's size at least
            }
        }
    }
}

TEST_CASE("cells_pass agrees with check_cell, and a refused span names its first refused cell") {
    Fixture f;
    REQUIRE(static_cast<bool>(f.model.cells_pass));
    const double kInf = std::numeric_limits<double>::infinity();
    const std::size_t stride = f.model.point_stride();
    const std::size_t alpha_slot = alpha_slot_of(f.model);
    // One cell at a time, over the edges of Phong's (0, 1) and the others'
    // (0, 4] (oracle: check_cell, whose messages the earlier case checks).
    for (const char* dist : {"phong", "ggx", "beckmann"}) {
        for (const char* quantity : {"bsdf", "albedo_avg"}) {
            const QuantityInfo& q = f.model.quantity(quantity);
            for (double alpha : {-1.0, 0.0, 1e-300, 0.3, 0.999999, 1.0, 1.0000001, 4.0,
                                 std::nan(""), kInf, -kInf}) {
                CAPTURE(dist);
                CAPTURE(alpha);
                std::vector<double> point(stride, 0.5);
                point[alpha_slot] = alpha;
                const bool pass = f.model.check_cell(q, point.data(), f.options(dist)).empty();
                CHECK(f.model.cells_pass(q, point.data(), 1, stride, f.options(dist)) == pass);
            }
        }
    }
    // A span: refused by Phong as soon as one cell is, whatever its place;
    // the other distributions accept it.
    const QuantityInfo& q = f.model.quantity("bsdf");
    std::vector<std::map<std::string, double>> pts;
    for (int k = 0; k < 1000; ++k)
        pts.push_back({{"theta_i", 0.08 * k}, {"theta_o", 30 + 0.05 * k}, {"alpha", 0.2 + 0.0007 * k},
                       {"eta", 1.5}});
    std::vector<double> points = flat_points(f.model, q, pts);
    CHECK(f.model.cells_pass(q, points.data(), pts.size(), stride, f.options("phong")));
    points[999 * stride + alpha_slot] = 1.0;
    CHECK_FALSE(f.model.cells_pass(q, points.data(), pts.size(), stride, f.options("phong")));
    CHECK(f.model.cells_pass(q, points.data(), 999, stride, f.options("phong")));
    CHECK(f.model.cells_pass(q, points.data(), pts.size(), stride, f.options("ggx")));

    // Through estimate(): cells 600 (alpha 1.5) and 800 (alpha 2) refused; the
    // message is check_cell's for cell 600, the first, with either form of
    // point function, on the direct path (spans of whole launches), on the
    // general one (a checkpoint: every cell checked first) and for a Monte
    // Carlo quantity, and nothing is launched on the general paths.
    auto bad = pts;
    bad[600]["alpha"] = 1.5;
    bad[800]["alpha"] = 2.0;
    const std::vector<double> bad_points = flat_points(f.model, q, bad);
    const std::string expected =
        f.model.check_cell(q, &bad_points[600 * stride], f.options("phong"));
    REQUIRE(expected.find("alpha = 1.5 ") == 0);
    auto dev = device();
    for (const char* quantity : {"bsdf", "albedo_r"}) {
        const QuantityInfo& qq = f.model.quantity(quantity);
        for (bool with_checkpoint : {false, true}) {
            for (bool spans : {false, true}) {
                CAPTURE(quantity);
                CAPTURE(with_checkpoint);
                CAPTURE(spans);
                IntegrationSettings s;
                s.samples = 16;
                EstimateCheckpoint checkpoint;
                checkpoint.save = [](const EstimateState&, bool) {};
                EstimateCheckpoint* cp = with_checkpoint ? &checkpoint : nullptr;
                const PointFn point_of = [&](std::size_t cell, double* out) {
                    std::copy_n(&bad_points[cell * stride], stride, out);
                };
                const PointsFn points_of = [&](std::size_t first, std::size_t count, double* out) {
                    std::copy_n(&bad_points[first * stride], count * stride, out);
                };
                CountingBackend counting;
                const bool direct = std::string(quantity) == "bsdf" && !with_checkpoint;
                Backend& backend = direct ? static_cast<Backend&>(*dev) : counting;
                const std::string m = input_error_text([&] {
                    if (spans)
                        estimate(backend, f.model, qq, f.options("phong"), bad.size(), points_of, s,
                                 nullptr, cp);
                    else
                        estimate(backend, f.model, qq, f.options("phong"), bad.size(), point_of, s,
                                 nullptr, cp);
                });
                CHECK(m == expected);
                if (!direct) CHECK(counting.launches == 0);
            }
        }
    }
}

TEST_CASE("engine tuning: the environment only through the documented variables") {
    // docs/contributing.md, "Engine tuning and debugging switches", lists the
    // variables environment_setting() reads; any other name is a programming
    // error, including the launch knobs that are EngineTuning fields only.
    for (const char* documented :
         {"BRDFTAB_DEVICE", "BRDFTAB_SAMPLE_PARALLEL", "BRDFTAB_NODE_PARALLEL",
          "BRDFTAB_WALK_PARALLEL", "BRDFTAB_KERNEL_OPTIONS", "BRDFTAB_TEST_RANK_ABORT",
          "BRDFTAB_READ_TIMEOUT", "BRDFTAB_PROGRESS_INTERVAL"}) {
        CAPTURE(documented);
        CHECK_NOTHROW(environment_setting(documented));
    }
    for (const char* other : {"BRDFTAB_LOCAL_SIZE", "BRDFTAB_GENERIC_KERNELS",
                              "BRDFTAB_SAMPLE_PARALLEL_SCRATCH", "HOME"}) {
        CAPTURE(other);
        CHECK_THROWS_AS(environment_setting(other), std::logic_error);
    }
}

TEST_CASE("engine tuning: the backend keeps the tuning it was given, the host backends none") {
    EngineTuning t;
    t.sample_parallel = LaunchChoice::Off;
    t.local_size = 32;
    t.node_split_shift = -3;
    t.extra_kernel_options = "-D BT_TEST_UNUSED=1";
    auto device = make_backend("", Precision::Double, "", t);
    CHECK(device->tuning().sample_parallel == LaunchChoice::Off);
    CHECK(device->tuning().local_size == 32);
    CHECK(device->tuning().node_split_shift == -3);
    CHECK(device->tuning().extra_kernel_options == "-D BT_TEST_UNUSED=1");
    t.walk_parallel = false;
    device->set_tuning(t);
    CHECK_FALSE(device->tuning().walk_parallel);
    // The host backends have no launch knobs: defaults, whatever is set.
    auto host = make_backend("host", Precision::Double, "", t);
    host->set_tuning(t);
    CHECK(host->tuning().walk_parallel);
    CHECK(host->tuning().local_size == kLocalSize);
}

TEST_CASE("the engine names no model: launch preferences live in the model files") {
    // The model contract (host/models/registry.h): a model is its kernel
    // header and its registration file, and the engine reads what it needs
    // from ModelInfo / QuantityInfo.  Every registered model's name (and its
    // spelling as an identifier) must be absent from host/engine/.
    namespace fs = std::filesystem;
    std::vector<std::string> names;
    for (const ModelInfo& m : all_models()) {
        names.push_back(m.name);
        std::string id = m.name;
        std::replace(id.begin(), id.end(), '-', '_');
        names.push_back(id);
    }
    REQUIRE(names.size() >= 12);
    auto lower = [](std::string t) {
        for (char& c : t) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
        return t;
    };
    std::size_t files = 0;
    for (const auto& entry : fs::recursive_directory_iterator(fs::path(BT_SOURCE_DIR) / "host/engine")) {
        const fs::path& path = entry.path();
        if (!entry.is_regular_file()) continue;
        if (path.extension() != ".cpp" && path.extension() != ".h") continue;
        std::ifstream in(path);
        const std::string text = lower(std::string(std::istreambuf_iterator<char>(in), {}));
        ++files;
        for (const std::string& name : names) {
            CAPTURE(path.string());
            CAPTURE(name);
            CHECK(text.find(name) == std::string::npos);
        }
    }
    CHECK(files >= 10);  // the engine, the backend and the launch strategies
}
