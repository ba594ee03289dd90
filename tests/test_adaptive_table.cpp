// test_adaptive_table.cpp — adaptive tables (host/adaptive): refinement on
// synthetic functions whose error and node count follow from the theory of
// linear interpolation, tensor tables of the same size that fail, continuity
// across patch faces, determinism and the HDF5 round trip.
//
// Oracles: closed-form functions evaluated directly (quadratics that order-2
// patches must hold exactly; the h^(order+1) law of Lagrange interpolation
// for convergence); the interpolation error
// of |x - c| on a cell of width h with the kink at fraction s (2 s (1 - s) h
// at the kink, h min(s, 1 - s) at the midpoint: elementary); tensor tables
// interpolated by code written here, not by the library.
#include <doctest/doctest.h>

#include "test_support.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "host/adaptive/adaptive_io.h"
#include "host/adaptive/adaptive_table.h"
#include "host/core/error.h"
#include "host/io/table_io.h"

using namespace brdftab;

namespace {

using Fn = std::function<double(const double*)>;

struct Built {
    AdaptiveLayout layout;
    std::vector<double> values, stderr_;
    AdaptiveBuildReport report;
};

Built build(std::size_t dims, const AdaptiveBuildOptions& o, const Fn& f) {
    Built b;
    b.report = build_adaptive(
        dims, o,
        [&](std::size_t count, const double* t, double* v, double*) {
            for (std::size_t k = 0; k < count; ++k) v[k] = f(t + k * dims);
        },
        false, b.layout, b.values, b.stderr_);
    return b;
}

// Largest |table - f| over `points` random points (uniform in t) and the
// given extra points.
double max_error(const Built& b, std::size_t dims, const Fn& f, std::size_t points,
                 const std::vector<std::vector<double>>& extra = {}) {
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(0, 1);
    double m = 0;
    std::vector<double> t(dims);
    for (std::size_t k = 0; k < points; ++k) {
        for (double& x : t) x = u(rng);
        m = std::max(m, std::fabs(b.layout.eval(t.data(), b.values.data()) - f(t.data())));
    }
    for (const auto& p : extra) m = std::max(m, std::fabs(b.layout.eval(p.data(), b.values.data()) - f(p.data())));
    return m;
}

// A uniform nx x ny tensor table of f on [0, 1]^2, interpolated bilinearly
// (written here), and its largest error over random points and `extra`.
double tensor_error(std::size_t nx, std::size_t ny, const Fn& f, std::size_t points,
                    const std::vector<std::vector<double>>& extra = {}) {
    std::vector<double> v(nx * ny);
    for (std::size_t i = 0; i < nx; ++i)
        for (std::size_t j = 0; j < ny; ++j) {
            const double p[2] = {double(i) / double(nx - 1), double(j) / double(ny - 1)};
            v[i * ny + j] = f(p);
        }
    auto eval = [&](const double* p) {
        const double ux = p[0] * double(nx - 1), uy = p[1] * double(ny - 1);
        const std::size_t i = std::min<std::size_t>(std::size_t(ux), nx - 2);
        const std::size_t j = std::min<std::size_t>(std::size_t(uy), ny - 2);
        const double fx = ux - double(i), fy = uy - double(j);
        return (1 - fx) * ((1 - fy) * v[i * ny + j] + fy * v[i * ny + j + 1]) +
               fx * ((1 - fy) * v[(i + 1) * ny + j] + fy * v[(i + 1) * ny + j + 1]);
    };
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> u(0, 1);
    double m = 0;
    for (std::size_t k = 0; k < points; ++k) {
        const double p[2] = {u(rng), u(rng)};
        m = std::max(m, std::fabs(eval(p) - f(p)));
    }
    for (const auto& p : extra) m = std::max(m, std::fabs(eval(p.data()) - f(p.data())));
    return m;
}

// Every tensor table nx x ny (nx, ny >= 2) with at most `values` values
// misses `target` on f.
void check_every_tensor_fails(std::size_t values, const Fn& f, double target,
                              const std::vector<std::vector<double>>& extra) {
    for (std::size_t ny = 2; ny <= values / 2; ++ny)
        for (std::size_t nx = 2; nx * ny <= values; ++nx) {
            CAPTURE(nx);
            CAPTURE(ny);
            CHECK(tensor_error(nx, ny, f, 2000, extra) > target);
        }
}

}  // namespace

TEST_CASE("a kink on a declared breakpoint costs nothing") {
    const double c = 0.3;
    const Fn f = [&](const double* p) { return std::fabs(p[0] - c) * (1 + p[1]); };
    AdaptiveBuildOptions o;
    o.target = 1e-3;
    o.breakpoints = {{{c, false}}, {}};
    const Built b = build(2, o, f);
    // Bilinear on each side of the kink: the two root patches (3 x 3 nodes
    // each, 3 shared on the face) are exact.
    CHECK(b.report.leaves == 2);
    CHECK(b.values.size() == 15);
    CHECK(max_error(b, 2, f, 20000) < 1e-14);
    // Every tensor table of 15 values misses the target.
    check_every_tensor_fails(15, f, o.target, {{c, 1.0}});
}

TEST_CASE("an undeclared kink refines to the node count the theory predicts") {
    const double c = 1 / M_PI;
    const Fn f = [&](const double* p) { return std::fabs(p[0] - c) + 0.25 * p[1]; };
    AdaptiveBuildOptions o;
    o.target = 1e-4;
    const Built b = build(2, o, f);
    // Theory: only the leaf holding the kink has an error; at level L its
    // cells are h = 2^-L / 2 wide, the kink at fraction s of its cell, and
    // the midpoint probe sees h min(s, 1 - s).  It is split until that is
    // <= safety x target, each split adding 2 nodes in x to 3 in y (y is
    // linear: never split).
    int level = 0;
    double worst_at_kink = 0;
    for (;; ++level) {
        const double h = std::ldexp(1.0, -level) / 2;
        const double s = std::fmod(c, h) / h;
        if (h * std::min(s, 1 - s) <= o.safety * o.target) {
            worst_at_kink = 2 * s * (1 - s) * h;
            break;
        }
    }
    CAPTURE(level);
    CHECK(b.values.size() == std::size_t(3 * (3 + 2 * level)));
    const double err = max_error(b, 2, f, 20000, {{c, 0.0}, {c, 0.5}, {c, 1.0}});
    CHECK(err == doctest::Approx(worst_at_kink).epsilon(1e-9));
    CHECK(err <= o.target);
    check_every_tensor_fails(b.values.size(), f, o.target, {{c, 0.0}, {c, 1.0}});
}

TEST_CASE("a declared jump is represented exactly by two-sided patches") {
    const double c = 0.3;
    const Fn f = [&](const double* p) { return (p[0] >= c ? 1.0 : 0.0) + 0.25 * p[1]; };
    AdaptiveBuildOptions o;
    o.target = 1e-3;
    o.breakpoints = {{{c, true}}, {}};
    const Built b = build(2, o, f);
    CHECK(b.report.leaves == 2);
    CHECK(b.values.size() == 18);  // no node shared across the jump
    CHECK(max_error(b, 2, f, 20000, {{c, 0.5}, {std::nextafter(c, 0.0), 0.5}}) < 1e-14);
    check_every_tensor_fails(18, f, o.target, {});
    // Undeclared, the jump cannot be resolved: the refinement stops at its
    // budget with the estimate above the target.
    o.breakpoints.clear();
    o.max_values = 2000;
    const Built u = build(2, o, f);
    CHECK(u.report.budget_hit);
    CHECK(u.report.estimated_max > o.target);
    CHECK(u.values.size() <= o.max_values);
}

namespace {

// Random points on interior faces of leaves: the leaf's own interpolant and
// its neighbour's agree (the neighbour found by the descent from a point
// just outside the face, evaluated on the face itself).
double face_crack(const AdaptiveLayout& L, const std::vector<double>& values, std::size_t points,
                  std::size_t& tested) {
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> u(0, 1);
    const std::size_t d = L.dims;
    double worst = 0;
    tested = 0;
    std::vector<double> p(d), q(d);
    while (tested < points) {
        const std::size_t l = std::size_t(rng() % L.leaf_count());
        const std::size_t a = std::size_t(rng() % d);
        const bool upper = rng() & 1;
        const double* box = L.box.data() + l * d * 2;
        const double face = box[2 * a + (upper ? 1 : 0)];
        if (face == 0 || face == 1) continue;  // the domain's boundary
        for (std::size_t b = 0; b < d; ++b) p[b] = box[2 * b] + u(rng) * (box[2 * b + 1] - box[2 * b]);
        p[a] = face;
        q = p;
        q[a] = upper ? std::nextafter(face, 2.0) : std::nextafter(face, -1.0);
        const std::size_t other = L.leaf_of(q.data());
        REQUIRE(other != l);
        worst = std::max(worst, std::fabs(L.eval_leaf(l, p.data(), values.data()) -
                                          L.eval_leaf(other, p.data(), values.data())));
        ++tested;
    }
    return worst;
}

}  // namespace

namespace {

// The table of a build, written as float32 bit-rounded to `accuracy`
// (absolute) and read back: its hanging nodes recomputed from the rounded
// stored values by the reader.
AdaptiveTable rounded_round_trip(const Built& b, std::size_t dims, double accuracy, const std::string& path) {
    AdaptiveTable t;
    t.data.name = "f";
    t.data.model = "synthetic";
    t.data.quantity = "albedo";
    t.data.units = "1";
    for (std::size_t a = 0; a < dims; ++a)
        t.data.axes.push_back(make_axis("x" + std::to_string(a), "1", 0, 1, 2, Spacing::Linear));
    t.data.value = b.values;
    t.data.stored_type = StoredType::Float32;
    t.data.round_accuracy = accuracy;
    t.data.round_absolute = true;
    t.layout = b.layout;
    t.target = accuracy;
    write_table_file(path, {}, {t});
    return read_adaptive_table(path, "f");
}

}  // namespace

TEST_CASE("continuity across patch faces at 1e5 random face points") {
    // Features along different axes in different places, so that leaves of
    // different shapes meet: hanging nodes on faces, edges and corners.
    const Fn f3 = [](const double* p) {
        return std::exp(-((p[0] - 0.37) * (p[0] - 0.37) / 0.002 + (p[1] - 0.61) * (p[1] - 0.61) / 0.05)) *
                   (1 + p[2] * p[2]) +
               0.3 * std::sqrt((p[2] - 0.2) * (p[2] - 0.2) + 1e-4);
    };
    const Fn f2 = [](const double* p) { return std::fabs(p[0] - 0.3 - 0.4 * p[1]) + 0.1 * p[1]; };
    const auto dir = test::scratch_dir(BT_BINARY_DIR, "test_adaptive_table", "continuity");
    for (const auto& [n, order] : {std::pair<std::size_t, int>{3, 1}, {5, 1}, {3, 2}, {5, 2}}) {
        CAPTURE(n);
        CAPTURE(order);
        AdaptiveBuildOptions o;
        o.patch_nodes = n;
        o.patch_order = order;
        o.target = 2e-3;
        o.max_values = 60000;
        // A start fine enough that its probes see the narrow peak (a
        // coarser one can miss it altogether: no refinement finds what no
        // probe sees; the certificate's random probes would).
        o.initial_level = {3, 2, 1};
        const Built b3 = build(3, o, f3);
        MESSAGE("3-D, patch_nodes " << n << ", order " << order << ": " << b3.report.values << " nodes, "
                                    << b3.report.hanging_nodes << " hanging, " << b3.report.balance_splits
                                    << " balance halvings, " << b3.report.leaves << " leaves, budget hit "
                                    << b3.report.budget_hit << ", estimate " << b3.report.estimated_max
                                    << ", error " << max_error(b3, 3, f3, 20000));
        CHECK(b3.report.hanging_nodes > 100);
        CHECK(b3.report.balance_splits > 0);  // the test function needs the balance rule
        CHECK(b3.report.continuity_residual < 1e-13);
        std::size_t tested = 0;
        CHECK(face_crack(b3.layout, b3.values, 100000, tested) < 1e-12);
        CHECK(tested == 100000);
        // The accuracy the refinement reached is kept (order 1 stops at its
        // budget here, above the target: its own estimate is the bound).
        CHECK(max_error(b3, 3, f3, 20000) < 1.5 * std::max(o.target, b3.report.estimated_max));
        CHECK(b3.report.stored() < b3.report.values);  // hanging nodes are not stored
        // Bit-rounded storage: the reader derives the hanging nodes from the
        // rounded stored values, so the faces still agree.
        const std::string tag = std::to_string(n) + "_" + std::to_string(order);
        const AdaptiveTable r3 = rounded_round_trip(b3, 3, o.target, (dir / ("r3_" + tag + ".h5")).string());
        REQUIRE(r3.data.value.size() == b3.values.size());
        CHECK(r3.data.value != b3.values);  // the rounding changed the values
        CHECK(face_crack(r3.layout, r3.data.value, 100000, tested) < 1e-12);

        o.target = 1e-3;
        o.initial_level.clear();
        const Built b2 = build(2, o, f2);
        CHECK(b2.report.hanging_nodes > 10);
        CHECK(face_crack(b2.layout, b2.values, 100000, tested) < 1e-12);
        CHECK(max_error(b2, 2, f2, 20000) < 1.5 * o.target);
        const AdaptiveTable r2 = rounded_round_trip(b2, 2, o.target, (dir / ("r2_" + tag + ".h5")).string());
        CHECK(face_crack(r2.layout, r2.data.value, 100000, tested) < 1e-12);
    }
    // Without hanging nodes and the balance the same table has cracks (so
    // the checks above can fail).
    for (int order : {1, 2}) {
        CAPTURE(order);
        AdaptiveBuildOptions o;
        o.target = 2e-3;
        o.patch_order = order;
        o.initial_level = {3, 2, 1};
        o.continuity = false;
        const Built raw = build(3, o, f3);
        CHECK(raw.report.hanging_nodes == 0);
        std::size_t tested = 0;
        CHECK(face_crack(raw.layout, raw.values, 100000, tested) > 1e-6);
    }
}

TEST_CASE("order-2 patches reproduce functions quadratic along each axis exactly") {
    // Degree <= 2 in each coordinate separately (x^2 y^2 z^2 included): the
    // tensor piecewise quadratic holds them exactly, the multilinear one not.
    const Fn f1 = [](const double* p) { return 1 + 2 * p[0] - 3 * p[0] * p[0]; };
    const Fn f2 = [](const double* p) {
        const double x = p[0], y = p[1];
        return 0.5 + x - 2 * x * x + 0.7 * x * y - 1.3 * y * y + 2.1 * x * x * y * y;
    };
    const Fn f3 = [](const double* p) {
        const double x = p[0], y = p[1], z = p[2];
        return x * x * y * y * z * z - 0.4 * x * z * z + 0.9 * y - 0.2 * z * z + 1;
    };
    for (std::size_t n : {std::size_t(3), std::size_t(5), std::size_t(9)})
        for (const auto& [dims, f] : {std::pair<std::size_t, Fn>{1, f1}, {2, f2}, {3, f3}}) {
            CAPTURE(n);
            CAPTURE(dims);
            if (n == 9 && dims == 3) continue;
            AdaptiveBuildOptions o;
            o.patch_nodes = n;
            o.patch_order = 2;
            o.target = 1e-9;
            // A first uniform split along axis 0 and a breakpoint on the last
            // axis: several leaves, faces between them.
            o.initial_level.assign(dims, 0);
            o.initial_level[0] = 1;
            o.breakpoints.assign(dims, {});
            o.breakpoints[dims - 1] = {{0.3, false}};
            const Built b = build(dims, o, f);
            CHECK(b.report.estimated_max < 1e-13);
            CHECK(b.report.leaves == 4);  // nothing refined beyond the start
            CHECK(max_error(b, dims, f, 20000) < 1e-13);
            o.patch_order = 1;
            o.target = 1e30;  // the same start, not refined
            const Built lin = build(dims, o, f);
            CHECK(max_error(lin, dims, f, 20000) > 1e-4);
        }
}

namespace {

// Largest error of a uniform 1-D table of 2^level patches (no refinement:
// the target is never missed) of f at 20 001 evenly spaced points.
double uniform_error(int order, std::size_t n, int level, const Fn& f) {
    AdaptiveBuildOptions o;
    o.patch_nodes = n;
    o.patch_order = order;
    o.target = 1e30;
    o.initial_level = {level};
    const Built b = build(1, o, f);
    REQUIRE(b.report.leaves == (std::size_t{1} << level));
    double m = 0;
    for (int k = 0; k <= 20000; ++k) {
        const double t = k / 20000.0;
        m = std::max(m, std::fabs(b.layout.eval(&t, b.values.data()) - f(&t)));
    }
    return m;
}

}  // namespace

TEST_CASE("convergence order: the error falls by 8 per halving with order 2, by 4 with order 1") {
    // Smooth: the interpolation error is C h^(order + 1) max|f^(order+1)|
    // locally, so halving h divides it by 2^(order + 1) as h -> 0.
    const Fn f = [](const double* p) { return std::sin(3 * p[0]) + std::exp(1.5 * p[0]); };
    for (std::size_t n : {std::size_t(3), std::size_t(5)}) {
        CAPTURE(n);
        for (int level = 3; level <= 6; ++level) {
            CAPTURE(level);
            const double r2 = uniform_error(2, n, level, f) / uniform_error(2, n, level + 1, f);
            const double r1 = uniform_error(1, n, level, f) / uniform_error(1, n, level + 1, f);
            CHECK(r2 > 7.0);
            CHECK(r2 < 9.0);
            CHECK(r1 > 3.5);
            CHECK(r1 < 4.5);
        }
    }
    // And the refinement, on the same function at E = 1e-7, stores fewer
    // values with order 2 and meets E.
    AdaptiveBuildOptions o;
    o.target = 1e-7;
    o.patch_order = 2;
    const Built q = build(1, o, f);
    o.patch_order = 1;
    const Built l = build(1, o, f);
    CHECK(max_error(q, 1, f, 20000) <= o.target);
    CHECK(max_error(l, 1, f, 20000) <= o.target);
    CHECK(q.values.size() * 4 < l.values.size());
}

TEST_CASE("refinement is deterministic") {
    const Fn f = [](const double* p) { return std::sin(7 * p[0]) * std::exp(-3 * p[1]) + std::fabs(p[1] - 0.4); };
    AdaptiveBuildOptions o;
    o.target = 1e-3;
    const Built a = build(2, o, f), b = build(2, o, f);
    CHECK(a.values == b.values);
    CHECK(a.layout.box == b.layout.box);
    CHECK(a.layout.leaf_nodes == b.layout.leaf_nodes);
    CHECK(a.layout.split_t == b.layout.split_t);
}

TEST_CASE("bad options are refused with the key named") {
    AdaptiveLayout L;
    std::vector<double> v, s;
    const AdaptiveBatchFn none = [](std::size_t, const double*, double*, double*) {};
    AdaptiveBuildOptions o;
    o.patch_nodes = 4;
    CHECK_THROWS_WITH_AS(build_adaptive(2, o, none, false, L, v, s), doctest::Contains("patch_nodes"), InputError);
    o = AdaptiveBuildOptions{};
    o.breakpoints = {{{0.5, false}, {0.4, false}}};
    CHECK_THROWS_WITH_AS(build_adaptive(2, o, none, false, L, v, s), doctest::Contains("breakpoints"), InputError);
    o = AdaptiveBuildOptions{};
    o.target = 0;
    CHECK_THROWS_WITH_AS(build_adaptive(2, o, none, false, L, v, s), doctest::Contains("target"), InputError);
    o = AdaptiveBuildOptions{};
    o.patch_order = 3;
    CHECK_THROWS_WITH_AS(build_adaptive(2, o, none, false, L, v, s), doctest::Contains("patch_order"), InputError);
}

TEST_CASE("adaptive tables round-trip through HDF5; tensor readers refuse them") {
    const auto dir = test::scratch_dir(BT_BINARY_DIR, "test_adaptive_table", "io");
    const Fn f = [](const double* p) { return 0.5 + std::sin(5 * p[0]) * std::cos(3 * p[1]) + std::fabs(p[0] - 0.6); };
    AdaptiveBuildOptions o;
    o.target = 1e-3;
    o.breakpoints = {{{0.6, false}}, {}};
    Built b = build(2, o, f);
    AdaptiveTable t;
    t.data.name = "albedo";
    t.data.model = "synthetic";
    t.data.quantity = "albedo";
    t.data.units = "1";
    t.data.axes = {make_axis("mu", "1", -1, -0.02, 2, Spacing::Linear),
                   make_axis("alpha", "1", 0.01, 1, 2, Spacing::Log)};
    t.data.value = b.values;
    t.data.stderr_.assign(b.values.size(), 1e-7);
    t.data.stored_type = StoredType::Float64;
    t.layout = b.layout;
    t.breakpoints_t = {{0.6}, {}};
    t.breakpoint_jump = {{false}, {}};
    t.target = o.target;
    t.estimated_max = b.report.estimated_max;
    const std::string path = (dir / "a.h5").string();
    write_table_file(path, {}, {t});
    const AdaptiveTable r = read_adaptive_table(path, "albedo");
    CHECK(r.data.value == t.data.value);
    CHECK(r.data.stderr_ == t.data.stderr_);
    CHECK(r.layout.split_axis == t.layout.split_axis);
    CHECK(r.layout.split_t == t.layout.split_t);
    CHECK(r.layout.lower == t.layout.lower);
    CHECK(r.layout.upper == t.layout.upper);
    CHECK(r.layout.box == t.layout.box);
    CHECK(r.layout.leaf_nodes == t.layout.leaf_nodes);
    CHECK(r.breakpoints_t == t.breakpoints_t);
    CHECK(r.target == t.target);
    CHECK(r.data.axes[1].spacing == Spacing::Log);
    const double x[2] = {-0.5, 0.2};
    CHECK(r.eval(x) == t.eval(x));
    CHECK(r.layout.patch_order == 1);
    CHECK(is_adaptive_table(path, "albedo"));
    {
        // Order 2: the attribute travels, and the read table evaluates the same.
        AdaptiveBuildOptions o2 = o;
        o2.patch_order = 2;
        const Built b2 = build(2, o2, f);
        AdaptiveTable t2 = t;
        t2.layout = b2.layout;
        t2.data.value = b2.values;
        t2.data.stderr_.assign(b2.values.size(), 1e-7);
        const std::string p2 = (dir / "q.h5").string();
        write_table_file(p2, {}, {t2});
        const AdaptiveTable r2 = read_adaptive_table(p2, "albedo");
        CHECK(r2.layout.patch_order == 2);
        CHECK(r2.eval(x) == t2.eval(x));
        CHECK(t2.eval(x) != t.eval(x));
    }
    CHECK_THROWS_WITH_AS(read_table(path, "albedo"), doctest::Contains("adaptive"), InputError);

    // float32 with bit rounding: what is read back is the rounded float.
    t.data.stored_type = StoredType::Float32;
    t.data.round_accuracy = 1e-4;
    t.data.round_absolute = true;
    const std::string p32 = (dir / "b.h5").string();
    write_table_file(p32, {}, {t});
    const AdaptiveTable r32 = read_adaptive_table(p32, "albedo");
    REQUIRE(r32.data.value.size() == t.data.value.size());
    double worst = 0;
    for (std::size_t i = 0; i < t.data.value.size(); ++i)
        worst = std::max(worst, std::fabs(r32.data.value[i] - t.data.value[i]));
    CHECK(worst > 0);
    CHECK(worst <= 0.1 * t.data.round_accuracy);
    CHECK(r32.data.round_accuracy == t.data.round_accuracy);

    // A hanging node constrained by a leaf that has it as its own node
    // would need its own value: the reader refuses the file.
    {
        REQUIRE(!t.layout.hanging_leaf.empty());
        AdaptiveTable bad = t;
        const std::size_t first = bad.layout.stored_count(bad.data.value.size());
        const std::size_t per = bad.layout.nodes_per_leaf();
        const auto at = std::find(bad.layout.leaf_nodes.begin(), bad.layout.leaf_nodes.end(), std::uint32_t(first));
        REQUIRE(at != bad.layout.leaf_nodes.end());
        bad.layout.hanging_leaf[0] = std::uint32_t(std::size_t(at - bad.layout.leaf_nodes.begin()) / per);
        const std::string pb = (dir / "h.h5").string();
        write_table_file(pb, {}, {bad});
        CHECK_THROWS_WITH_AS(read_adaptive_table(pb, "albedo"), doctest::Contains("hanging node"), InputError);
    }
    // A damaged layout is refused, naming the table.
    t.layout.leaf_nodes[0] = std::uint32_t(t.data.value.size());
    CHECK_THROWS_WITH_AS(write_table_file((dir / "c.h5").string(), {}, {t}), doctest::Contains("leaf_nodes"),
                         InputError);
    CHECK(!std::filesystem::exists(dir / "c.h5"));
}
