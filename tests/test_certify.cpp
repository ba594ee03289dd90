// test_certify.cpp — certificates of written tables and the certified
// generation loop (host/plan/certify.h).
//
// Oracles from outside the code under test:
//   - a dense brute-force measurement: the model evaluated directly on a
//     0.5-degree grid over the whole domain (edges included), the table
//     interpolated there by this file's own bilinear interpolation (not the
//     lookup library the certificate uses), the largest relative difference
//     taken.  A certificate must agree with it: not below (its probes must
//     find the worst places) and not above (it must not invent error);
//   - the stored attributes read back with the HDF5 reader;
//   - a loop whose first round is deliberately generated too coarse must
//     fail that round and pass after refinement.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <unistd.h>

#include "host/core/error.h"
#include "host/engine/evaluate.h"
#include "host/generate/generate.h"
#include "host/io/table_io.h"
#include "host/lookup/lookup.h"
#include "host/models/registry.h"
#include "host/plan/certify.h"
#include "host/plan/plan.h"
#include "host/spec/spec.h"

using namespace brdftab;

namespace {

std::string data_path(const std::string& name) { return std::string(BT_SOURCE_DIR) + "/tests/data/" + name; }

std::string temp_path(const std::string& name) {
    const auto dir = std::filesystem::temp_directory_path() / ("bt_test_certify_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    return (dir / name).string();
}

// The spec's tables, computed and written to `path`; returns them as read back.
TableData generate_and_read(const Spec& spec, Backend& backend, const std::string& path) {
    std::vector<GeneratedTable> g = generate_tables(spec, backend, spec.integration);
    std::vector<TableData> data;
    for (auto& t : g) data.push_back(std::move(t.data));
    write_tables(path, data);
    return read_table(path, spec.tables[0].name);
}

// Spec text with every `count = N` replaced.
Spec with_counts(const std::string& file, std::size_t count) {
    std::FILE* f = std::fopen(file.c_str(), "rb");
    REQUIRE(f);
    std::string text;
    char buf[4096];
    for (std::size_t n; (n = std::fread(buf, 1, sizeof buf, f)) > 0;) text.append(buf, n);
    std::fclose(f);
    for (std::size_t pos = 0; (pos = text.find("count = ", pos)) != std::string::npos; pos += 8) {
        const std::size_t end = text.find('\n', pos);
        text.replace(pos + 8, end - pos - 8, std::to_string(count));
    }
    return parse_spec_string(text, file);
}

struct DenseMax {
    double max_rel = 0;
    double at_i = 0, at_o = 0;
};

// Brute force: the closed form on a 0.5-degree grid of (theta_i, theta_o)
// against the table's bilinear interpolation on its linear axes, relative to
// max(|reference|, 1e-3 max|table|) as the certificate measures it.
DenseMax dense_measurement(const TableData& t, Backend& backend) {
    const ModelInfo& model = find_model(t.model);
    const QuantityInfo& q = model.quantity(t.quantity);
    std::vector<std::map<std::string, double>> named;
    const double step = 0.5;
    const std::size_t n = static_cast<std::size_t>(std::lround(80.0 / step)) + 1;
    for (std::size_t i = 0; i < n; ++i)
        for (std::size_t o = 0; o < n; ++o)
            named.push_back({{"theta_i", i * step}, {"theta_o", o * step}, {"alpha", 0.3}, {"eta", 1.5},
                             {"phi_d", 0.0}});
    const std::vector<double> points = build_kernel_points(model, q, named, [](std::size_t) { return "dense"; });
    IntegrationSettings s;
    s.method = Method::ClosedForm;
    const std::vector<int> options = resolve_options(model, nlohmann::json{{"distribution", "ggx"}}, "dense");
    const EstimateResult r = estimate_at(backend, model, q, options, points, s);
    double max_table = 0;
    for (double v : t.value) max_table = std::max(max_table, std::fabs(v));
    const double floor = 1e-3 * max_table;
    const Axis &ai = t.axes[0], &ao = t.axes[1];
    auto bilinear = [&](double x, double y) {
        auto locate = [](const Axis& a, double v, std::size_t& j, double& w) {
            const double u = (v - a.min) / (a.max - a.min) * double(a.count - 1);
            j = std::min<std::size_t>(static_cast<std::size_t>(u), a.count - 2);
            w = u - double(j);
        };
        std::size_t j, k;
        double wj, wk;
        locate(ai, x, j, wj);
        locate(ao, y, k, wk);
        auto v = [&](std::size_t a, std::size_t b) { return t.value[a * ao.count + b]; };
        return (1 - wj) * ((1 - wk) * v(j, k) + wk * v(j, k + 1)) + wj * ((1 - wk) * v(j + 1, k) + wk * v(j + 1, k + 1));
    };
    DenseMax d;
    for (std::size_t p = 0; p < named.size(); ++p) {
        const double x = named[p]["theta_i"], y = named[p]["theta_o"];
        const double e = std::fabs(bilinear(x, y) - r.value[p]) / std::max(std::fabs(r.value[p]), floor);
        if (e > d.max_rel) d = {e, x, y};
    }
    return d;
}

}  // namespace

TEST_CASE("an under-resolved table fails its certificate, and the certificate agrees with brute force") {
    auto backend = make_backend("host", Precision::Double);
    const Spec spec = parse_spec_file(data_path("certify_under_resolved.toml"));
    const TableData t = generate_and_read(spec, *backend, temp_path("under.h5"));
    REQUIRE(t.axes[0].count == 5);
    CertifyOptions o;
    o.target = 1e-2;
    const Certificate c = certify_table(t, *backend, o);
    const DenseMax d = dense_measurement(t, *backend);
    MESSAGE("5x5: certificate max " << c.max_error << " at (" << c.max_at[0] << ", " << c.max_at[1]
                                    << "), brute force max " << d.max_rel << " at (" << d.at_i << ", " << d.at_o
                                    << ")");
    CHECK_FALSE(c.passed);
    CHECK(c.max_error > 10 * o.target);
    // The probes find the worst place within 10 %, and add no error of their own.
    CHECK(c.max_error >= 0.9 * d.max_rel);
    CHECK(c.max_error <= 1.02 * d.max_rel);
    CHECK(c.reference_method == "closed-form");
    CHECK(c.reference_noise == 0);
    CHECK(c.line_probes == 2 * 8 * 4 * 3);  // 2 axes x 8 lines x 4 intervals x 3 fractions
    CHECK(c.random_probes == 1000);
    CHECK(c.local_probes > 0);
    CHECK(c.probes == c.line_probes + c.random_probes + c.local_probes);
}

TEST_CASE("a well-resolved table passes, and brute force confirms it") {
    auto backend = make_backend("host", Precision::Double);
    const Spec spec = with_counts(data_path("certify_under_resolved.toml"), 65);
    const TableData t = generate_and_read(spec, *backend, temp_path("fine.h5"));
    CertifyOptions o;
    o.target = 1e-2;
    const Certificate c = certify_table(t, *backend, o);
    const DenseMax d = dense_measurement(t, *backend);
    MESSAGE("65x65: certificate max " << c.max_error << ", brute force max " << d.max_rel);
    CHECK(c.passed);
    CHECK(d.max_rel <= o.target);
    CHECK(c.max_error >= 0.8 * d.max_rel);
    CHECK(c.max_error <= 1.02 * d.max_rel);
}

TEST_CASE("certificates are stored as attributes and read back") {
    auto backend = make_backend("host", Precision::Double);
    const std::string path = temp_path("attrs.h5");
    const Spec spec = parse_spec_file(data_path("certify_under_resolved.toml"));
    const TableData t = generate_and_read(spec, *backend, path);
    CHECK_FALSE(read_certificate(path, t.name).has_value());
    CertifyOptions o;
    o.target = 0.5;
    o.absolute = true;
    o.interpolation = Interpolation::Cubic;
    Certificate c = certify_table(t, *backend, o);
    c.refinements = 3;
    c.predicted_max = 0.25;
    write_certificate(path, c);
    write_certificate(path, c);  // replaces, does not fail on existing attributes
    const auto back = read_certificate(path, t.name);
    REQUIRE(back.has_value());
    CHECK(back->mode == "accuracy");
    CHECK(back->target == 0.5);
    CHECK(back->absolute);
    CHECK(back->abs_floor == 0);
    CHECK(back->interpolation == Interpolation::Cubic);
    CHECK(back->max_error == c.max_error);
    CHECK(back->rms_error == c.rms_error);
    REQUIRE(back->max_at.size() == 2);
    CHECK(back->max_at[0] == c.max_at[0]);
    CHECK(back->max_at[1] == c.max_at[1]);
    CHECK(back->axis_names == std::vector<std::string>{"theta_i", "theta_o"});
    CHECK(back->probes == c.probes);
    CHECK(back->passed == c.passed);
    CHECK(back->refinements == 3);
    CHECK(back->predicted_max == 0.25);
    // The table itself is untouched by the attributes.
    const TableData again = read_table(path, t.name);
    CHECK(again.value == t.value);
}

TEST_CASE("bad certificate options are input errors") {
    auto backend = make_backend("host", Precision::Double);
    const Spec spec = parse_spec_file(data_path("certify_under_resolved.toml"));
    const TableData t = generate_and_read(spec, *backend, temp_path("bad.h5"));
    for (double e : std::vector<double>{0.0, -1.0, std::nan(""), INFINITY}) {
        CertifyOptions o;
        o.target = e;
        CHECK_THROWS_AS(certify_table(t, *backend, o), InputError);
    }
    CertifiedGenerateOptions g;
    g.target.accuracy = 1e-2;
    g.max_refinements = -1;
    CHECK_THROWS_AS(certified_generate(spec, *backend, g, temp_path("x.h5"), nullptr), InputError);
    g.max_refinements = 1;
    g.target.budget = 1.0;  // both
    CHECK_THROWS_AS(certified_generate(spec, *backend, g, temp_path("x.h5"), nullptr), InputError);
    CHECK_FALSE(std::filesystem::exists(temp_path("x.h5")));
}

TEST_CASE("the loop: a failing first round is refined into a passing one") {
    // The first round is generated on 5 x 5 nodes whatever the plan says (a
    // deliberately under-resolved table); later rounds as planned.  The
    // certificate must fail round 0, the refinement must raise the counts,
    // and round 1 must pass.
    auto backend = make_backend("host", Precision::Double);
    const Spec spec = parse_spec_file(data_path("certify_under_resolved.toml"));
    const std::string path = temp_path("loop.h5");
    CertifiedGenerateOptions g;
    g.target.accuracy = 1e-2;
    g.max_refinements = 2;
    std::vector<std::size_t> generated_counts;
    const GenerateToFn generate = [&](const Spec& planned, const std::string& out, int round) {
        Spec s = planned;
        if (round == 0)
            for (Axis& a : s.tables[0].axes) a = make_axis(a.name, a.unit, a.min, a.max, 5, a.spacing);
        generated_counts.push_back(s.tables[0].axes[0].count);
        generate_and_read(s, *backend, out);
    };
    const CertifiedResult r = certified_generate(spec, *backend, g, path, generate);
    REQUIRE(r.rounds.size() >= 2);
    CHECK_FALSE(r.rounds[0].passed);
    CHECK(r.passed);
    CHECK(r.stop == "passed");
    CHECK(generated_counts.front() == 5);
    // Refinement never lowers a count below the first plan's.
    CHECK(generated_counts.back() >= r.rounds[0].plan.tables[0].counts[0]);
    const auto c = read_certificate(path, "brdf");
    REQUIRE(c.has_value());
    CHECK(c->passed);
    CHECK(c->refinements == static_cast<int>(r.rounds.size()) - 1);
    CHECK(c->max_error <= 1e-2);

    // No refinement allowed: the failed certificate is what the file keeps.
    g.max_refinements = 0;
    const CertifiedResult r0 = certified_generate(spec, *backend, g, path, generate);
    CHECK(r0.rounds.size() == 1);
    CHECK_FALSE(r0.passed);
    CHECK(r0.stop == "max-refinements");
    const auto c0 = read_certificate(path, "brdf");
    REQUIRE(c0.has_value());
    CHECK_FALSE(c0->passed);
    CHECK(c0->refinements == 0);
    CHECK(c0->max_error > 1e-2);
    std::filesystem::remove_all(std::filesystem::path(path).parent_path());
}

TEST_CASE("integrals: node probes measure the integration noise alone, the reference is quiet") {
    // At a node the interpolation error is zero: the difference is the
    // table's own noise plus the reference's (independent seeds) plus
    // rounding (float64 here: none), so it stays within a few combined
    // standard errors.
    auto backend = make_backend("", Precision::Double);
    const Spec spec = parse_spec_file(data_path("rough_dielectric_albedo.toml"));
    const TableData t = generate_and_read(spec, *backend, temp_path("albedo.h5"));
    REQUIRE(!t.stderr_.empty());
    double table_se = 0;
    for (double s : t.stderr_) table_se = std::max(table_se, s);
    CertifyOptions o;
    o.target = 1e-2;
    o.absolute = true;
    const Certificate c = certify_table(t, *backend, o);
    MESSAGE("albedo_r 5x3: max " << c.max_error << ", node max " << c.node_max << ", table stderr max "
                                 << table_se << ", reference noise " << c.reference_noise);
    CHECK(c.node_probes == 64);
    CHECK(c.reference_method != "closed-form");
    CHECK(c.reference_noise > 0);
    CHECK(c.reference_noise <= 0.2 * o.target * 1.001);
    CHECK(c.node_max <= 5 * std::hypot(table_se, c.reference_noise));
    CHECK(c.max_error >= c.node_max);
    std::filesystem::remove_all(std::filesystem::path(temp_path("albedo.h5")).parent_path());
}

TEST_CASE("quadrature tables: the certificate sees the rule's own error (finer reference rule)") {
    // With the table's own rule as reference the node probes would read zero.
    // A 2-node rule is far from converged; the certificate's node probes must
    // show its error, measured here independently as the table's difference
    // from the same grid computed with a 32-node rule.
    auto backend = make_backend("host", Precision::Double);
    auto spec_text = [](int nodes) {
        return "model = \"rough-dielectric\"\n[parameters]\ndistribution = \"ggx\"\neta = 1.5\nnodes = " +
               std::to_string(nodes) +
               "\n[[axes]]\nname = \"theta_i\"\nrange = [0.0, 85.0]\ncount = 5\n[[axes]]\nname = \"alpha\"\n"
               "range = [0.1, 0.9]\ncount = 3\n[[tables]]\nquantity = \"albedo_t\"\n[integration]\n"
               "method = \"quadrature\"\n[output]\ntype = \"float64\"\n";
    };
    const TableData coarse =
        generate_and_read(parse_spec_string(spec_text(2), "coarse.toml"), *backend, temp_path("coarse.h5"));
    const TableData fine =
        generate_and_read(parse_spec_string(spec_text(32), "fine.toml"), *backend, temp_path("fine.h5"));
    double rule_error = 0;
    for (std::size_t i = 0; i < coarse.value.size(); ++i)
        rule_error = std::max(rule_error, std::fabs(coarse.value[i] - fine.value[i]));
    REQUIRE(rule_error > 1e-6);  // the 2-node rule really is coarse
    CertifyOptions o;
    o.target = 1e-9;
    o.absolute = true;
    o.node_points = 200;  // 15 cells: every node is probed with high probability
    const Certificate c = certify_table(coarse, *backend, o);
    MESSAGE("2-node rule: error at nodes " << rule_error << ", certificate node max " << c.node_max);
    CHECK(c.node_max >= 0.5 * rule_error);
    CHECK(c.node_max <= 2.0 * rule_error);
    CHECK_FALSE(c.passed);
    std::filesystem::remove_all(std::filesystem::path(temp_path("coarse.h5")).parent_path());
}

TEST_CASE("critical axes tied to an eta axis: probes follow the kink, the certificate agrees with brute force") {
    // The mu_i nodes of a `critical` axis move with eta (one sits on the
    // critical cosine of each eta), so the probes are placed in the warped
    // coordinate and mapped at each probe's own eta.  Brute force: the model
    // evaluated directly on a dense (mu_i, eta) grid, the table interpolated
    // there with the lookup library, the largest absolute difference taken.
    auto backend = make_backend("host", Precision::Double);
    const std::string text =
        "model = \"rough-dielectric\"\n[parameters]\ndistribution = \"ggx\"\nalpha = 0.3\nnodes = 8\n"
        "[[axes]]\nname = \"mu_i\"\nrange = [-1.0, -0.02]\ncount = 7\nspacing = \"critical\"\n"
        "[[axes]]\nname = \"eta\"\nrange = [1.3, 2.0]\ncount = 3\n"
        "[[tables]]\nquantity = \"albedo_r\"\n[integration]\nmethod = \"quadrature\"\n[output]\ntype = \"float64\"\n";
    const TableData t = generate_and_read(parse_spec_string(text, "critical.toml"), *backend, temp_path("critical.h5"));
    REQUIRE(t.axes[0].dependent());
    CertifyOptions o;
    o.target = 1e-3;
    o.absolute = true;
    const Certificate c = certify_table(t, *backend, o);

    const ModelInfo& model = find_model("rough-dielectric");
    const QuantityInfo& q = model.quantity("albedo_r");
    std::vector<std::map<std::string, double>> named;
    std::vector<std::vector<double>> xs;
    for (int i = 0; i <= 120; ++i)
        for (int j = 0; j <= 20; ++j) {
            const double mu = -1.0 + 0.98 * i / 120.0, eta = 1.3 + 0.7 * j / 20.0;
            named.push_back({{"mu_i", mu}, {"eta", eta}, {"alpha", 0.3}, {"nodes", 24}});
            xs.push_back({mu, eta});
        }
    const std::vector<double> points = build_kernel_points(model, q, named, [](std::size_t) { return "dense"; });
    IntegrationSettings s;
    s.method = Method::Quadrature;
    const std::vector<int> options = resolve_options(model, nlohmann::json{{"distribution", "ggx"}}, "dense");
    const EstimateResult r = estimate_at(*backend, model, q, options, points, s);
    const LookupTable table(t);
    double dense_max = 0;
    for (std::size_t p = 0; p < xs.size(); ++p)
        dense_max = std::max(dense_max, std::fabs(table.eval(xs[p], Interpolation::Linear, OutOfRange::Clamp) - r.value[p]));
    MESSAGE("critical 7x3: certificate max " << c.max_error << " at (" << c.max_at[0] << ", " << c.max_at[1]
                                             << "), dense max " << dense_max);
    CHECK_FALSE(c.passed);
    CHECK(c.max_error >= 0.8 * dense_max);
    CHECK(c.max_error <= 1.5 * dense_max);
    // Every probe lies in the table's domain, and the worst one is off the nodes.
    CHECK(c.max_at[0] >= -1.0);
    CHECK(c.max_at[0] <= -0.02);
    CHECK(c.max_at[1] >= 1.3);
    CHECK(c.max_at[1] <= 2.0);
    CHECK(c.line_probes == 4 * 6 * 3 + 4 * 2 * 3);  // 4 lines along mu_i (6 intervals) and along eta (2), 3 fractions each
}

TEST_CASE("plan: a critical axis tied to eta is piloted, and its prediction holds against the certificate") {
    // The pilot's lines along mu_i are critical axes at each line's eta; its
    // lines along eta hold mu_i at a node t_k, which moves with eta as the
    // table's nodes do.  The prediction for the spec's own counts is compared
    // with the certificate of the table generated at those counts (probes
    // against direct evaluation, independent of the pilot's lines).
    auto backend = make_backend("host", Precision::Double);
    const std::string text =
        "model = \"rough-dielectric\"\n[parameters]\ndistribution = \"ggx\"\nalpha = 0.3\nnodes = 8\n"
        "[[axes]]\nname = \"mu_i\"\nrange = [-1.0, -0.02]\ncount = 13\nspacing = \"critical\"\n"
        "[[axes]]\nname = \"eta\"\nrange = [1.3, 2.0]\ncount = 4\n"
        "[[tables]]\nquantity = \"albedo_r\"\n[integration]\nmethod = \"quadrature\"\n[output]\ntype = \"float64\"\n";
    const Spec spec = parse_spec_string(text, "critical-plan.toml");
    const TablePilot pilot = run_pilot(spec, 0, *backend, PilotOptions{});
    REQUIRE(pilot.linear.size() == 2);
    REQUIRE(pilot.linear[0].max_abs.valid);
    PlanTarget target;
    target.absolute = true;
    target.accuracy = 1e-3;
    const TablePlan predicted = predict_table(pilot, target, {13, 4}, Method::Quadrature, 0, StoredType::Float64);
    const TableData t = generate_and_read(spec, *backend, temp_path("critical-plan.h5"));
    CertifyOptions o;
    o.target = 1e-3;
    o.absolute = true;
    const Certificate c = certify_table(t, *backend, o);
    MESSAGE("critical 13x4: predicted max " << predicted.error_max << ", certified " << c.max_error);
    CHECK(predicted.error_max >= c.max_error / 2);
    CHECK(predicted.error_max <= c.max_error * 2);
}

TEST_CASE("an explicit axis of a whole-number parameter is probed at its nodes only") {
    // The H-function moments alpha_n(c) exist for whole n only (the model
    // refuses n = 0.25): the certificate runs no lines along n and puts its
    // random and local probes on n's nodes; along c it probes as usual.
    auto backend = make_backend("host", Precision::Double);
    const std::string text =
        "model = \"hfunction\"\n[parameters]\npsi = \"lambert0\"\n"
        "[[axes]]\nname = \"n\"\nspacing = \"explicit\"\nvalues = [0, 1, 2]\n"
        "[[axes]]\nname = \"c\"\nrange = [0.0, 0.9]\ncount = 5\n"
        "[[tables]]\nquantity = \"moment\"\n[output]\ntype = \"float64\"\n";
    const TableData t = generate_and_read(parse_spec_string(text, "whole.toml"), *backend, temp_path("whole.h5"));
    CertifyOptions o;
    o.target = 1e-2;
    const Certificate c = certify_table(t, *backend, o);
    MESSAGE("alpha_n(c), 3 x 5: certificate max " << c.max_error << " at (n " << c.max_at[0] << ", c "
                                                  << c.max_at[1] << ")");
    CHECK(c.axis_max[0] == 0);  // no lines along n
    CHECK(c.axis_max[1] > 0);
    CHECK(c.max_at[0] == std::round(c.max_at[0]));
    CHECK(c.line_probes == 4 * 4 * 3);  // 4 lines along c (4 intervals, 3 fractions), none along n
    CHECK(c.max_error > 0);
}
