// generate_tables: spec -> tables, cell coordinates, provenance, file round trip.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>

#include "generate.h"
#include "spec.h"
#include "table_io.h"

using namespace brdftab;

namespace {

const char* kSpec = R"(
model = "rough-dielectric"
[parameters]
distribution = "beckmann"
eta = 1.5
[[axes]]
name = "mu_i"
range = [0.2, 1.0]
count = 3
[[axes]]
name = "theta_o"
range = [0.0, 180.0]
count = 5
[[axes]]
name = "alpha"
range = [0.1, 0.4]
count = 2
spacing = "log"
[[tables]]
name = "f"
quantity = "bsdf"
[integration]
seed = 11
[output]
type = "float64"
)";

}  // namespace

TEST_CASE("cell points follow the axes (mu -> theta, phi defaults, parameters)") {
    Spec spec = parse_spec_string(kSpec, "mem.toml");
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
    CHECK(p[2] == doctest::Approx(45.0 * 3.14159265358979323846 / 180));
    cp.point(29, p.data());
    CHECK(p[0] == doctest::Approx(0.0).epsilon(1e-12));  // mu = 1
    CHECK(p[2] == doctest::Approx(3.14159265358979323846));
}

TEST_CASE("generated table equals direct evaluation and round-trips through HDF5") {
    Spec spec = parse_spec_string(kSpec, "mem.toml");
    auto device = make_backend("", Precision::Double);
    auto tables = generate_tables(spec, *device, spec.integration);
    REQUIRE(tables.size() == 1);
    const TableData& d = tables[0].data;
    CHECK(d.method == "closed-form");
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
    CHECK(d.method == "mc");
    REQUIRE(d.samples.size() == 6);
    for (std::size_t c = 0; c < 6; ++c) {
        CHECK(d.samples[c] >= 2000);
        CHECK(d.stderr_[c] > 0);
        CHECK(d.stderr_[c] < 0.1 * d.value[c]);
    }
    CHECK(d.total_samples >= 6 * 2000);
}

TEST_CASE("recombined tables: values at stored_at and the recipe for the lookup") {
    Spec spec = parse_spec_string(R"(
model = "rough-dielectric"
[parameters]
alpha = 0.4
eta = 1.5
[[axes]]
name = "theta_i"
range = [0.0, 60.0]
count = 3
[[axes]]
name = "theta_o"
range = [0.0, 170.0]
count = 4
[[tables]]
quantity = "brdf"
[[tables]]
quantity = "btdf"
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
    CHECK(m.method == "recombined");
    // At w = 0.5: (1 + 2 w) brdf + 4 w^2 btdf = 2 brdf + btdf.
    for (std::size_t c = 0; c < m.value.size(); ++c)
        CHECK(m.value[c] == doctest::Approx(2 * r.value[c] + t.value[c]).epsilon(1e-14));
    const auto& recipe = m.parameters.at("recombine");
    CHECK(recipe.at("parameter") == "w");
    CHECK(recipe.at("terms").size() == 2);
    CHECK(recipe.at("terms")[1].at("table") == "btdf");
}
