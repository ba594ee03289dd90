// test_lookup_warps.cpp — the log-complement and critical spacings through the
// spec parser, the lookup library, the HDF5 file and the C header export.
//
// Oracles: node positions and inverses written here from the defining
// formulas (Snell's critical cosine cos(asin(1/eta)), geometric distances to
// the pivot), not through Axis::warp; an independent bilinear interpolation
// in (t, log eta); functions that are piecewise linear in those coordinates,
// which linear interpolation must reproduce exactly; and the exported C
// header compiled by the system's C compiler.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <cstring>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "host/core/error.h"
#include "host/core/grid.h"
#include "host/io/header_export.h"
#include "host/io/table_io.h"
#include "host/lookup/lookup.h"
#include "host/spec/spec.h"

using namespace brdftab;

namespace {

// ---- independent oracle of the critical warp (light from inside) ---------
struct CriticalOracle {
    double lo, hi;      // mu range, within [-1, 0]
    std::size_t n, kc;  // nodes, kink node
    double q;           // grading of both sides
    double tc() const { return double(kc) / double(n - 1); }
    double kink(double eta) const {
        const double xc = -std::cos(std::asin(1.0 / eta));
        const double span = hi - lo, side = 1.0 / 16;
        return std::min(std::max(xc, lo + side * tc() * span), hi - side * (1 - tc()) * span);
    }
    double x(double t, double eta) const {
        const double xc = kink(eta);
        if (t <= tc()) return xc - (xc - lo) * std::pow((tc() - t) / tc(), q);
        return xc + (hi - xc) * std::pow((t - tc()) / (1 - tc()), q);
    }
    double t(double x, double eta) const {
        const double xc = kink(eta);
        if (x <= xc) return tc() * (1 - std::pow((xc - x) / (xc - lo), 1 / q));
        return tc() + (1 - tc()) * std::pow((x - xc) / (hi - xc), 1 / q);
    }
};

// A function with a kink on mu_c(eta), like Fresnel's reflectance from inside:
// constant (total internal reflection) above the kink, rising like
// sqrt(mu_c - mu) below it; smooth in eta.
double kinked(double mu, double eta) {
    const double mc = std::cos(std::asin(1.0 / eta));
    return mu >= -mc ? 1.0 : 1.0 - 0.5 * std::sqrt(-mc - mu) * (1 + 0.1 * eta);
}

TableData critical_table(const CriticalOracle& o, const Axis& eta,
                         const std::function<double(double, double)>& f) {
    TableData t;
    t.name = "albedo_r_inside";
    t.model = "test";
    t.quantity = "albedo_r";
    t.units = "1";
    t.axes = {make_critical_axis("mu_i", o.lo, o.hi, o.n, o.kc, o.q, 0.0, "eta"), eta};
    t.value.resize(o.n * eta.count);
    for (std::size_t i = 0; i < o.n; ++i)
        for (std::size_t j = 0; j < eta.count; ++j)
            t.value[i * eta.count + j] =
                f(o.x(double(i) / double(o.n - 1), eta.values[j]), eta.values[j]);
    return t;
}

// Bilinear interpolation in (t_mu at the point's eta, t_eta = log-spaced).
double oracle_interp(const CriticalOracle& o, const Axis& eta, const TableData& t, double mu,
                     double e) {
    const double te = std::log(e / eta.min) / std::log(eta.max / eta.min) * double(eta.count - 1);
    const double tm = o.t(mu, e) * double(o.n - 1);
    const std::size_t je = std::min<std::size_t>(std::size_t(te), eta.count - 2);
    const std::size_t im = std::min<std::size_t>(std::size_t(tm), o.n - 2);
    const double se = te - double(je), sm = tm - double(im);
    auto v = [&](std::size_t i, std::size_t j) { return t.value[i * eta.count + j]; };
    return (1 - sm) * ((1 - se) * v(im, je) + se * v(im, je + 1)) +
           sm * ((1 - se) * v(im + 1, je) + se * v(im + 1, je + 1));
}

}  // namespace

TEST_CASE("critical axis: nodes exact, between nodes the (t, eta) interpolation") {
    const CriticalOracle o{-1.0, -0.02, 17, 8, 2.0};
    const Axis eta = make_axis("eta", "1", 1.0, 3.0, 9, Spacing::Log);
    const TableData t = critical_table(o, eta, kinked);
    const LookupTable lt(t);
    // Nodes: the value stored there (the oracle places them independently).
    for (std::size_t i = 0; i < o.n; ++i)
        for (std::size_t j = 0; j < eta.count; ++j) {
            const double mu = o.x(double(i) / double(o.n - 1), eta.values[j]);
            CHECK(lt.eval({mu, eta.values[j]}) ==
                  doctest::Approx(t.value[i * eta.count + j]).epsilon(1e-12));
        }
    // Off the nodes: the independent bilinear interpolation.
    for (double e : {1.0, 1.03, 1.31, 1.5, 2.2, 2.99})
        for (double mu : {-0.999, -0.9, -0.75, -0.52, -0.3, -0.1, -0.021}) {
            const double want = oracle_interp(o, eta, t, mu, e);
            CHECK(lt.eval({mu, e}) == doctest::Approx(want).epsilon(1e-12));
        }
    // On the kink line itself, between eta nodes, the table is exact: both
    // neighbouring eta columns have their kink on the same node.
    for (double e : {1.2, 1.7, 2.5}) {
        const double mc = -std::cos(std::asin(1.0 / e));
        CHECK(lt.eval({mc, e}) == doctest::Approx(1.0).epsilon(1e-12));
    }
    // Direction-level lookup is refused with a reason, eval still works.
    CHECK_THROWS_AS(lt.bind({{"eta", 1.5}}), InputError);
}

TEST_CASE("critical axis: a function piecewise linear in (t, log eta) is reproduced exactly") {
    const CriticalOracle o{-1.0, -0.02, 12, 5, 1.5};
    const Axis eta = make_axis("eta", "1", 1.1, 2.5, 6, Spacing::Log);
    // g(t, s) = |t - t_c| * (1 + s) + s with s = t_eta: linear in s, and in t
    // on each side of the kink node.
    auto g = [&](double mu, double e) {
        const double s = std::log(e / 1.1) / std::log(2.5 / 1.1);
        return std::fabs(o.t(mu, e) - o.tc()) * (1 + s) + s;
    };
    const LookupTable lt(critical_table(o, eta, g));
    for (double e : {1.1, 1.25, 1.6, 2.0, 2.5})
        for (double mu = -1.0; mu <= -0.02; mu += 0.0613)
            CHECK(lt.eval({mu, e}) == doctest::Approx(g(mu, e)).epsilon(1e-11));
}

TEST_CASE("critical and log-complement axes survive the file and are looked up alike") {
    const std::string path = std::string(BT_BINARY_DIR) + "/test_lookup_warps.h5";
    const CriticalOracle o{-1.0, -0.02, 17, 8, 2.0};
    const Axis eta = make_axis("eta", "1", 1.0, 3.0, 9, Spacing::Log);
    TableData t = critical_table(o, eta, kinked);
    t.stored_type = StoredType::Float64;
    // A fixed-eta critical axis (positions in the node list) and a
    // log-complement axis.
    TableData f;
    f.name = "fixed";
    f.model = "test";
    f.quantity = "albedo_r";
    f.units = "1";
    f.stored_type = StoredType::Float64;
    f.axes = {make_critical_axis("mu_i", -1.0, -0.02, 9, 4, 2.0, 1.5),
              make_log_complement_axis("c", "1", 0.0, 0.999, 7, 1.0)};
    for (double x : f.axes[0].values)
        for (double c : f.axes[1].values) f.value.push_back(kinked(x, 1.5) * std::sqrt(1 - c));
    write_tables(path, {t, f});

    const TableData back = TableReader(path).read("albedo_r_inside");
    REQUIRE(back.axes.size() == 2);
    const Axis& mu = back.axes[0];
    CHECK(mu.spacing == Spacing::Critical);
    CHECK(mu.depends_on == "eta");
    CHECK(mu.critical_node == 8);
    CHECK(mu.grading == 2.0);
    CHECK(mu.min == -1.0);
    CHECK(mu.max == -0.02);
    const LookupTable mem(t), file = LookupTable::open(path, "albedo_r_inside");
    for (double e : {1.0, 1.4, 2.9})
        for (double x : {-0.97, -0.6, -0.33, -0.05}) {
            CHECK(file.eval({x, e}) == mem.eval({x, e}));
            CHECK(file.eval({x, e}, Interpolation::Cubic) == mem.eval({x, e}, Interpolation::Cubic));
        }

    const LookupTable lf = LookupTable::open(path, "fixed");
    const Axis& fm = lf.axes()[0];
    const Axis& fc = lf.axes()[1];
    CHECK(fm.spacing == Spacing::Critical);
    CHECK_FALSE(fm.dependent());
    CHECK(fm.critical_eta == 1.5);
    CHECK(fm.values[4] == doctest::Approx(-std::cos(std::asin(1 / 1.5))).epsilon(1e-14));
    CHECK(fc.spacing == Spacing::LogComplement);
    CHECK(fc.pivot == 1.0);
    // Between nodes of the log-complement axis: linear in log(1 - c).
    const double c0 = fc.values[2], c1 = fc.values[3];
    const double cm = 1 - std::sqrt((1 - c0) * (1 - c1));  // halfway in log(1 - c)
    const double mu_node = fm.values[6];
    const double want = 0.5 * (kinked(mu_node, 1.5) * std::sqrt(1 - c0) +
                               kinked(mu_node, 1.5) * std::sqrt(1 - c1));
    CHECK(lf.eval({mu_node, cm}) == doctest::Approx(want).epsilon(1e-12));
    std::remove(path.c_str());
}

TEST_CASE("spec: critical axes take eta from the eta axis or the fixed eta") {
    const std::string head = R"(model = "rough-dielectric"
[parameters]
distribution = "ggx"
)";
    const std::string mu_axis = R"(
[[tables.axes]]
name = "mu_i"
range = [-1.0, -0.02]
count = 16
spacing = "critical"
critical_fraction = 0.4
grading = 2
)";
    {
        const Spec s = parse_spec_string(head + R"([[tables]]
quantity = "albedo_r"
)" + mu_axis + R"(
[[tables.axes]]
name = "alpha"
range = [0.01, 1.0]
count = 4
[[tables.axes]]
name = "eta"
range = [1.0, 3.0]
count = 5
)",
                                         "crit.toml");
        const Axis& a = s.tables.at(0).axes.at(0);
        CHECK(a.spacing == Spacing::Critical);
        CHECK(a.depends_on == "eta");
        CHECK(a.critical_node == 6);  // round(0.4 * 15)
        CHECK(a.grading == 2.0);
    }
    {
        const Spec s = parse_spec_string(head + "eta = 1.33\nalpha = 0.1\n[[tables]]\nquantity = \"albedo_r\"\n" +
                                             mu_axis,
                                         "crit.toml");
        const Axis& a = s.tables.at(0).axes.at(0);
        CHECK_FALSE(a.dependent());
        CHECK(a.critical_eta == 1.33);
        CHECK(a.values[6] == doctest::Approx(-std::cos(std::asin(1 / 1.33))).epsilon(1e-14));
    }
    // Wrong axis, wrong keys, bad values: errors naming the key.
    auto fails = [&](const std::string& text, const std::string& needle) {
        try {
            parse_spec_string(text, "bad.toml");
            FAIL("accepted: " << text);
        } catch (const InputError& e) {
            CHECK_MESSAGE(std::string(e.what()).find(needle) != std::string::npos, std::string(e.what()));
        }
    };
    fails(head + "eta = 1.5\nalpha = 0.1\ntheta_o = 10\n[[tables]]\nquantity = \"brdf\"\n"
                 "[[tables.axes]]\nname = \"theta_i\"\nrange = [0, 80]\ncount = 8\n"
                 "spacing = \"critical\"\n",
          "mu_i or mu_o");
    fails(head + "eta = 1.5\nalpha = 0.1\n[[tables]]\nquantity = \"albedo_r\"\n"
                 "[[tables.axes]]\nname = \"mu_i\"\nrange = [0.1, 1]\ncount = 8\ngrading = 2\n",
          "only allowed with spacing = \"critical\"");
    fails(head + "eta = 1.5\nalpha = 0.1\n[[tables]]\nquantity = \"albedo_r\"\n"
                 "[[tables.axes]]\nname = \"mu_i\"\nrange = [-1, 0.5]\ncount = 8\n"
                 "spacing = \"critical\"\n",
          "within [-1, 0]");
    fails(head + "eta = 1.5\nalpha = 0.1\n[[tables]]\nquantity = \"albedo_r\"\n"
                 "[[tables.axes]]\nname = \"mu_i\"\nrange = [0.1, 1]\ncount = 8\n"
                 "spacing = \"critical\"\ngrading = 7\n",
          "tables[0].axes[0].grading");
    fails(head + "eta = 1.5\nmu_i = 0.5\n[[tables]]\nquantity = \"albedo_r\"\n"
                 "[[tables.axes]]\nname = \"alpha\"\nrange = [0.1, 1]\ncount = 8\n"
                 "spacing = \"log-complement\"\npivot = 0.5\n",
          "pivot");
}

TEST_CASE("C header export: log-complement inverted exactly, critical refused") {
    // Refusal first: no file is written.
    const CriticalOracle o{-1.0, -0.02, 9, 4, 2.0};
    const Axis eta = make_axis("eta", "1", 1.0, 3.0, 5, Spacing::Log);
    const std::string dir = std::string(BT_BINARY_DIR);
    const std::string refused = dir + "/test_warps_refused.h";
    std::remove(refused.c_str());
    try {
        export_c_header(critical_table(o, eta, kinked), refused, {});
        FAIL("critical axis exported");
    } catch (const InputError& e) {
        CHECK(std::string(e.what()).find("critical") != std::string::npos);
    }
    CHECK_FALSE(std::ifstream(refused).good());

    TableData t;
    t.name = "kd";
    t.model = "test";
    t.quantity = "albedo";
    t.units = "1";
    t.axes = {make_log_complement_axis("c", "1", 0.0, 0.9999, 13, 1.0),
              make_axis("x", "1", 0.0, 1.0, 3, Spacing::Linear)};
    for (double c : t.axes[0].values)
        for (double x : t.axes[1].values) t.value.push_back(std::sqrt(1 - c) + 0.25 * x);
    const std::string header = dir + "/test_warps_kd.h";
    HeaderExportOptions opt;
    opt.type = HeaderValueType::Float;
    export_c_header(t, header, opt);
    const LookupTable lt(t);
    const std::vector<double> cs = {0.0, 0.3, 0.77, 0.95, 0.9991, 0.99985, 0.9999};
    const std::string prog = dir + "/test_warps_kd.c", exe = dir + "/test_warps_kd";
    {
        std::ofstream c(prog);
        c << "#include <stdio.h>\n#include \"test_warps_kd.h\"\nint main(void) {\n"
             "  const double cs[] = {";
        for (double v : cs) c << v << ",";
        c << "};\n  for (int i = 0; i < " << cs.size()
          << "; ++i) { double x[2] = {cs[i], 0.4}; printf(\"%.17g\\n\", kd_eval(x)); }\n"
             "  return 0;\n}\n";
    }
    const char* cc = std::getenv("CC");
    const std::string compiler = cc && *cc ? cc : "cc";
    const std::string cmd = compiler + " -std=c99 -Wall -Werror -I" + dir + " " + prog + " -o " +
                            exe + " -lm 2>/dev/null && " + exe + " > " + exe + ".out";
    if (std::system(cmd.c_str()) != 0) {
        MESSAGE("no working C compiler ('" << compiler << "'): header not compiled");
        return;
    }
    std::ifstream in(exe + ".out");
    for (double c : cs) {
        double got = 0;
        in >> got;
        REQUIRE(static_cast<bool>(in));
        // Float storage: node values rounded to float (relative 2^-24).
        CHECK(got == doctest::Approx(lt.eval({c, 0.4})).epsilon(1e-6));
    }
    for (const std::string& p : {header, prog, exe, exe + ".out"}) std::remove(p.c_str());
}

TEST_CASE("C header export: the lookup equals the library's linear eval bit for bit") {
    // Every spacing the header implements, values exactly representable as
    // float: a float header then stores them exactly, and its lookup (the
    // prepared inverse-warp constants, the explicit node index, the corner
    // contraction) must reproduce LookupTable::eval with clamping exactly.
    TableData t;
    t.name = "allwarps";
    t.model = "test";
    t.quantity = "albedo";
    t.units = "1";
    t.axes = {make_axis("theta", "deg", 0, 90, 6, Spacing::Cos),
              make_axis("alpha", "1", 0.05, 1, 4, Spacing::Log),
              make_axis("b", "1", 0, 2, 4, Spacing::Quadratic),
              make_axis("e", "1", 0, 1, 5, Spacing::Explicit, {0, 0.02, 0.1, 0.5, 1}),
              make_log_complement_axis("c", "1", 0, 0.99, 5, 1.0),
              make_axis("g", "1", -1, 1, 3, Spacing::Linear)};
    std::mt19937_64 rng(12);
    std::uniform_real_distribution<double> U(0, 1);
    t.value.resize(checked_cell_count(t.axes));
    for (double& v : t.value) v = double(float(4 * U(rng) - 1));
    const std::string dir = std::string(BT_BINARY_DIR);
    const std::string header = dir + "/test_warps_all.h";
    HeaderExportOptions opt;
    opt.type = HeaderValueType::Float;
    export_c_header(t, header, opt);
    const LookupTable lt(t);
    // Random points, some outside the ranges (clamped), some on nodes.
    std::vector<std::vector<double>> pts;
    for (int n = 0; n < 400; ++n) {
        std::vector<double> x;
        for (const Axis& a : t.axes) {
            const double w = a.max - a.min;
            x.push_back(n % 7 == 0 ? a.values[std::size_t(U(rng) * double(a.count)) % a.count]
                                   : a.min - 0.05 * w + 1.1 * w * U(rng));
        }
        pts.push_back(x);
    }
    const std::string prog = dir + "/test_warps_all.c", exe = dir + "/test_warps_all";
    {
        std::ofstream c(prog);
        c << "#include <stdio.h>\n#include \"test_warps_all.h\"\nstatic const double p[][6] = {\n";
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
             " printf(\"%a\\n\", allwarps_eval(p[i]));\n  return 0;\n}\n";
    }
    const char* cc = std::getenv("CC");
    const std::string compiler = cc && *cc ? cc : "cc";
    const std::string cmd = compiler + " -std=c99 -Wall -Wextra -Werror -I" + dir + " " + prog +
                            " -o " + exe + " -lm 2>" + exe + ".err && " + exe + " > " + exe + ".out";
    if (std::system(cmd.c_str()) != 0) {
        std::ifstream err(exe + ".err");
        const std::string text((std::istreambuf_iterator<char>(err)), {});
        // A compiler that exists but rejects the header is a failure.
        CHECK_MESSAGE(text.find("allwarps") == std::string::npos, text);
        MESSAGE("no working C compiler ('" << compiler << "'): header not compiled");
        return;
    }
    std::ifstream in(exe + ".out");
    int mismatches = 0;
    for (const auto& x : pts) {
        std::string line;
        REQUIRE(static_cast<bool>(std::getline(in, line)));
        const double got = std::strtod(line.c_str(), nullptr), want = lt.eval(x);
        if (std::memcmp(&got, &want, sizeof got) != 0) ++mismatches;
    }
    CHECK(mismatches == 0);
    for (const std::string& p : {header, prog, exe, exe + ".out", exe + ".err"})
        std::remove(p.c_str());
}
