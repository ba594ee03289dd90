// test_sampler.cpp — kernels/common/sampler.h (Philox, Sobol', Owen scramble)
// compiled as C++.  Oracles: Random123's published known-answer vectors,
// Joe–Kuo's direction-number rows expanded by an independent recurrence, the
// (0,m,2)-net property of Sobol' dims 0/1 (a theorem, checked by counting),
// moments of U(0,1), and plain loops written here (the obvious Sobol' and
// Owen-scramble loops) that the unrolled, table-driven kernels must match bit
// for bit.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <random>
#include <set>
#include <vector>

#include "kernels/common/sampler.h"
#include "test_sampling.h"

using brdftab::test::make_sampler;

TEST_CASE("philox4x32-10 matches Random123 known-answer vectors")
{
    // Random123 tests/kat_vectors, "philox4x32 10" lines (counter, key, result).
    struct Kat {
        uint c[4], k[2], r[4];
    } kats[] = {
        {{0, 0, 0, 0}, {0, 0}, {0x6627e8d5u, 0xe169c58du, 0xbc57ac4cu, 0x9b00dbd8u}},
        {{0xffffffffu, 0xffffffffu, 0xffffffffu, 0xffffffffu},
         {0xffffffffu, 0xffffffffu},
         {0x408f276du, 0x41c83b0eu, 0xa20bc7c6u, 0x6d5451fdu}},
        {{0x243f6a88u, 0x85a308d3u, 0x13198a2eu, 0x03707344u},
         {0xa4093822u, 0x299f31d0u},
         {0xd16cfe09u, 0x94fdccebu, 0x5001e420u, 0x24126ea1u}},
    };
    for (const Kat& t : kats) {
        uint out[4];
        bt_philox4x32_10(t.c[0], t.c[1], t.c[2], t.c[3], t.k[0], t.k[1], out);
        for (int w = 0; w < 4; ++w) {
            CHECK(out[w] == t.r[w]);
            CHECK(bt_philox4x32_10_word(t.c[0], t.c[1], t.c[2], t.c[3], t.k[0], t.k[1], w) ==
                  t.r[w]);
        }
    }
}

TEST_CASE("MC uniform uses counter (cell, batch, sample, dim/4), word dim%4, key (key0, key1)")
{
    bt_sampler s = make_sampler(BT_METHOD_MC, 0xa4093822u, 0x299f31d0u, 0x243f6a88u, 0x85a308d3u,
                        0x13198a2eu);
    // dim/4 = 0x03707344 is not a valid dim, so use the KAT block layout with
    // dim/4 = 1 and compare against the block function (validated above).
    uint out[4];
    bt_philox4x32_10(s.cell, s.batch, s.sample, 1u, s.key0, s.key1, out);
    for (uint w = 0; w < 4; ++w) CHECK(bt_uniform(&s, 4u + w) == std::ldexp((double)out[w], -32));
}

TEST_CASE("uniforms are in [0,1), never 1.0, with U(0,1) mean and variance")
{
    CHECK(bt_u32_to_unit(0xffffffffu) < 1.0);
    CHECK(bt_u32_to_unit(0u) == 0.0);
    // Float-mode conversion (device only) emulated: 24 top bits * 2^-24 in float.
    CHECK((float)(0xffffffffu >> 8) * 5.9604644775390625e-08f < 1.0f);

    for (uint method : {BT_METHOD_MC, BT_METHOD_RQMC}) {
        // N = 8 dims x 64 cells x 256 samples = 131072 values.  For i.i.d.
        // U(0,1): stderr(mean) = sqrt(1/12/N) = 8e-4, stderr(var) =
        // sqrt(1/180/N) = 2.1e-4 (var of (U-1/2)^2 is 1/80 - 1/144 = 1/180).
        // RQMC values are not independent across samples but are even more
        // evenly spread, so the same 5-sigma bounds are conservative.
        double sum = 0, sum2 = 0;
        long n = 0;
        for (uint cell = 0; cell < 64; ++cell)
            for (uint k = 0; k < 256; ++k) {
                bt_sampler s = make_sampler(method, 7u, 11u, cell, 3u, k);
                for (uint d = 0; d < BT_MAX_DIMS; ++d) {
                    double u = bt_uniform(&s, d);
                    REQUIRE(u >= 0.0);
                    REQUIRE(u < 1.0);
                    sum += u;
                    sum2 += (u - 0.5) * (u - 0.5);
                    ++n;
                }
            }
        double mean = sum / n, var = sum2 / n - (mean - 0.5) * (mean - 0.5);
        CHECK(std::fabs(mean - 0.5) < 5 * std::sqrt(1.0 / 12 / n));
        CHECK(std::fabs(var - 1.0 / 12) < 5 * std::sqrt(1.0 / 180 / n));
    }
    bt_sampler c = make_sampler(BT_METHOD_CLOSED, 1, 2, 3, 4, 5);
    CHECK(bt_uniform(&c, 0) == 0.5);
}

TEST_CASE("Sobol table equals the Joe-Kuo recurrence")
{
    // Rows d = 2..8 of new-joe-kuo-6.21201: s, a, m_1..m_s.
    struct Row {
        unsigned s, a, m[5];
    } rows[7] = {{1, 0, {1}},          {2, 1, {1, 3}},       {3, 1, {1, 3, 1}},
                 {3, 2, {1, 1, 1}},    {4, 1, {1, 1, 3, 3}}, {4, 4, {1, 3, 5, 13}},
                 {5, 2, {1, 1, 5, 5, 17}}};
    for (unsigned k = 0; k < 32; ++k) CHECK(bt_sobol_v[0][k] == (1u << (31 - k)));
    for (int d = 1; d < 8; ++d) {
        const Row& r = rows[d - 1];
        // m-form of the recurrence (Bratley & Fox), in 64-bit to avoid overflow:
        // m_k = (XOR_{j=1}^{s-1} 2^j a_j m_{k-j}) ^ 2^s m_{k-s} ^ m_{k-s},
        // a_j = bit (s-1-j) of a.
        std::vector<std::uint64_t> m(33);
        for (unsigned k = 1; k <= r.s; ++k) m[k] = r.m[k - 1];
        for (unsigned k = r.s + 1; k <= 32; ++k) {
            std::uint64_t v = (m[k - r.s] << r.s) ^ m[k - r.s];
            for (unsigned j = 1; j < r.s; ++j)
                if ((r.a >> (r.s - 1 - j)) & 1u) v ^= m[k - j] << j;
            m[k] = v;
        }
        for (unsigned k = 1; k <= 32; ++k) {
            CHECK(m[k] % 2 == 1);           // direction numbers are odd
            CHECK(m[k] < (1ull << k));      // and below 2^k
            CHECK(bt_sobol_v[d][k - 1] == (std::uint32_t)(m[k] << (32 - k)));
        }
    }
}

namespace {

// True when the 2^m points (x, y) (32-bit digits) form a (0,m,2)-net: every
// elementary interval [a 2^-j, (a+1) 2^-j) x [b 2^-(m-j), ...) holds one point.
bool is_02_net(const std::vector<uint>& x, const std::vector<uint>& y, unsigned m)
{
    for (unsigned j = 0; j <= m; ++j) {
        std::vector<int> count(1u << m, 0);
        for (size_t p = 0; p < x.size(); ++p) {
            uint a = j == 0 ? 0 : x[p] >> (32 - j);
            uint b = (m - j) == 0 ? 0 : y[p] >> (32 - (m - j));
            ++count[(a << (m - j)) | b];
        }
        for (int c : count)
            if (c != 1) return false;
    }
    return true;
}

uint to_u32(double u) { return (uint)std::ldexp(u, 32); }

}  // namespace

TEST_CASE("Sobol dims 0/1 form a (0,m,2)-net, before and after Owen scrambling")
{
    for (unsigned m = 1; m <= 12; ++m) {
        std::vector<uint> x(1u << m), y(1u << m), xs(1u << m), ys(1u << m);
        for (uint k = 0; k < (1u << m); ++k) {
            x[k] = bt_sobol_u32(k, 0);
            y[k] = bt_sobol_u32(k, 1);
            bt_sampler s = make_sampler(BT_METHOD_RQMC, 0x1234u, 0x9876u, 17u + m, 5u, k);
            xs[k] = to_u32(bt_uniform(&s, 0));
            ys[k] = to_u32(bt_uniform(&s, 1));
        }
        CHECK(is_02_net(x, y, m));
        CHECK(is_02_net(xs, ys, m));
        // The scramble must actually move the points.
        CHECK(xs != x);
    }
    // A negative control: a non-net (the same points with the y order
    // reversed) must be rejected, so the checker can fail.
    std::vector<uint> x(256), y(256);
    for (uint k = 0; k < 256; ++k) {
        x[k] = bt_sobol_u32(k, 0);
        y[k] = bt_sobol_u32(255 - k, 0);
    }
    CHECK_FALSE(is_02_net(x, y, 8));
}

TEST_CASE("every scrambled Sobol dim is stratified: one point per 1/2^m interval")
{
    const unsigned m = 10;
    for (uint d = 0; d < BT_MAX_DIMS; ++d) {
        std::set<uint> seen;
        for (uint k = 0; k < (1u << m); ++k) {
            bt_sampler s = make_sampler(BT_METHOD_RQMC, 3u, 4u, 99u, 2u, k);
            seen.insert(to_u32(bt_uniform(&s, d)) >> (32 - m));
        }
        CHECK(seen.size() == (1u << m));
    }
}

TEST_CASE("RQMC batches are unbiased and beat MC on a smooth integrand")
{
    // f(u) = u0 u1 u2 exp(u3), exact integral (1/8)(e - 1).  200 independent
    // scrambles (batches) of 256 points: their mean must match the exact
    // value within 5 standard errors of the batch means (unbiasedness of a
    // uniform scramble), and the RQMC batch variance must be far below the
    // MC one (variance of f is ~0.03/256 per batch for MC).
    const double exact = (std::exp(1.0) - 1.0) / 8.0;
    double var_of[2];
    for (uint method : {BT_METHOD_MC, BT_METHOD_RQMC}) {
        const int nb = 200;
        std::vector<double> means(nb);
        for (int b = 0; b < nb; ++b) {
            double acc = 0;
            for (uint k = 0; k < 256; ++k) {
                bt_sampler s = make_sampler(method, 42u, 0u, 7u, (uint)b, k);
                acc += bt_uniform(&s, 0) * bt_uniform(&s, 1) * bt_uniform(&s, 2) *
                       std::exp(bt_uniform(&s, 3));
            }
            means[b] = acc / 256;
        }
        double mu = 0, v = 0;
        for (double x : means) mu += x / nb;
        for (double x : means) v += (x - mu) * (x - mu) / (nb - 1);
        CHECK(std::fabs(mu - exact) < 5 * std::sqrt(v / nb));
        var_of[method] = v;
    }
    CHECK(var_of[BT_METHOD_RQMC] < 0.1 * var_of[BT_METHOD_MC]);
}

TEST_CASE("streams differ across cells, batches, keys and dims; results are deterministic")
{
    for (uint method : {BT_METHOD_MC, BT_METHOD_RQMC}) {
        auto seq = [&](uint k0, uint cell, uint batch, uint dim) {
            std::vector<double> v;
            for (uint k = 0; k < 16; ++k) {
                bt_sampler s = make_sampler(method, k0, 5u, cell, batch, k);
                v.push_back(bt_uniform(&s, dim));
            }
            return v;
        };
        auto base = seq(1, 10, 0, 0);
        CHECK(base == seq(1, 10, 0, 0));  // pure function: same inputs, same bits
        CHECK(base != seq(1, 11, 0, 0));
        CHECK(base != seq(1, 10, 1, 0));
        CHECK(base != seq(2, 10, 0, 0));
        CHECK(base != seq(1, 10, 0, 1));
        // Order independence: evaluating other cells in between changes nothing.
        bt_sampler a = make_sampler(method, 1, 5, 10, 0, 3);
        double first = bt_uniform(&a, 2);
        bt_sampler other = make_sampler(method, 9, 9, 9, 9, 9);
        (void)bt_uniform(&other, 2);
        CHECK(bt_uniform(&a, 2) == first);
    }
}

namespace {

// The obvious forms, written here from the definitions in sobol.h's header
// comment, as references for the branch-free kernels.
uint reference_sobol(uint index, uint dim)
{
    const uint d = dim < BT_SOBOL_DIMS ? dim : 0u;
    uint x = 0;
    for (unsigned k = 0; index != 0; ++k, index >>= 1)
        if (index & 1u) x ^= bt_sobol_v[d][k];
    return x;
}

// "lowbias32" (C. Wellons' hash prospector), from its published constants.
uint reference_hash(uint x)
{
    x = (x ^ (x >> 16)) * 0x7FEB352Du;
    x = (x ^ (x >> 15)) * 0x846CA68Bu;
    return x ^ (x >> 16);
}

// Flip digit k (k = 0 most significant) of x, for k < digits, by the top bit
// of the hash of its node (1 << k) | (digits 0..k-1 of x).
uint reference_scramble(uint x, uint seed, unsigned digits)
{
    uint y = x;
    for (unsigned k = 0; k < digits; ++k) {
        const uint prefix = k == 0 ? 0u : x >> (32 - k);
        const uint node = (1u << k) | prefix;
        if (reference_hash((node * 0x9E3779B9u) ^ seed) >> 31) y ^= 1u << (31 - k);
    }
    return y;
}

}  // namespace

TEST_CASE("table-driven Sobol' equals the plain loop over the set bits of the index")
{
    long mismatches = 0, cases = 0;
    auto check = [&](uint index, uint dim) {
        ++cases;
        if (bt_sobol_u32(index, dim) != reference_sobol(index, dim)) ++mismatches;
    };
    // Every entry of every nibble table: the index n << 4j selects entry n of
    // table j; dims 8 and up fall back to dim 0.
    for (uint dim = 0; dim < BT_SOBOL_DIMS + 2; ++dim)
        for (unsigned j = 0; j < 8; ++j)
            for (uint n = 0; n < 16; ++n) check(n << (4 * j), dim);
    for (uint dim = 0; dim < BT_SOBOL_DIMS; ++dim) {
        check(0xFFFFFFFFu, dim);
        for (uint index = 0; index < 4096; ++index) check(index, dim);
    }
    std::mt19937 rng(12345);
    for (int t = 0; t < 200000; ++t) check(rng(), rng() % (BT_SOBOL_DIMS + 1));
    CHECK(cases > 200000);
    CHECK(mismatches == 0);
    // The reference itself, on known points: dim 0 is the bit reversal.
    CHECK(reference_sobol(1, 0) == 0x80000000u);
    CHECK(reference_sobol(6, 0) == 0x60000000u);
    CHECK(reference_sobol(3, 1) == (0x80000000u ^ 0xC0000000u));
}

TEST_CASE("both Owen-scramble forms equal the plain reference, bit for bit")
{
    CHECK(bt_hash32(0x12345678u) == reference_hash(0x12345678u));
    std::mt19937 rng(777);
    long mismatches_loop = 0, mismatches_chain = 0, mismatches_default = 0, cases = 0;
    auto check = [&](uint x, uint seed, unsigned digits) {
        ++cases;
        const uint r = reference_scramble(x, seed, digits);
        if (bt_owen_scramble_loop(x, seed, digits) != r) ++mismatches_loop;
        if (bt_owen_scramble_chain(x, seed, digits) != r) ++mismatches_chain;
        if (digits == BT_SOBOL_SCRAMBLE_BITS && bt_owen_scramble(x, seed) != r)
            ++mismatches_default;
    };
    // 32 digits (double), 24 (float on a device), and a few others.
    for (unsigned digits : {32u, 24u, 1u, 7u, 31u}) {
        check(0u, 0u, digits);
        check(0xFFFFFFFFu, 0xFFFFFFFFu, digits);
        for (int t = 0; t < 40000; ++t) check(rng(), rng(), digits);
    }
    // Sobol' points under realistic seeds.
    for (uint dim = 0; dim < BT_SOBOL_DIMS; ++dim)
        for (uint index = 0; index < 2048; ++index)
            check(bt_sobol_u32(index, dim), bt_scramble_seed(3u, 4u, 99u, index >> 8, dim), 32u);
    CHECK(cases > 200000);
    CHECK(mismatches_loop == 0);
    CHECK(mismatches_chain == 0);
    CHECK(mismatches_default == 0);
    // The scramble moves points: a reference that returned x would fail above
    // only if the kernels did too, so check that it flips something.
    int moved = 0;
    for (uint x = 0; x < 64; ++x) moved += reference_scramble(x << 26, 0xABCDu, 32) != (x << 26);
    CHECK(moved > 48);
}

TEST_CASE("RQMC uniforms equal the reference Sobol' point, scrambled by the reference")
{
    std::mt19937 rng(4242);
    long mismatches = 0;
    for (int t = 0; t < 20000; ++t) {
        bt_sampler s = make_sampler(BT_METHOD_RQMC, rng(), rng(), rng() % 100000, rng() % 64,
                                    rng() % 65536);
        const uint dim = rng() % BT_SOBOL_DIMS;
        const uint seed = bt_scramble_seed(s.key0, s.key1, s.cell, s.batch, dim);
        const double expected =
            std::ldexp((double)reference_scramble(reference_sobol(s.sample, dim), seed, 32), -32);
        if (bt_uniform(&s, dim) != expected) ++mismatches;
    }
    CHECK(mismatches == 0);
}
