// Node-parallel quadrature (kernels/common/node_parallel.h; host/engine/launch/node_parallel*.cpp,
// EngineTuning::node_parallel): a quadrature batch's nodes as work items of one
// kernel, summed in node order by another, must give the very bits of the
// usual kernel, whose work item loops over the nodes itself.
//
// Oracles: the usual kernel (one loop, no layout, no scratch, no
// sub-launches) for bit identity, and the serial host path (the same header
// compiled as C++), which agrees to rounding: the device contracts a*b + c
// into FMAs where the host build does not (kernels/common/bt_math.h), so
// host and device differ in the last bits today, with or without this path.
// Accuracy against independent solutions of the H-equation is
// tests/test_hfunction.cpp's job.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "host/engine/engine.h"
#include "scoped_tuning.h"
#include "test_support.h"
#include "host/models/registry.h"
#include "kernels/common/sampler.h"
#include "kernels/models/hfunction.h"
#include "kernels/models/oren_nayar.h"

using namespace brdftab;

namespace {

using brdftab::test::ScopedTuning;

// Bitwise equality of doubles (NaN included).
bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

// Every (mu, c) of the test, fine rule (batch 0) and coarse rule (batch 1)
// for each: mu at 0, tiny (the node count grows like -log mu: ~3100 nodes at
// the smallest denormal), small, 1, above 1 (analytic continuation) and
// large; c from 0 to 1, with c next to 1 (K(0) -> 0, the log singularity).
struct Launch {
    BatchLaunch launch;
    std::vector<double> mu, c;
};

Launch h_launch(const std::string& psi, const std::map<std::string, double>& poly = {}) {
    const ModelInfo& m = find_model("hfunction");
    const QuantityInfo& q = m.quantity("H");
    PointBuilder builder(m, q);
    Launch out;
    BatchLaunch& l = out.launch;
    l.model = &m;
    l.quantity = q.id;
    l.options = resolve_options(m, {{"psi", psi}}, "test");
    l.method = BT_METHOD_QUADRATURE;
    l.key0 = 7;
    l.key1 = 11;
    l.stride = m.point_stride();
    l.batch_size = 1;
    const double mus[] = {0.0,  4.9e-324, 1e-300, 1e-12, 1e-5, 3e-3, 0.02, 0.1, 0.25,
                          0.5,  0.77,     0.999,  1.0,   1.5,  7.0,  1e3,  1e6, 1e12};
    const double cs[] = {0.0, 0.1, 0.5, 0.9, 0.99, 0.999999, 1.0 - 1e-12, 1.0};
    std::uint32_t cell = 0;
    for (double mu : mus)
        for (double c : cs) {
            std::map<std::string, double> values = poly;
            values["mu"] = mu;
            values["c"] = c;
            std::vector<double> point(l.stride);
            builder.build(values, point.data());
            for (std::uint32_t batch : {0u, 1u}) {
                l.points.insert(l.points.end(), point.begin(), point.end());
                l.cells.push_back(cell);
                l.batches.push_back(batch);
                out.mu.push_back(mu);
                out.c.push_back(c);
            }
            ++cell;
        }
    return out;
}

struct Outputs {
    std::vector<double> mean, m2;
};

Outputs run(Backend& backend, const BatchLaunch& l) {
    Outputs o;
    backend.run(l, o.mean, o.m2);
    return o;
}

// The launch run with EngineTuning::node_parallel set to `node_parallel`
// (Off: the usual kernel, On: node-parallel).
Outputs run_switched(Backend& backend, const BatchLaunch& l, LaunchChoice node_parallel) {
    ScopedTuning set(backend, &EngineTuning::node_parallel, node_parallel);
    return run(backend, l);
}

void check_same_bits(const Launch& x, const Outputs& a, const Outputs& b) {
    REQUIRE(a.mean.size() == b.mean.size());
    for (std::size_t w = 0; w < a.mean.size(); ++w) {
        CAPTURE(w);
        CAPTURE(x.mu[w]);
        CAPTURE(x.c[w]);
        CAPTURE(x.launch.batches[w]);
        CHECK(same_bits(a.mean[w], b.mean[w]));
        CHECK(same_bits(a.m2[w], b.m2[w]));
    }
}

const char* const kPsi[] = {"lambert0", "lambert1", "lambert2", "isotropic", "poly"};

// psi = poly: a valid Psi (1 - 2 int Psi = 0.32 > 0) with every coefficient set.
const std::map<std::string, double> kPoly = {
    {"psi_0", 0.2}, {"psi_1", 0.3}, {"psi_2", -0.1}, {"psi_3", 0.25}};

}  // namespace

TEST_CASE("node-parallel H: the usual kernel's bits, every psi, fine and coarse rules") {
    auto device = make_backend("", Precision::Double);
    auto host = make_backend("host", Precision::Double);
    for (const char* psi : kPsi) {
        CAPTURE(psi);
        const Launch x = h_launch(psi, std::string(psi) == "poly" ? kPoly : std::map<std::string, double>{});
        Outputs usual, node, split, short_layout, one_kernel, shifted_up, shifted_down;
        {
            ScopedTuning off(*device, &EngineTuning::node_parallel, LaunchChoice::Off);
            usual = run(*device, x.launch);
        }
        {
            ScopedTuning on(*device, &EngineTuning::node_parallel, LaunchChoice::On);
            node = run(*device, x.launch);
            // Sub-launches of at most 300 nodes: one or two work items each,
            // and a work item of more nodes than the cap alone (tiny mu).
            {
                ScopedTuning cap(*device, &EngineTuning::node_parallel_scratch_nodes, 300);
                split = run(*device, x.launch);
            }
            // The host lays out 50 nodes per work item at most; the sum
            // kernel computes the others itself, in their place.
            {
                ScopedTuning cap(*device, &EngineTuning::node_layout_cap, 50);
                short_layout = run(*device, x.launch);
            }
            // H's terms run on two kernels, series and direct form
            // (node_parallel.h, "Split terms"); one node kernel for both,
            // and host guesses 7 nodes too high or too low (those nodes come
            // back NaN and the sum kernel computes them).
            {
                ScopedTuning one(*device, &EngineTuning::split_node_terms, false);
                one_kernel = run(*device, x.launch);
            }
            {
                ScopedTuning up(*device, &EngineTuning::node_split_shift, 7);
                shifted_up = run(*device, x.launch);
            }
            {
                ScopedTuning down(*device, &EngineTuning::node_split_shift, -7);
                shifted_down = run(*device, x.launch);
            }
        }
        const Outputs serial = run(*host, x.launch);
        check_same_bits(x, usual, node);
        check_same_bits(x, usual, split);
        check_same_bits(x, usual, short_layout);
        check_same_bits(x, usual, one_kernel);
        check_same_bits(x, usual, shifted_up);
        check_same_bits(x, usual, shifted_down);
        for (std::size_t w = 0; w < serial.mean.size(); ++w) {
            CAPTURE(w);
            CAPTURE(x.mu[w]);
            CAPTURE(x.c[w]);
            CAPTURE(x.launch.batches[w]);
            REQUIRE(std::isfinite(serial.mean[w]));
            // Host and device differ by FMA contraction only (see the top).
            CHECK(std::fabs(node.mean[w] - serial.mean[w]) <= 1e-13 * std::fabs(serial.mean[w]));
            CHECK(node.m2[w] == 0.0);
            // H(0) = 1, and H = 1 to double precision below HF_MU_TINY
            // (H - 1 = O(mu log(1/mu)); the rule takes no nodes there).
            if (x.mu[w] < HF_MU_TINY) CHECK(node.mean[w] == 1.0);
        }
    }
}

TEST_CASE("node-parallel H: no H-function (poly with 1 - 2 int Psi < 0) gives the usual NaN") {
    auto device = make_backend("", Precision::Double);
    const Launch x = h_launch("poly", {{"psi_0", 0.8}});
    const Outputs usual = run_switched(*device, x.launch, LaunchChoice::Off);
    const Outputs node = run_switched(*device, x.launch, LaunchChoice::On);
    check_same_bits(x, usual, node);
    for (std::size_t w = 0; w < node.mean.size(); ++w)
        if (x.mu[w] > 0) CHECK(std::isnan(node.mean[w]));
}

TEST_CASE("node-parallel H in float: the usual float kernel's bits") {
    // The host lays out the nodes from its double count; a float device may
    // count one more or one fewer, which the sum kernel absorbs.
    auto device = make_backend("", Precision::Float);
    for (const char* psi : {"lambert0", "isotropic"}) {
        CAPTURE(psi);
        const Launch x = h_launch(psi);
        const Outputs usual = run_switched(*device, x.launch, LaunchChoice::Off);
        const Outputs node = run_switched(*device, x.launch, LaunchChoice::On);
        check_same_bits(x, usual, node);
    }
}

TEST_CASE("node-parallel H through estimate(): same values and error estimates as the usual kernel") {
    // The engine's own launches (slabs, the fine/coarse batch pair, the
    // default switch): the whole result, bit for bit, and the default is the
    // node-parallel path.
    const ModelInfo& m = find_model("hfunction");
    const QuantityInfo& q = m.quantity("H");
    REQUIRE(q.node_parallel.enabled());
    CHECK_FALSE(m.quantity("moment").node_parallel.enabled());  // stays on the usual kernel
    auto device = make_backend("", Precision::Double);
    PointBuilder builder(m, q);
    std::vector<std::map<std::string, double>> cells;
    for (int k = 0; k < 200; ++k) cells.push_back({{"mu", 0.005 * k}, {"c", 0.995}});
    const std::vector<int> options = resolve_options(m, {{"psi", "lambert1"}}, "test");
    IntegrationSettings s;
    s.slab_work_items = 64;  // several launches
    auto estimate_h = [&] {
        return estimate(*device, m, q, options, cells.size(),
                        [&](std::size_t c, double* out) { builder.build(cells[c], out); }, s);
    };
    EstimateResult usual, node, by_default;
    {
        ScopedTuning off(*device, &EngineTuning::node_parallel, LaunchChoice::Off);
        usual = estimate_h();
    }
    {
        ScopedTuning on(*device, &EngineTuning::node_parallel, LaunchChoice::On);
        node = estimate_h();
    }
    {
        ScopedTuning by_default_choice(*device, &EngineTuning::node_parallel, LaunchChoice::Default);
        by_default = estimate_h();
    }
    CHECK(node_parallel_by_default());
    REQUIRE(usual.value.size() == cells.size());
    for (std::size_t c = 0; c < cells.size(); ++c) {
        CAPTURE(c);
        CHECK(same_bits(usual.value[c], node.value[c]));
        CHECK(same_bits(usual.stderr_[c], node.stderr_[c]));
        CHECK(same_bits(usual.value[c], by_default.value[c]));
        CHECK(usual.samples[c] == node.samples[c]);
    }
}

TEST_CASE("hfunction's node functions compose to its sample function (host build)") {
    // The contract of kernels/common/node_parallel.h, checked on the C++
    // build of the header: count, prepare, the terms added in node order and
    // finish give hfunction_sample's H bit for bit (and so the serial path's).
    const double mus[] = {0.0, 1e-140, 1e-12, 1e-5, 0.02, 0.5, 1.0, 7.0, 1e12};
    const double cs[] = {0.0, 0.5, 0.999999, 1.0};
    const double poly[4] = {0.2, 0.3, -0.1, 0.25};
    for (int psi = HF_PSI_LAMBERT0; psi <= HF_PSI_POLY; ++psi)
        for (double mu : mus)
            for (double c : cs)
                for (unsigned batch : {0u, 1u}) {
                    CAPTURE(psi);
                    CAPTURE(mu);
                    CAPTURE(c);
                    CAPTURE(batch);
                    double p[16] = {0};
                    p[HF_PARAM_MU] = mu;
                    p[HF_PARAM_C] = c;
                    for (int k = 0; k < 4; ++k) p[HF_PARAM_PSI_0 + k] = poly[k];
                    const int o[8] = {psi};
                    bt_sampler s{};
                    s.method = BT_METHOD_QUADRATURE;
                    s.batch = batch;
                    const int n = hfunction_h_node_count(p, o, HF_Q_H, &s);
                    double state[HF_NODE_STATE];
                    hfunction_h_node_prepare(p, o, HF_Q_H, &s, state);
                    double sum = 0.0;
                    for (int k = 0; k < n; ++k) sum += hfunction_h_node_term(state, o, HF_Q_H, k);
                    const double composed = hfunction_h_node_finish(p, o, HF_Q_H, &s, sum);
                    CHECK(same_bits(composed, hfunction_sample(p, o, HF_Q_H, &s)));
                    // The split forms: at each node exactly one is a number,
                    // the term's bits; the host's guess is the series prefix
                    // (here, where both use the host's exp, exactly).
                    const int split = hfunction_h_node_split(p, o, HF_Q_H, &s);
                    CHECK(split >= 0);
                    CHECK(split <= n);
                    for (int k = 0; k < n; ++k) {
                        CAPTURE(k);
                        const double term = hfunction_h_node_term(state, o, HF_Q_H, k);
                        const double series = hfunction_h_node_term_series(state, o, HF_Q_H, k);
                        const double direct = hfunction_h_node_term_direct(state, o, HF_Q_H, k);
                        CHECK(std::isnan(series) != std::isnan(direct));
                        CHECK(same_bits(std::isnan(series) ? direct : series, term));
                        CHECK(std::isnan(direct) == (k < split));
                    }
                    if (mu >= HF_MU_TINY)
                        CHECK(n > (batch == 0 ? 120 : 60));  // the fine rule has ~125+ nodes
                    else
                        CHECK(n == 0);  // H = 1 to double precision: no nodes (hf_h_nodes)
                }
}

// ------------------------------------------------------------------------
// Oren-Nayar's Gaussian-surface quadrature: nested node-parallel sums
// (kernels/common/node_parallel.h "Nested sums"; groups = theta_a nodes,
// nodes = the phi_a nodes of each).  Oracle: the usual kernel, bit for bit.

namespace {

// Every (direction pair, sigma, nodes) of the test, fine (batch 0) and
// coarse (batch 1) rule: normal and grazing incidence and view (89.9 and
// exactly 90 deg: the cosine floor), phi_d at 0 and 180 deg (the X = Y line
// degenerates) and in between, sigma from 0 (no sum: the sample function's
// own branch) and 0.05 deg to 60 deg, and node counts 2, 7 and 12.
struct OnLaunch {
    BatchLaunch launch;
    std::vector<std::string> what;
};

OnLaunch on_launch(const std::string& quantity, const std::map<std::string, std::string>& options = {}) {
    const ModelInfo& m = find_model("oren-nayar");
    const QuantityInfo& q = m.quantity(quantity);
    PointBuilder builder(m, q);
    OnLaunch out;
    BatchLaunch& l = out.launch;
    l.model = &m;
    l.quantity = q.id;
    l.options = resolve_options(m, options, "test");
    l.method = BT_METHOD_QUADRATURE;
    l.key0 = 3;
    l.key1 = 5;
    l.stride = m.point_stride();
    l.batch_size = 1;
    const double thetas_i[] = {0.0, 30.0, 75.0, 89.9, 90.0};
    const double thetas_o[] = {0.0, 45.0, 89.0, 90.0};
    const double phis_d[] = {0.0, 180.0, 63.0};
    const double sigmas[] = {0.0, 0.05, 5.0, 20.0, 60.0};
    const double nodes[] = {2.0, 7.0, 12.0};
    std::uint32_t cell = 0;
    for (double ti : thetas_i)
        for (double to : thetas_o)
            for (double pd : phis_d)
                for (double sigma : sigmas)
                    for (double n : nodes) {
                        if (n != 12.0 && (sigma == 0.0 || pd == 63.0)) continue;  // fewer cells
                        std::vector<double> point(l.stride);
                        builder.build({{"theta_i", ti}, {"phi_i", 10.0}, {"theta_o", to},
                                       {"phi_o", 10.0 + pd}, {"sigma", sigma}, {"rho", 0.7},
                                       {"nodes", n}},
                                      point.data());
                        for (std::uint32_t batch : {0u, 1u}) {
                            l.points.insert(l.points.end(), point.begin(), point.end());
                            l.cells.push_back(cell);
                            l.batches.push_back(batch);
                            out.what.push_back("theta_i " + std::to_string(ti) + " theta_o " +
                                               std::to_string(to) + " phi_d " + std::to_string(pd) +
                                               " sigma " + std::to_string(sigma) + " nodes " +
                                               std::to_string(n) + " batch " + std::to_string(batch));
                        }
                        ++cell;
                    }
    return out;
}

void check_on_same_bits(const OnLaunch& x, const Outputs& a, const Outputs& b) {
    REQUIRE(a.mean.size() == b.mean.size());
    REQUIRE(a.mean.size() == x.what.size());
    for (std::size_t w = 0; w < a.mean.size(); ++w) {
        CAPTURE(x.what[w]);
        CHECK(same_bits(a.mean[w], b.mean[w]));
        CHECK(same_bits(a.m2[w], b.m2[w]));
    }
}

}  // namespace

TEST_CASE("node-parallel oren-nayar: the usual kernel's bits for every quadrature quantity") {
    auto device = make_backend("", Precision::Double);
    const std::vector<std::pair<std::string, std::map<std::string, std::string>>> cases = {
        {"brdf", {}},
        {"brdf_direct", {}},
        {"brdf_interreflection", {}},
        {"approx_error", {{"error", "absolute"}, {"approximation", "qualitative"}}},
    };
    for (const auto& [quantity, options] : cases) {
        CAPTURE(quantity);
        const QuantityInfo& q = find_model("oren-nayar").quantity(quantity);
        REQUIRE(q.node_parallel.enabled());
        REQUIRE(q.node_parallel.nested());
        const OnLaunch x = on_launch(quantity, options);
        Outputs usual, node, split, blocks;
        {
            ScopedTuning off(*device, &EngineTuning::node_parallel, LaunchChoice::Off);
            usual = run(*device, x.launch);
        }
        {
            ScopedTuning on(*device, &EngineTuning::node_parallel, LaunchChoice::On);
            node = run(*device, x.launch);
            {
                // One work item per block (scratch cap / 256 -> 1) and
                // sub-launches of at most 18 nodes (scratch cap / 16), or of
                // one group with more.
                ScopedTuning cap(*device, &EngineTuning::node_parallel_scratch_nodes, 300);
                split = run(*device, x.launch);
            }
            // Blocks of at most 1024 groups (cap / 64), so a few dozen work
            // items each, those without groups (sigma 0, below the horizon)
            // among them, and many sub-launches of at most 4096 nodes per
            // block.
            ScopedTuning cap(*device, &EngineTuning::node_parallel_scratch_nodes, 65536);
            blocks = run(*device, x.launch);
        }
        check_on_same_bits(x, usual, node);
        check_on_same_bits(x, usual, split);
        check_on_same_bits(x, usual, blocks);
        // Not a vacuous comparison: a positive, finite BRDF everywhere (it
        // grows like 1/cos when both directions graze: up to ~5e4 here).
        if (quantity == "brdf")
            for (std::size_t w = 0; w < node.mean.size(); ++w) {
                CAPTURE(x.what[w]);
                CHECK(std::isfinite(node.mean[w]));
                CHECK(node.mean[w] > 0.0);
            }
    }
    CHECK_FALSE(find_model("oren-nayar").quantity("single_slope_direct").node_parallel.enabled());
}

TEST_CASE("node-parallel oren-nayar in float: the usual float kernel's bits") {
    auto device = make_backend("", Precision::Float);
    const OnLaunch x = on_launch("brdf");
    const Outputs usual = run_switched(*device, x.launch, LaunchChoice::Off);
    const Outputs node = run_switched(*device, x.launch, LaunchChoice::On);
    check_on_same_bits(x, usual, node);
}

TEST_CASE("node-parallel oren-nayar through estimate(): the default, same values and errors") {
    const ModelInfo& m = find_model("oren-nayar");
    const QuantityInfo& q = m.quantity("brdf");
    auto device = make_backend("", Precision::Double);
    PointBuilder builder(m, q);
    std::vector<std::map<std::string, double>> cells;
    for (int k = 0; k < 120; ++k)
        cells.push_back({{"theta_i", 0.75 * k}, {"phi_i", 0.0}, {"theta_o", 89.95 - 0.7 * k},
                         {"phi_o", k % 3 == 0 ? 0.0 : (k % 3 == 1 ? 180.0 : 3.0 * k)},
                         {"sigma", 0.5 + 0.5 * k},
                         {"rho", 0.9}});
    const std::vector<int> options = resolve_options(m, {}, "test");
    IntegrationSettings s;
    s.slab_work_items = 40;  // several launches
    auto estimate_brdf = [&] {
        return estimate(*device, m, q, options, cells.size(),
                        [&](std::size_t c, double* out) { builder.build(cells[c], out); }, s);
    };
    EstimateResult usual, by_default;
    {
        ScopedTuning off(*device, &EngineTuning::node_parallel, LaunchChoice::Off);
        usual = estimate_brdf();
    }
    {
        ScopedTuning by_default_choice(*device, &EngineTuning::node_parallel, LaunchChoice::Default);
        by_default = estimate_brdf();
    }
    CHECK(q.node_parallel.by_default);
    REQUIRE(usual.value.size() == cells.size());
    for (std::size_t c = 0; c < cells.size(); ++c) {
        CAPTURE(c);
        CHECK(same_bits(usual.value[c], by_default.value[c]));
        CHECK(same_bits(usual.stderr_[c], by_default.stderr_[c]));
        CHECK(usual.samples[c] == by_default.samples[c]);
    }
}

TEST_CASE("oren-nayar's node functions compose to its sample function (host build)") {
    // The nested contract of kernels/common/node_parallel.h on the C++ build
    // of the header: count, prepare, every group's prepare, its terms, its
    // reduction and addition in order, and finish give oren_nayar_sample bit
    // for bit.  The table prepare reads is built entry by entry by the table
    // function, as the device's table kernel builds it.
    std::vector<double> table(static_cast<std::size_t>(ON_NODE_TABLE_ENTRIES) * ON_NODE_TABLE_SIZE);
    for (int e = 0; e < ON_NODE_TABLE_ENTRIES; ++e)
        oren_nayar_node_table(e, &table[static_cast<std::size_t>(e) * ON_NODE_TABLE_SIZE]);
    const double thetas_i[] = {0.0, 0.3, 1.2, 1.5706, BT_HALF_PI};
    const double thetas_o[] = {0.0, 0.8, 1.55, BT_HALF_PI};
    const double phis_d[] = {0.0, BT_PI, 2.0};
    const double sigmas[] = {1e-7, 0.01, 0.3, 1.0};
    const int quantities[] = {ON_Q_BRDF, ON_Q_BRDF_DIRECT, ON_Q_BRDF_INTER, ON_Q_APPROX_ERROR};
    std::size_t nested = 0;
    for (int quantity : quantities)
        for (double ti : thetas_i)
            for (double to : thetas_o)
                for (double pd : phis_d)
                    for (double sigma : sigmas)
                        for (unsigned batch : {0u, 1u}) {
                            CAPTURE(quantity);
                            CAPTURE(ti);
                            CAPTURE(to);
                            CAPTURE(pd);
                            CAPTURE(sigma);
                            CAPTURE(batch);
                            double p[16] = {0};
                            p[0] = ti;
                            p[1] = 0.2;
                            p[2] = to;
                            p[3] = 0.2 + pd;
                            p[ON_PARAM_SIGMA] = sigma;
                            p[ON_PARAM_RHO] = 0.6;
                            p[ON_PARAM_NODES] = 9;
                            const int o[8] = {0, 0, 0};
                            bt_sampler s{};
                            s.method = BT_METHOD_QUADRATURE;
                            s.batch = batch;
                            const double expected = oren_nayar_sample(p, o, quantity, &s);
                            const int groups = oren_nayar_node_count(p, o, quantity, &s);
                            if (groups == 0) continue;  // the sample function's own value
                            ++nested;
                            std::vector<double> item(ON_NODE_ITEM_STATE);
                            oren_nayar_node_prepare(p, o, quantity, &s, table.data(), item.data());
                            double acc[ON_NODE_ACC] = {0, 0, 0};
                            for (int g = 0; g < groups; ++g) {
                                std::vector<double> gs(ON_NODE_GROUP_STATE);
                                const int nodes = oren_nayar_node_group(item.data(), o, quantity, g, gs.data());
                                REQUIRE(nodes >= 2 * (batch == 0 ? 9 : 5));
                                std::vector<double> terms(static_cast<std::size_t>(nodes) * ON_NODE_TERMS);
                                std::vector<double> phi(static_cast<std::size_t>(nodes));
                                oren_nayar_node_term_setup(item.data(), gs.data(), phi.data());
                                for (int k = 0; k < nodes; ++k)
                                    oren_nayar_node_term(item.data(), gs.data(), o, quantity, phi[static_cast<std::size_t>(k)],
                                                         &terms[static_cast<std::size_t>(k) * ON_NODE_TERMS]);
                                double partial[ON_NODE_PARTIALS] = {0, 0};
                                oren_nayar_node_group_reduce(item.data(), gs.data(), o, quantity, terms.data(), partial);
                                oren_nayar_node_group_add(item.data(), gs.data(), o, quantity, partial, acc);
                            }
                            const double composed = oren_nayar_node_finish(p, o, quantity, &s, acc);
                            CHECK(same_bits(composed, expected));
                        }
    CHECK(nested > 500);
}
