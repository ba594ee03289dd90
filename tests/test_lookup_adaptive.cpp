// test_lookup_adaptive.cpp — the lookup library on adaptive tables
// (host/lookup/adaptive_lookup.cpp): eval, eval_many, eval_dirs, bind, sample
// and pdf against the adaptive table's own evaluation and closed forms.
//
// Oracles: a function multilinear in the warped coordinates on each side of
// a declared kink, which the patches reproduce exactly (t computed here from
// the warps' definitions, not by the library); AdaptiveTable::eval (the
// representation's reference evaluation, host/adaptive), which eval must
// equal bit for bit because it forms the same t and calls the same leaf
// interpolant; the normalisation of a density (a midpoint quadrature over
// the hemisphere written here).  The C header's traversal, compiled by the
// system's C compiler, must equal AdaptiveTable::eval (what `brdftab query`
// prints) bit for bit on values exactly representable as float.
#include <doctest/doctest.h>

#include "test_support.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include "host/adaptive/adaptive_io.h"
#include "host/adaptive/adaptive_table.h"
#include "host/core/error.h"
#include "host/io/header_export.h"
#include "host/lookup/lookup.h"

using namespace brdftab;

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180;

using Fn = std::function<double(const double*)>;

// A 4-D adaptive table over (theta_i, theta_o, phi_d, alpha) of f(t).
AdaptiveTable make_table(const Fn& f, double target, std::size_t max_values,
                         const std::vector<std::vector<AdaptiveBreakpoint>>& bp, int order = 1) {
    AdaptiveBuildOptions o;
    o.patch_order = order;
    o.target = target;
    o.max_values = max_values;
    o.breakpoints = bp;
    AdaptiveTable t;
    std::vector<double> stderrs;
    const AdaptiveBuildReport r = build_adaptive(
        4, o,
        [&](std::size_t count, const double* tp, double* v, double*) {
            for (std::size_t k = 0; k < count; ++k) v[k] = f(tp + 4 * k);
        },
        false, t.layout, t.data.value, stderrs);
    t.data.name = "f";
    t.data.model = "synthetic";
    t.data.quantity = "brdf";
    t.data.units = "1/sr";
    t.data.axes = {make_axis("theta_i", "deg", 0, 90, 9, Spacing::Cos),
                   make_axis("theta_o", "deg", 0, 90, 9, Spacing::Cos),
                   make_axis("phi_d", "deg", 0, 180, 9, Spacing::Linear),
                   make_axis("alpha", "1", 0.01, 1, 5, Spacing::Log)};
    t.data.stored_type = StoredType::Float64;
    t.breakpoints_t.resize(4);
    t.breakpoint_jump.resize(4);
    t.target = target;
    t.estimated_max = r.estimated_max;
    return t;
}

// t of axis coordinates from the warps' definitions (cos, cos, linear, log).
void t_of(const double* x, double* t) {
    t[0] = (std::cos(x[0] * kDeg) - 1) / (std::cos(90 * kDeg) - 1);
    t[1] = (std::cos(x[1] * kDeg) - 1) / (std::cos(90 * kDeg) - 1);
    t[2] = x[2] / 180;
    t[3] = std::log(x[3] / 0.01) / std::log(1 / 0.01);
}

double smooth(const double* t) {
    return 0.2 + std::exp(-3 * t[0]) * std::cos(2 * t[1] * t[2]) + 0.3 * std::sin(4 * t[3]) * t[1];
}

Vec3 dir(double theta_deg, double phi_deg) {
    const double th = theta_deg * kDeg, ph = phi_deg * kDeg;
    return {std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th)};
}

}  // namespace

TEST_CASE("adaptive lookup: a piecewise multilinear function in t is reproduced exactly") {
    const Fn f = [](const double* t) {
        return 1 + std::fabs(t[0] - 0.375) + 0.5 * t[1] + 0.25 * t[1] * t[2] - 0.125 * t[3] * t[0];
    };
    const AdaptiveTable at = make_table(f, 1e-6, 20000, {{{0.375, false}}, {}, {}, {}});
    const LookupTable lt(at);
    CHECK(lt.is_adaptive());
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> u(0, 1);
    double worst = 0;
    for (int k = 0; k < 20000; ++k) {
        const double x[4] = {90 * u(rng), 90 * u(rng), 180 * u(rng), 0.01 + 0.99 * u(rng)};
        double t[4];
        t_of(x, t);
        worst = std::max(worst, std::fabs(lt.eval(x) - f(t)));
    }
    // Rounding only: the warps' t agree to a few ulps, f has slope <= 2.
    CHECK(worst < 1e-13);
}

TEST_CASE("adaptive lookup: eval, eval_many and the file path equal AdaptiveTable::eval bit for bit") {
    for (int order : {1, 2}) {
        CAPTURE(order);
        // A breakpoint on theta_o: leaf boxes whose bounds are not dyadic.
        const AdaptiveTable at = make_table(smooth, 1e-3, 30000, {{}, {{0.3, false}}, {}, {}}, order);
        REQUIRE(at.layout.leaf_count() > 20);  // the tree descent is exercised
        REQUIRE(!at.layout.hanging_leaf.empty());
        const auto dir_path = test::scratch_dir(BT_BINARY_DIR, "test_lookup_adaptive", "io");
        const std::string path = (dir_path / ("a" + std::to_string(order) + ".h5")).string();
        write_table_file(path, {}, {at});
        const LookupTable mem(at);
        const LookupTable file = LookupTable::open(path, "f");
        CHECK(file.is_adaptive());
        CHECK(file.coordinate_names() == std::vector<std::string>{"theta_i", "theta_o", "phi_d", "alpha"});
        const AdaptiveTable back = read_adaptive_table(path, "f");
        std::mt19937_64 rng(5);
        std::uniform_real_distribution<double> u(0, 1);
        const std::size_t n = 5000;
        std::vector<double> pts(4 * n), many(n);
        for (std::size_t k = 0; k < n; ++k) {
            double* x = pts.data() + 4 * k;
            x[0] = 90 * u(rng);
            x[1] = 90 * u(rng);
            x[2] = 180 * u(rng);
            x[3] = 0.01 + 0.99 * u(rng);
            if (k % 50 == 0) x[1] = 90;  // the upper end
            if (k % 50 == 1) x[3] = 1.3;  // outside alpha: clamped alike
        }
        file.eval_many(pts.data(), n, many.data());
        std::size_t same = 0;
        for (std::size_t k = 0; k < n; ++k) {
            const double* x = pts.data() + 4 * k;
            const double ref = back.eval(x);
            const double v = file.eval(x);
            same += v == ref && mem.eval(x) == at.eval(x) && many[k] == v &&
                    file.eval(std::vector<double>(x, x + 4)) == v;
        }
        CHECK(same == n);
        if (order == 2) continue;
        // Out-of-range policy, cubic and the tensor-only calls.
        CHECK_THROWS_WITH_AS(file.eval({10.0, 10.0, 10.0, 1.3}, Interpolation::Linear, OutOfRange::Reject),
                             doctest::Contains("alpha"), InputError);
        CHECK_THROWS_WITH_AS(file.eval({10.0, 10.0, 10.0, 0.5}, Interpolation::Cubic),
                             doctest::Contains("adaptive"), InputError);
        CHECK_THROWS_WITH_AS(file.bind({{"alpha", 0.5}}, Interpolation::Cubic), doctest::Contains("adaptive"),
                             InputError);
        std::vector<std::size_t> cells;
        CHECK_THROWS_AS(file.stencil_cells({10.0, 10.0, 10.0, 0.5}, Interpolation::Linear, OutOfRange::Clamp, cells),
                        InputError);
        CHECK(stderr_lookup(file) == nullptr);  // no stderr stored
    }
}

TEST_CASE("adaptive lookup: eval_dirs and bind agree with eval at the directions' coordinates") {
    const AdaptiveTable at = make_table(smooth, 1e-3, 30000, {});
    const LookupTable lt(at);
    const double alpha = 0.07;
    const BoundTable b = lt.bind({{"alpha", alpha}});
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> u(0, 1);
    double worst_dirs = 0, worst_bound = 0;
    std::size_t same_many = 0;
    const std::size_t n = 3000;
    std::vector<double> wi(3 * n), wo(3 * n), out(n), out_dirs(n);
    for (std::size_t k = 0; k < n; ++k) {
        const double ti = 89 * u(rng), to = 89 * u(rng), pi = 360 * u(rng), po = 360 * u(rng);
        const Vec3 a = dir(ti, pi), c = dir(to, po);
        double pd = std::fmod(std::fabs(po - pi), 360.0);
        if (pd > 180) pd = 360 - pd;
        const double ref = lt.eval({ti, to, pd, alpha});
        worst_dirs = std::max(worst_dirs, std::fabs(lt.eval_dirs(a, c, {{"alpha", alpha}}) - ref));
        worst_bound = std::max(worst_bound, std::fabs(b.eval(a, c) - ref));
        wi[3 * k] = a.x, wi[3 * k + 1] = a.y, wi[3 * k + 2] = a.z;
        wo[3 * k] = c.x, wo[3 * k + 1] = c.y, wo[3 * k + 2] = c.z;
    }
    b.eval_many(wi.data(), wo.data(), n, out.data());
    lt.eval_dirs_many(wi.data(), wo.data(), n, out_dirs.data(), {{"alpha", alpha}});
    for (std::size_t k = 0; k < n; ++k)
        same_many += out[k] == b.eval({wi[3 * k], wi[3 * k + 1], wi[3 * k + 2]},
                                      {wo[3 * k], wo[3 * k + 1], wo[3 * k + 2]}) &&
                     out_dirs[k] == lt.eval_dirs({wi[3 * k], wi[3 * k + 1], wi[3 * k + 2]},
                                                 {wo[3 * k], wo[3 * k + 1], wo[3 * k + 2]},
                                                 {{"alpha", alpha}});
    CHECK(same_many == n);
    // The angles of a direction differ from the test's by rounding (acos,
    // atan2); the table is continuous with slopes of order 10 per radian.
    CHECK(worst_dirs < 1e-11);
    CHECK(worst_bound < 1e-11);
}

TEST_CASE("adaptive lookup: bound sampling is a normalised density consistent with pdf and eval") {
    const AdaptiveTable at = make_table(smooth, 1e-3, 30000, {});
    const LookupTable lt(at);
    const BoundTable b = lt.bind({{"alpha", 0.3}});
    REQUIRE(b.can_sample());
    for (double ti : {0.0, 23.0, 61.0, 85.0}) {
        const Vec3 wi = dir(ti, 40);
        // Midpoint rule in (mu, phi) over the upper hemisphere.
        const int nm = 400, np = 400;
        double total = 0;
        for (int i = 0; i < nm; ++i)
            for (int j = 0; j < np; ++j) {
                const double mu = (i + 0.5) / nm, ph = 2 * kPi * (j + 0.5) / np;
                const double s = std::sqrt(1 - mu * mu);
                total += b.pdf(wi, {s * std::cos(ph), s * std::sin(ph), mu});
            }
        total *= (1.0 / nm) * (2 * kPi / np);
        CHECK(total == doctest::Approx(1).epsilon(2e-2));
        std::mt19937_64 rng(17);
        std::uniform_real_distribution<double> u(0, 1);
        for (int k = 0; k < 200; ++k) {
            const SampleResult s = b.sample(wi, u(rng), u(rng));
            REQUIRE(s.pdf > 0);
            CHECK(s.pdf == doctest::Approx(b.pdf(wi, s.wo)).epsilon(1e-9));
            CHECK(s.value == doctest::Approx(b.eval(wi, s.wo)).epsilon(1e-12));
        }
    }
}

TEST_CASE("adaptive C header: the compiled traversal equals AdaptiveTable::eval bit for bit") {
    AdaptiveTable at = make_table(smooth, 1e-3, 20000, {});
    REQUIRE(at.layout.leaf_count() > 20);
    for (double& v : at.data.value) v = double(float(v));  // a float header stores them exactly
    const std::string dir = std::string(BT_BINARY_DIR);
    const std::string header = dir + "/test_adaptive_hdr.h";
    HeaderExportOptions opt;
    opt.type = HeaderValueType::Float;
    opt.name = "ad";
    export_c_header(at, header, opt);
    std::mt19937_64 rng(21);
    std::uniform_real_distribution<double> U(0, 1);
    std::vector<std::vector<double>> pts;
    for (int n = 0; n < 2000; ++n) {
        std::vector<double> x;
        for (const Axis& a : at.data.axes) {
            const double w = a.max - a.min;
            x.push_back(a.min - 0.05 * w + 1.1 * w * U(rng));  // some outside: clamped
        }
        pts.push_back(x);
    }
    const std::string prog = dir + "/test_adaptive_hdr.c", exe = dir + "/test_adaptive_hdr";
    {
        std::ofstream c(prog);
        c << "#include <stdio.h>\n#include \"test_adaptive_hdr.h\"\nstatic const double p[][4] = {\n";
        char buf[40];
        for (const auto& x : pts) {
            c << "  {";
            for (double v : x) {
                std::snprintf(buf, sizeof buf, "%a", v);
                c << buf << ",";
            }
            c << "},\n";
        }
        c << "};\nint main(void) {\n  size_t i;\n  for (i = 0; i < sizeof p / sizeof p[0]; ++i)"
             " printf(\"%a\\n\", ad_eval(p[i]));\n  return 0;\n}\n";
    }
    const char* cc = std::getenv("CC");
    const std::string compiler = cc && *cc ? cc : "cc";
    const std::string cmd = compiler + " -std=c99 -Wall -Wextra -Werror -I" + dir + " " + prog +
                            " -o " + exe + " -lm 2>" + exe + ".err && " + exe + " > " + exe + ".out";
    if (std::system(cmd.c_str()) != 0) {
        std::ifstream err(exe + ".err");
        const std::string text((std::istreambuf_iterator<char>(err)), {});
        // A compiler that exists but rejects the header is a failure.
        CHECK_MESSAGE(text.find("ad_") == std::string::npos, text);
        MESSAGE("no working C compiler ('" << compiler << "'): header not compiled");
        return;
    }
    std::ifstream in(exe + ".out");
    int mismatches = 0;
    for (const auto& x : pts) {
        std::string line;
        REQUIRE(static_cast<bool>(std::getline(in, line)));
        const double got = std::strtod(line.c_str(), nullptr), want = at.eval(x.data());
        if (std::memcmp(&got, &want, sizeof got) != 0) ++mismatches;
    }
    CHECK(mismatches == 0);
    for (const std::string& p : {header, prog, exe, exe + ".out", exe + ".err"})
        std::remove(p.c_str());
}
