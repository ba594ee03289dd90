// test_renderer_luts_rqmc.cpp — the renderer presets' quadrature against an
// independent estimator, RQMC with 2^20 Owen-scrambled Sobol points (16
// batches of 2^16), on random entries: 200 of the Cycles preset's six
// tables, 40 of Filament's DFG texture (its three channels) and 40 of the
// UE4 split-sum texture (label `long`: a few minutes on one core).  Each
// entry: |quadrature - RQMC| within 4 RQMC standard errors + 1e-6, and the
// quadrature's own error estimate (the distance to the coarse rule, the
// stored stderr) is at most 1e-6.
#include <doctest/doctest.h>

#include "test_sampling.h"
#include "test_support.h"

#include <cmath>
#include <string>

#include "host/core/grid.h"
#include "host/spec/spec.h"
#include "kernels/models/rough_dielectric.h"

namespace {

// The kernel's point and options for one table entry of a preset (the
// options the presets use, spelled out from the model's option table).
struct Entry {
    double p[8] = {0, 0, 0, 0, 0, 1.5, 0, 0};
    int o[RD_OPT_COUNT] = {BT_MF_GGX, BT_G1_EXACT, BT_SHADOW_HEIGHT_CORRELATED, RD_LOBE_BOTH, 0,
                           RD_SAMPLING_VISIBLE, RD_FRESNEL_DIELECTRIC, RD_MU_RULE_SINGLE, 0, 0};
    int q = RD_Q_ALBEDO;
};

Entry entry_of(const brdftab::TableSpec& t, const std::vector<double>& x) {
    const double kDeg = brdftab::test::kPi / 180;
    Entry e;
    e.p[RD_PARAM_NODES] = t.fixed.at("nodes");
    for (std::size_t d = 0; d < t.axes.size(); ++d) {
        const std::string& n = t.axes[d].name;
        if (n == "alpha") e.p[RD_PARAM_ALPHA] = x[d];
        if (n == "eta") e.p[RD_PARAM_ETA] = x[d];
        if (n == "mu_i") e.p[0] = std::acos(x[d]);
        if (n == "theta_i") e.p[0] = x[d] * kDeg;
    }
    auto opt = [&](const char* k) { return t.options.value(k, std::string()); };
    REQUIRE(opt("distribution") == "ggx");
    REQUIRE(opt("shadowing") == "height-correlated");
    if (opt("g1") == "schlick") e.o[RD_OPT_G1] = BT_G1_SCHLICK;
    if (opt("fresnel") == "none") {
        e.o[RD_OPT_FRESNEL] = RD_FRESNEL_NONE;
        e.o[RD_OPT_LOBE] = RD_LOBE_REFLECTION;
    }
    if (opt("side") == "inside") e.o[RD_OPT_SIDE] = 1;
    if (opt("mu_rule") == "graded") e.o[RD_OPT_MU_RULE] = RD_MU_RULE_GRADED;
    if (opt("tir_rule") == "sqrt") e.o[RD_OPT_TIR_RULE] = RD_TIR_RULE_SQRT;
    if (opt("coarse_rule") == "three-quarters") e.o[RD_OPT_COARSE_RULE] = RD_COARSE_RULE_THREE_QUARTERS;
    e.q = t.quantity == "albedo_r"       ? RD_Q_ALBEDO_R
          : t.quantity == "albedo"       ? RD_Q_ALBEDO
          : t.quantity == "albedo_avg"   ? RD_Q_ALBEDO_AVG
          : t.quantity == "split_a"      ? RD_Q_SPLIT_A
          : t.quantity == "split_b"      ? RD_Q_SPLIT_B
          : t.quantity == "sheen_albedo" ? RD_Q_SHEEN_ALBEDO
                                         : -1;
    REQUIRE(e.q >= 0);
    return e;
}

// `entries` random entries of the preset, each against RQMC at 2^20 points.
void check_against_rqmc(const char* preset, int entries, std::uint64_t seed) {
    const brdftab::Spec s =
        brdftab::parse_spec_file(std::string(BT_SOURCE_DIR) + "/tables/renderers/" + preset);
    std::uint64_t state = seed;
    auto next = [&] {  // splitmix64
        std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
        return z ^ (z >> 31);
    };
    double worst = 0, worst_estimate = 0;
    for (int entry = 0; entry < entries; ++entry) {
        const brdftab::TableSpec& t = s.tables[next() % s.tables.size()];
        const brdftab::Grid grid(t.axes);
        const std::size_t cell = next() % grid.cell_count();
        const Entry e = entry_of(t, grid.coordinates(cell));
        bt_sampler s0 = brdftab::test::make_sampler(BT_METHOD_QUADRATURE, 0, 0, 0, 0, 0);
        bt_sampler s1 = brdftab::test::make_sampler(BT_METHOD_QUADRATURE, 0, 0, 0, 1, 0);
        const double quad = rough_dielectric_sample(e.p, e.o, e.q, &s0);
        const double estimate = std::fabs(quad - rough_dielectric_sample(e.p, e.o, e.q, &s1));
        brdftab::test::RunningStat st;
        for (uint b = 0; b < 16; ++b) {
            double sum = 0;
            for (uint k = 0; k < (1u << 16); ++k) {
                bt_sampler r = brdftab::test::make_sampler(BT_METHOD_RQMC, 11, 12, uint(entry), b, k);
                sum += rough_dielectric_sample(e.p, e.o, e.q, &r);
            }
            st.add(sum / (1u << 16));
        }
        const double d = std::fabs(quad - st.mean);
        INFO(std::string(preset) << " entry " << entry << " table " << t.name << " cell " << cell << ": quadrature "
                    << quad << " (estimate " << estimate << "), RQMC " << st.mean << " +- " << st.se());
        CHECK(d <= 4 * st.se() + 1e-6);
        CHECK(estimate <= 1e-6);  // the preset's own error estimate meets the target
        worst = std::fmax(worst, d / (st.se() + 1e-12));
        worst_estimate = std::fmax(worst_estimate, estimate);
    }
    MESSAGE(std::string(preset) << ": largest |quadrature - RQMC| / RQMC stderr " << worst << ", largest estimate "
                   << worst_estimate);
}

}  // namespace

TEST_CASE("Cycles preset: quadrature within RQMC noise at 2^20 points on 200 random entries")
{
    check_against_rqmc("cycles.toml", 200, 0x9E3779B97F4A7C15ull);
}

TEST_CASE("Filament and UE4 presets: quadrature within RQMC noise at 2^20 points on 40 random entries each")
{
    check_against_rqmc("filament-dfg.toml", 40, 0x6A09E667F3BCC909ull);
    check_against_rqmc("ue4-splitsum.toml", 40, 0xBB67AE8584CAA73Bull);
}

TEST_CASE("Cycles preset: the averages against the single mu rule at 32 nodes")
{
    // An independent, much finer quadrature of the same integral: one
    // Gauss-Legendre rule per smooth piece of E(mu) (split at mu_c, 2 mu_c and
    // 1/IOR, no grazing or normal panels) with 32 mu nodes, each E at 32 nodes,
    // against the preset's graded rule, on 5 random entries of each average.
    const brdftab::Spec s =
        brdftab::parse_spec_file(std::string(BT_SOURCE_DIR) + "/tables/renderers/cycles.toml");
    std::uint64_t state = 0x2545F4914F6CDD1Dull;
    auto next = [&] {  // splitmix64
        std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
        return z ^ (z >> 31);
    };
    double worst = 0;
    for (const brdftab::TableSpec& t : s.tables) {
        if (t.quantity != "albedo_avg") continue;
        const brdftab::Grid grid(t.axes);
        for (int k = 0; k < 5; ++k) {
            const std::size_t cell = next() % grid.cell_count();
            const std::vector<double> x = grid.coordinates(cell);
            double p[8] = {0, 0, 0, 0, 0, 1.5, t.fixed.at("nodes"), 0};
            for (std::size_t d = 0; d < t.axes.size(); ++d) {
                if (t.axes[d].name == "alpha") p[RD_PARAM_ALPHA] = x[d];
                if (t.axes[d].name == "eta") p[RD_PARAM_ETA] = x[d];
            }
            int o[RD_OPT_COUNT] = {BT_MF_GGX, 0, BT_SHADOW_HEIGHT_CORRELATED, RD_LOBE_BOTH, 0, RD_SAMPLING_VISIBLE,
                                   RD_FRESNEL_DIELECTRIC, RD_MU_RULE_GRADED, 0, 0};
            if (t.options["fresnel"] == "none") {
                o[RD_OPT_FRESNEL] = RD_FRESNEL_NONE;
                o[RD_OPT_LOBE] = RD_LOBE_REFLECTION;
            }
            if (t.options["side"] == "inside") o[RD_OPT_SIDE] = 1;
            if (t.options["tir_rule"] == "sqrt") o[RD_OPT_TIR_RULE] = RD_TIR_RULE_SQRT;
            if (t.options["coarse_rule"] == "three-quarters") o[RD_OPT_COARSE_RULE] = RD_COARSE_RULE_THREE_QUARTERS;
            REQUIRE(t.options["mu_rule"] == "graded");
            bt_sampler s0 = brdftab::test::make_sampler(BT_METHOD_QUADRATURE, 0, 0, 0, 0, 0);
            const double value = rough_dielectric_sample(p, o, RD_Q_ALBEDO_AVG, &s0);
            int os[RD_OPT_COUNT];
            for (int j = 0; j < RD_OPT_COUNT; ++j) os[j] = o[j];
            os[RD_OPT_MU_RULE] = RD_MU_RULE_SINGLE;
            os[RD_OPT_TIR_RULE] = RD_TIR_RULE_SQRT;  // the single rule's splits at 2 mu_c and 1/IOR
            double pf[8];
            for (int j = 0; j < 8; ++j) pf[j] = p[j];
            pf[RD_PARAM_NODES] = 32;
            const double fine = rough_dielectric_sample(pf, os, RD_Q_ALBEDO_AVG, &s0);
            INFO(t.name << " cell " << cell << ": preset " << value << ", single rule at 32 nodes " << fine);
            CHECK(std::fabs(value - fine) <= 1e-6);
            worst = std::fmax(worst, std::fabs(value - fine));
        }
    }
    MESSAGE("largest |preset - single rule at 32 nodes| " << worst);
}
