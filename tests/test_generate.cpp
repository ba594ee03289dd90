// generate_tables: spec -> tables, cell coordinates, provenance, file round trip.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "host/core/error.h"
#include "host/generate/generate.h"
#include "host/spec/spec.h"
#include "host/io/table_io.h"
#include "test_support.h"
#include "kernels/common/sampler.h"  // bt_sampler: the test calls a host sample function

using namespace brdftab;

TEST_CASE("cell points follow the axes (mu -> theta, phi defaults, parameters)") {
    Spec spec = parse_spec_string(test::fixture_text("rough_dielectric_bsdf_mu.toml"), "mem.toml");
    const ModelInfo& model = find_model("rough-dielectric");
    const TableSpec& t = spec.tables.at(0);
    CellPoints cp(model, model.quantity("bsdf"), t);
    REQUIRE(cp.cell_count() == 3 * 5 * 2);
    std::vector<double> p(model.point_stride());
    // Last axis fastest: cell 0 = (mu 0.2, theta_o 0, alpha 0.1); cell 1 = alpha 0.4;
    // cell 2 = theta_o 45.
    cp.point(0, p.data());
    CHECK(p[0] == doctest::Approx(std::acos(0.2)));
    CHECK(p[1] == 0.0);
    CHECK(p[2] == 0.0);
    CHECK(p[4] == doctest::Approx(0.1));
    CHECK(p[5] == doctest::Approx(1.5));
    cp.point(1, p.data());
    CHECK(p[4] == doctest::Approx(0.4));
    cp.point(2, p.data());
    CHECK(p[2] == doctest::Approx(45.0 * test::kDeg));
    cp.point(29, p.data());
    CHECK(p[0] == doctest::Approx(0.0).epsilon(1e-12));  // mu = 1
    CHECK(p[2] == doctest::Approx(test::kPi));
}

TEST_CASE("CellPoints::points gives point()'s values for every span") {
    // Oracle: point(), cell by cell (divisions from the cell number), against
    // the span form's stepped multi-index, over spans that start and end
    // anywhere, so every axis wraps inside some span; mu_i (acos), degrees
    // and phi_d (phi_o from phi_i + phi_d) feeds.
    const ModelInfo& model = find_model("rough-dielectric");
    Spec mu = parse_spec_string(test::fixture_text("rough_dielectric_bsdf_mu.toml"), "mem.toml");
    Spec phi = parse_spec_string(R"(
model = "rough-dielectric"
[parameters]
eta = 1.5
[[axes]]
name = "theta_i"
range = [0, 80]
count = 3
[[axes]]
name = "phi_d"
range = [0, 180]
count = 4
[[axes]]
name = "alpha"
range = [0.1, 0.9]
count = 2
[[tables]]
name = "f"
quantity = "bsdf"
[tables.parameters]
theta_o = 40
)",
                                 "mem.toml");
    for (const Spec* spec : {&mu, &phi}) {
        CellPoints cp(model, model.quantity("bsdf"), spec->tables.at(0));
        const std::size_t n = cp.cell_count(), stride = model.point_stride();
        std::vector<double> one(n * stride);
        for (std::size_t c = 0; c < n; ++c) cp.point(c, &one[c * stride]);
        for (std::size_t first = 0; first < n; ++first) {
            for (std::size_t count = 0; first + count <= n; count += 7) {
                CAPTURE(first);
                CAPTURE(count);
                std::vector<double> span(count * stride, -99.0);
                cp.points(first, count, span.data());
                CHECK(std::equal(span.begin(), span.end(), one.begin() + first * stride));
            }
        }
    }
}

TEST_CASE("generated table equals direct evaluation and round-trips through HDF5") {
    Spec spec = parse_spec_string(test::fixture_text("rough_dielectric_bsdf_mu.toml"), "mem.toml");
    auto device = make_backend("", Precision::Double);
    auto tables = generate_tables(spec, *device, spec.integration);
    REQUIRE(tables.size() == 1);
    const TableData& d = tables[0].data;
    CHECK(d.method == Method::ClosedForm);
    CHECK(d.parameters["distribution"] == "beckmann");
    CHECK(d.parameters["eta"] == 1.5);
    CHECK(d.seed == 11);
    // Oracle: the host reference evaluated cell by cell through the registry.
    const ModelInfo& model = find_model("rough-dielectric");
    CellPoints cp(model, model.quantity("bsdf"), spec.tables[0]);
    std::vector<int> opts = resolve_options(model, spec.tables[0].options, "test");
    std::vector<double> p(model.point_stride());
    for (std::size_t c = 0; c < cp.cell_count(); ++c) {
        cp.point(c, p.data());
        bt_sampler s{0, 0, static_cast<uint>(c), 0, 0, BT_METHOD_CLOSED};
        const double expected = model.host_fn(p.data(), opts.data(), model.quantity("bsdf").id, &s);
        CAPTURE(c);
        CHECK(d.value[c] == doctest::Approx(expected).epsilon(1e-10));
    }
    const std::string path =
        (std::filesystem::temp_directory_path() / "brdftab_test_generate.h5").string();
    write_tables(path, {d});
    TableData back = read_table(path, "f");
    CHECK(back.value == d.value);
    CHECK(back.axes.size() == 3);
    CHECK(back.axes[0].name == "mu_i");
    CHECK(back.parameters == d.parameters);
    std::remove(path.c_str());
}

TEST_CASE("integral tables carry samples and standard errors") {
    Spec spec = parse_spec_string(R"(
model = "rough-dielectric"
[parameters]
eta = 1.33
[[axes]]
name = "theta_i"
range = [0.0, 60.0]
count = 3
[[axes]]
name = "alpha"
range = [0.2, 0.6]
count = 2
[[tables]]
quantity = "albedo_r"
[integration]
method = "mc"
samples = 2000
)",
                                  "mem.toml");
    auto device = make_backend("", Precision::Double);
    auto tables = generate_tables(spec, *device, spec.integration);
    const TableData& d = tables[0].data;
    CHECK(d.method == Method::MonteCarlo);
    REQUIRE(d.samples.size() == 6);
    for (std::size_t c = 0; c < 6; ++c) {
        CHECK(d.samples[c] >= 2000);
        CHECK(d.stderr_[c] > 0);
        CHECK(d.stderr_[c] < 0.1 * d.value[c]);
    }
    CHECK(d.total_samples >= 6 * 2000);
}

// brdf and btdf of one rough dielectric on a 3 x 4 grid (theta_o crosses the
// horizon): the sources of the derived-table cases.
std::string brdf_btdf() { return test::fixture_text("rough_dielectric_brdf_btdf.toml"); }

TEST_CASE("recombined tables: values at stored_at and the recipe for the lookup") {
    Spec spec = parse_spec_string(brdf_btdf() + R"(
[[recombined]]
name = "mix"
parameter = "w"
stored_at = 0.5
[[recombined.terms]]
table = "brdf"
coeffs = [1.0, 2.0]
[[recombined.terms]]
table = "btdf"
coeffs = [0.0, 0.0, 4.0]
)",
                                  "mem.toml");
    auto device = make_backend("", Precision::Double);
    auto tables = generate_tables(spec, *device, spec.integration);
    REQUIRE(tables.size() == 3);
    const TableData& r = tables[0].data;
    const TableData& t = tables[1].data;
    const TableData& m = tables[2].data;
    CHECK(m.name == "mix");
    CHECK(m.kind == TableKind::Recombined);
    // At w = 0.5: (1 + 2 w) brdf + 4 w^2 btdf = 2 brdf + btdf.
    for (std::size_t c = 0; c < m.value.size(); ++c)
        CHECK(m.value[c] == doctest::Approx(2 * r.value[c] + t.value[c]).epsilon(1e-14));
    const auto& recipe = m.parameters.at("recombine");
    CHECK(recipe.at("parameter") == "w");
    CHECK(recipe.at("terms").size() == 2);
    CHECK(recipe.at("terms")[1].at("table") == "btdf");
}

TEST_CASE("error tables: known errors by construction; the reference 0 needs a floor") {
    const std::string base = brdf_btdf() + R"(
[[recombined]]
name = "twice"
parameter = "w"
[[recombined.terms]]
table = "brdf"
coeffs = [2.0]
[[recombined]]
name = "sum"
parameter = "w"
[[recombined.terms]]
table = "brdf"
coeffs = [1.0]
[[recombined.terms]]
table = "btdf"
coeffs = [1.0]
)";
    auto device = make_backend("", Precision::Double);
    Spec spec = parse_spec_string(base + R"(
[[errors]]
name = "rel"
table = "twice"
reference = "brdf"
by = "theta_i"
[[errors]]
name = "abs"
table = "sum"
reference = "brdf"
measure = "absolute"
)",
                                  "mem.toml");
    auto tables = generate_tables(spec, *device, spec.integration);
    REQUIRE(tables.size() == 6);
    const TableData& brdf = tables[0].data;
    const TableData& btdf = tables[1].data;
    const GeneratedTable& rel = tables[4];
    const GeneratedTable& abs = tables[5];
    REQUIRE(rel.error.has_value());
    CHECK(rel.data.kind == TableKind::Error);
    CHECK(rel.data.units == "1");
    CHECK(abs.data.units == brdf.units);
    // 2 f against f: relative error exactly 1 where f > 0 (theta_o < 90), and
    // 0 where both are 0 (theta_o > 90: the brdf is zero below the horizon).
    std::size_t positive = 0;
    for (std::size_t c = 0; c < brdf.value.size(); ++c) {
        CAPTURE(c);
        if (brdf.value[c] > 0) {
            ++positive;
            CHECK(rel.data.value[c] == doctest::Approx(1.0).epsilon(1e-14));
        } else {
            CHECK(rel.data.value[c] == 0.0);
        }
        // (f + t) - f = t, the btdf.
        CHECK(abs.data.value[c] == doctest::Approx(btdf.value[c]).epsilon(1e-12).scale(1e-300));
    }
    REQUIRE(positive > 0);
    const ErrorSummary& s = *rel.error;
    CHECK(s.max_abs == doctest::Approx(1.0));
    CHECK(s.rms == doctest::Approx(std::sqrt(double(positive) / brdf.value.size())));
    CHECK(s.beyond_2sigma == positive);  // closed forms: no noise, every error is significant
    REQUIRE(s.worst.size() == 2);
    CHECK(s.worst[1] < 90);  // the worst cell is one where the brdf is positive
    REQUIRE(s.by_nodes.size() == 3);
    for (const auto& n : s.by_nodes) CHECK(n.max_abs == doctest::Approx(1.0));
    CHECK(rel.data.parameters.at("comparison").at("reference") == "brdf");
    CHECK(rel.data.parameters.at("comparison").at("by_nodes").size() == 3);

    // (f + t) / f - 1 is undefined where f = 0 < t: a clear error, no table.
    Spec bad = parse_spec_string(base + R"(
[[errors]]
name = "rel_sum"
table = "sum"
reference = "brdf"
)",
                                 "bad.toml");
    try {
        generate_tables(bad, *device, bad.integration);
        FAIL("no error for a zero reference");
    } catch (const InputError& e) {
        const std::string m = e.what();
        CAPTURE(m);
        CHECK(m.find("bad.toml: errors table 'rel_sum'") == 0);
        CHECK(m.find("floor") != std::string::npos);
        CHECK(m.find("theta_o = ") != std::string::npos);
    }
    // With a floor the denominator is max(|f|, floor).
    Spec floored = parse_spec_string(base + R"(
[[errors]]
name = "rel_sum"
table = "sum"
reference = "brdf"
floor = 0.5
)",
                                     "floor.toml");
    auto ft = generate_tables(floored, *device, floored.integration);
    const TableData& fe = ft.back().data;
    for (std::size_t c = 0; c < brdf.value.size(); ++c)
        CHECK(fe.value[c] == doctest::Approx(btdf.value[c] / std::max(brdf.value[c], 0.5)));
}

TEST_CASE("error tables: the propagated standard error covers Monte Carlo noise") {
    // Lambert-sphere order 1: brdf_mc with order = 1 is an unbiased Monte Carlo
    // estimate of eq. 10, which brdf_single gives in closed form.  The relative
    // error must be consistent with zero within its propagated standard error,
    // whichever of the two is the reference.
    Spec spec = parse_spec_string(test::fixture_text("lambert_sphere_mc_vs_exact.toml"), "ls.toml");
    auto device = make_backend("", Precision::Double);
    auto tables = generate_tables(spec, *device, spec.integration);
    REQUIRE(tables.size() == 4);
    for (std::size_t k : {2u, 3u}) {
        const GeneratedTable& g = tables[k];
        REQUIRE(g.error.has_value());
        CAPTURE(g.data.name);
        const std::size_t n = g.data.value.size();  // 100 cells
        double chi2 = 0;
        for (std::size_t c = 0; c < n; ++c) {
            REQUIRE(g.data.stderr_[c] > 0);
            const double z = g.data.value[c] / g.data.stderr_[c];
            chi2 += z * z;
        }
        // chi^2 with 100 degrees of freedom: mean 100, sd 14; [55, 160] is
        // beyond 3 sd on either side.
        CHECK(chi2 > 55);
        CHECK(chi2 < 160);
        CHECK(g.error->beyond_2sigma <= 15);  // expected 5 of 100
        CHECK(g.error->max_abs < 0.1);
    }
}

TEST_CASE("inverted tables: the inverse of eq. 40 (kd from c); monotonicity and range errors") {
    // Source: kd_fit (eq. 40) on 201 nodes in c in [0, 0.9].  Oracle: the
    // inverse of eq. 40 by bisection on the formula, written here
    // independently; the table inverts linear interpolation, so they agree to
    // h^2/8 max|kd''| (~1e-5 here; kd'' grows like (1 - c)^(-3/2), so a table
    // reaching c -> 1 needs nodes crowding there).
    auto kd_eq40 = [](double c) {
        const double s = std::sqrt(1 - c);
        return (-0.453029 * (1 - c) - 0.544162 * s + 1) / (1.42931 * s + 1);
    };
    const std::string base = R"(
model = "lambert-sphere"
[[tables]]
name = "kd"
quantity = "kd_fit"
[[tables.axes]]
name = "c"
range = [0.0, 0.9]
count = 201
[[inverted]]
name = "c_of_kd"
table = "kd"
[inverted.axis]
name = "kd"
)";
    auto device = make_backend("host", Precision::Double);
    Spec spec = parse_spec_string(base + "range = [0.01, 0.5]\ncount = 50\n", "inv.toml");
    auto tables = generate_tables(spec, *device, spec.integration);
    REQUIRE(tables.size() == 2);
    const TableData& inv = tables[1].data;
    CHECK(inv.kind == TableKind::Inverted);
    CHECK(inv.units == "1");
    REQUIRE(inv.axes.size() == 1);
    CHECK(inv.axes[0].name == "kd");
    CHECK(inv.parameters.at("inverse_of").at("table") == "kd");
    double worst = 0, worst_kd = 0;
    for (std::size_t k = 0; k < inv.value.size(); ++k) {
        const double target = inv.axes[0].values[k];
        double lo = 0, hi = 0.9;
        for (int it = 0; it < 100; ++it) {
            const double mid = 0.5 * (lo + hi);
            (kd_eq40(mid) < target ? lo : hi) = mid;
        }
        worst = std::max(worst, std::fabs(inv.value[k] - 0.5 * (lo + hi)));
        worst_kd = std::max(worst_kd, std::fabs(kd_eq40(inv.value[k]) - target));
    }
    MESSAGE("inverse of eq. 40: max |c - c_exact| = " << worst << ", max |kd(c) - kd| = " << worst_kd);
    CHECK(worst < 3e-5);
    CHECK(worst_kd < 3e-5);
    // Not monotone: rough-dielectric's brdf along theta_o peaks at the mirror
    // direction.
    Spec bumpy = parse_spec_string(R"(
model = "rough-dielectric"
[parameters]
alpha = 0.2
eta = 1.5
theta_i = 30.0
[[tables]]
quantity = "brdf"
[[tables.axes]]
name = "theta_o"
range = [0.0, 80.0]
count = 9
[[inverted]]
name = "inv"
table = "brdf"
[inverted.axis]
name = "f"
range = [0.1, 0.2]
count = 3
)",
                                   "bumpy.toml");
    CHECK_THROWS_WITH_AS(generate_tables(bumpy, *device, bumpy.integration),
                         doctest::Contains("is not strictly monotone along 'theta_o'"), InputError);
    // An axis beyond the source's values.
    Spec wide = parse_spec_string(base + "range = [0.01, 0.9]\ncount = 5\n", "wide.toml");
    CHECK_THROWS_WITH_AS(generate_tables(wide, *device, wide.integration),
                         doctest::Contains("outside the values of 'kd'"), InputError);
}

TEST_CASE("inverted tables: standard error sigma_x = sigma_y / |dy/dx| from a Monte Carlo source") {
    Spec spec = parse_spec_string(R"(
model = "lambert-sphere"
[[tables]]
name = "kd"
quantity = "kd_mc"
[[tables.axes]]
name = "c"
range = [0.2, 0.8]
count = 4
[[inverted]]
name = "c_of_kd"
table = "kd"
[inverted.axis]
name = "kd"
range = [0.1, 0.3]
count = 3
[integration]
samples = 20000
)",
                                  "mcinv.toml");
    auto device = make_backend("", Precision::Double);
    auto tables = generate_tables(spec, *device, spec.integration);
    const TableData& src = tables[0].data;
    const TableData& inv = tables[1].data;
    REQUIRE(inv.stderr_.size() == 3);
    for (std::size_t k = 0; k < 3; ++k) {
        // The segment of the target, found here directly.
        const double y = inv.axes[0].values[k];
        std::size_t j = 0;
        while (j + 2 < src.value.size() && y > src.value[j + 1]) ++j;
        const double f = (y - src.value[j]) / (src.value[j + 1] - src.value[j]);
        const double x = src.axes[0].values[j] + f * (src.axes[0].values[j + 1] - src.axes[0].values[j]);
        const double slope = (src.value[j + 1] - src.value[j]) / 0.2;
        const double sy = (1 - f) * src.stderr_[j] + f * src.stderr_[j + 1];
        CHECK(inv.value[k] == doctest::Approx(x).epsilon(1e-12));
        CHECK(inv.stderr_[k] == doctest::Approx(sy / slope).epsilon(1e-12));
        CHECK(inv.stderr_[k] > 0);
    }
}

TEST_CASE("resource estimate before computing: cells, disk bytes by hand, memory linear (issue #15)") {
    // A closed-form table (value only) and a Monte Carlo one (value, stderr,
    // samples) on the same 5 x 3 grid, stored as float64: disk is counted by
    // hand from the datasets table_io writes.
    const std::string text =
        "model = \"rough-dielectric\"\n"
        "[parameters]\nalpha = 0.3\ntheta_o = 10\n"
        "[[axes]]\nname = \"theta_i\"\nrange = [0, 80]\ncount = 5\n"
        "[[axes]]\nname = \"eta\"\nrange = [1.2, 1.8]\ncount = 3\n"
        "[[tables]]\nquantity = \"brdf\"\n"
        "[[tables]]\nquantity = \"albedo_r\"\n"
        "[output]\ntype = \"float64\"\n";
    Spec spec = parse_spec_string(text, "mem.toml");
    ResourceEstimate r = estimate_resources(spec, spec.integration);
    CHECK(r.cells == 30);
    CHECK(r.largest_cells == 15);
    // + the checkpoint's 65 B per computed cell (host/generate/checkpoint.cpp).
    CHECK(r.disk_bytes == 15 * 8 + 15 * (8 + 8 + 4) + 30 * 65);
    // float16, no stderr kept: 2 B per value, samples still 4 B.
    spec.output.stored_type = StoredType::Float16;
    spec.output.keep_stderr = false;
    r = estimate_resources(spec, spec.integration);
    CHECK(r.disk_bytes == 15 * 2 + 15 * (2 + 4) + 30 * 65);

    // 65536 x 65535 cells (the issue's bad_alloc): the count does not wrap.
    // (Tables are streamed to the file in chunks: memory stays bounded,
    // test_streaming.cpp.)
    spec.tables[0].axes[0].count = 65536;
    spec.tables[0].axes[1].count = 65535;
    r = estimate_resources(spec, spec.integration);
    CHECK(r.largest_cells == 65536.0 * 65535.0);
    for (auto& a : spec.tables[0].axes) a.count = 65536;
    spec.tables[0].axes.push_back(spec.tables[0].axes[0]);
    spec.tables[0].axes.push_back(spec.tables[0].axes[0]);
    CHECK(estimate_resources(spec, spec.integration).cells > 1.8e19);  // 2^64: no wrap to 0
}
