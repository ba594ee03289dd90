// test_bit_rounding.cpp — storage rounded to what a table's accuracy needs
// (host/io/bit_rounding.h, docs/format.md "Rounded storage").
//
// Oracles, none sharing code with the rounding under test:
//   - round to nearest on the kept bits by integer masks of the binary32 /
//     binary16 bit patterns (the two neighbours with the trailing bits zero,
//     distances in long double, ties to the even kept bit), for the relative
//     rule;
//   - exact integer arithmetic on the double's 53-bit significand for the
//     absolute rule's quantum;
//   - the per-value bounds of the rules, on every value;
//   - the file read back through the HDF5 C API (the stored bits) and the
//     linear-interpolation identity |interp(rounded) - interp(v)| <= bound,
//     which bounds how far a certificate can move.
#include <doctest/doctest.h>

#include <hdf5.h>

#include <cfloat>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <unistd.h>

#include "host/core/error.h"
#include "host/engine/engine.h"
#include "host/generate/generate.h"
#include "host/io/bit_rounding.h"
#include "host/io/half_float.h"
#include "host/io/table_io.h"
#include "host/plan/certify.h"
#include "host/spec/spec.h"

using namespace brdftab;

namespace {

std::string temp_path(const std::string& name) {
    const auto dir = std::filesystem::temp_directory_path() / ("bt_test_bit_rounding_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    return (dir / name).string();
}

std::uint32_t bits_of(float f) {
    std::uint32_t u;
    std::memcpy(&u, &f, 4);
    return u;
}
float float_of(std::uint32_t u) {
    float f;
    std::memcpy(&f, &u, 4);
    return f;
}

// Round |v| to m kept mantissa bits of binary32 by bit masks: the largest
// float <= |v| (truncation), its trailing 23 - m bits cleared (lo), lo plus
// one unit of the last kept bit (hi); the nearer of the two, a tie to the one
// whose last kept bit is 0.  Beyond the largest finite: infinity (hi's bit
// pattern 0x7f800000 stands for 2^128 in the comparison).
float oracle_float(double v, int m) {
    if (v == 0 || !std::isfinite(v)) return static_cast<float>(v);
    const double a = std::fabs(v);
    float t = static_cast<float>(a);
    if (double(t) > a) t = std::nextafter(t, 0.0f);
    const std::uint32_t unit = std::uint32_t(1) << (23 - m);
    const std::uint32_t lo = bits_of(t) & ~(unit - 1), hi = lo + unit;
    const long double lo_v = float_of(lo);
    const long double hi_v = hi >= 0x7f800000u ? std::ldexp(1.0L, 128) : (long double)float_of(hi);
    const long double dlo = (long double)a - lo_v, dhi = hi_v - (long double)a;
    std::uint32_t pick;
    if (dlo < dhi) pick = lo;
    else if (dhi < dlo) pick = hi;
    else pick = (lo & unit) == 0 ? lo : hi;
    const float r = pick >= 0x7f800000u ? std::numeric_limits<float>::infinity() : float_of(pick);
    return v < 0 ? -r : r;
}

// The same for binary16 (10 mantissa bits, largest finite 65504).
std::uint16_t oracle_half(double v, int m) {
    if (!std::isfinite(v) || v == 0) return half_bits(v);
    const double a = std::fabs(v);
    std::uint16_t t = half_bits(a);  // nearest; step down to the truncation
    if (half_to_double(t) > a) --t;
    const std::uint16_t unit = std::uint16_t(1u << (10 - m));
    const std::uint16_t lo = std::uint16_t(t & ~(unit - 1)), hi = std::uint16_t(lo + unit);
    const long double lo_v = half_to_double(lo);
    const long double hi_v = hi >= 0x7c00 ? 65536.0L : (long double)half_to_double(hi);
    const long double dlo = (long double)a - lo_v, dhi = hi_v - (long double)a;
    std::uint16_t pick;
    if (dlo < dhi) pick = lo;
    else if (dhi < dlo) pick = hi;
    else pick = (lo & unit) == 0 ? lo : hi;
    if (pick >= 0x7c00) pick = 0x7c00;
    return std::uint16_t(pick | (v < 0 ? 0x8000 : 0));
}

// v rounded to the nearest multiple of 2^k (ties to the even multiple) with
// integers: v = M 2^E, M a 53-bit integer.
double oracle_multiple(double v, int k) {
    if (v == 0 || !std::isfinite(v)) return v;
    int e2;
    const double fr = std::frexp(std::fabs(v), &e2);       // |v| = fr 2^e2, fr in [0.5, 1)
    const std::uint64_t M = std::uint64_t(std::ldexp(fr, 53));  // exact
    const int E = e2 - 53;
    double r;
    if (E >= k) {
        r = std::fabs(v);
    } else {
        const int shift = k - E;
        if (shift > 60) {
            r = 0;  // |v| < 2^(k-7): far below half a quantum
        } else {
            std::uint64_t q = M >> shift;
            const std::uint64_t rem = M & ((std::uint64_t(1) << shift) - 1), half = std::uint64_t(1) << (shift - 1);
            if (rem > half || (rem == half && (q & 1))) ++q;
            r = std::ldexp(double(q), k);
        }
    }
    return std::copysign(r, v);
}

// Random doubles over many magnitudes and both signs, with the edge cases.
std::vector<double> test_values(std::uint64_t seed, std::size_t n) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(0, 1);
    std::vector<double> v = {0.0, -0.0, 1.0, -1.0, 0.5, 3.0, FLT_MIN, -FLT_MIN, FLT_MIN / 3, 1e-40, -1e-45,
                             4.9e-324, DBL_MIN, 1e-300, FLT_MAX, -FLT_MAX, 0.999 * FLT_MAX, 65504, 65519,
                             6.1e-5, 6.0e-5, 1e-7, std::numeric_limits<double>::infinity(),
                             -std::numeric_limits<double>::infinity(), std::nan("")};
    for (std::size_t i = 0; i < n; ++i) {
        const double mag = std::ldexp(1.0 + u(rng), int(std::floor(u(rng) * 120)) - 60);
        v.push_back(u(rng) < 0.5 ? -mag : mag);
    }
    // Exact midpoints between neighbours of a 9-bit grid: 1 + (2k+1) 2^-10.
    for (int k = 0; k < 64; ++k) v.push_back(1.0 + (2 * k + 1) * std::ldexp(1.0, -10));
    return v;
}

}  // namespace

TEST_CASE("kept bits: the fewest whose rounding stays within 10 % of the accuracy") {
    // Relative: m is the smallest with 2^-(m+1) <= 0.1 E.
    for (double e : {1.0, 0.3, 1e-1, 1e-2, 3e-3, 1e-3, 1e-4, 1e-5}) {
        CAPTURE(e);
        const RoundingRule r = value_rounding(StoredType::Float32, e, false);
        REQUIRE(r.active());
        CHECK(std::ldexp(1.0, -(r.keep_bits + 1)) <= 0.1 * e);
        if (r.keep_bits > 0) CHECK(std::ldexp(1.0, -r.keep_bits) > 0.1 * e);
        CHECK(r.bound == std::ldexp(1.0, -(r.keep_bits + 1)));
    }
    CHECK(value_rounding(StoredType::Float32, 1e-2, false).keep_bits == 9);  // 2^-10 = 9.8e-4
    CHECK(value_rounding(StoredType::Float32, 1e-3, false).keep_bits == 13);
    // Needing the type's bits or more: inactive (the type's own rounding).
    CHECK_FALSE(value_rounding(StoredType::Float32, 1e-7, false).active());
    CHECK_FALSE(value_rounding(StoredType::Float16, 1e-3, false).active());
    CHECK(value_rounding(StoredType::Float16, 1e-2, false).keep_bits == 9);
    // Absolute: the largest power of two q with q/2 <= 0.1 E.
    for (double e : {1.0, 1e-2, 1e-3, 1e-4, 7e-5}) {
        CAPTURE(e);
        const RoundingRule r = value_rounding(StoredType::Float32, e, true);
        REQUIRE(r.active());
        CHECK(r.quantum / 2 <= 0.1 * e);
        CHECK(r.quantum > 0.1 * e);
        CHECK(std::ilogb(r.quantum) == std::log2(r.quantum));
    }
    // For values up to 1 (an albedo) at 1e-4 absolute: 0.1 E = 1e-5, so
    // q = 2^-16 (q/2 = 7.6e-6; 2^-15 / 2 = 1.5e-5 is too much), which keeps
    // 15 bits at the top of [0.5, 1).
    const RoundingRule a = value_rounding(StoredType::Float32, 1e-4, true);
    CHECK(a.quantum == std::ldexp(1.0, -16));
    CHECK(absolute_keep_bits(0.9, a) == 15);
    CHECK(absolute_keep_bits(1e-6, a) == 0);
    // Not asked for: nothing.
    CHECK_FALSE(value_rounding(StoredType::Float32, 0, false).active());
}

TEST_CASE("relative rounding is round to nearest on the kept bits (binary32 and binary16 bit masks)") {
    const std::vector<double> values = test_values(1, 20000);
    // (m = 0 keeps the implicit bit alone: the grid is the powers of two, and
    // a tie goes to the even multiple of the spacing, the larger one; that
    // case is checked below, not against the bit-pattern tie rule.)
    for (int m : {1, 2, 5, 9, 13, 22}) {
        CAPTURE(m);
        RoundingRule r;
        r.type = StoredType::Float32;
        r.keep_bits = m;
        r.bound = std::ldexp(1.0, -(m + 1));
        const std::uint32_t trailing = (std::uint32_t(1) << (23 - m)) - 1;
        for (double v : values) {
            CAPTURE(v);
            const float got = round_to_float(v, r);
            if (std::isnan(v)) {
                CHECK(std::isnan(got));
                continue;
            }
            const float want = oracle_float(v, m);
            CHECK(bits_of(got) == bits_of(want));
            CHECK(double(got) == round_value(v, r));
            // The trailing bits are zero, in normal and subnormal floats.
            if (std::isfinite(got)) CHECK((bits_of(got) & trailing) == 0);
            // The bound, relative to max(|v|, the smallest normal float).
            if (std::isfinite(v) && std::isfinite(got))
                CHECK(std::fabs(double(got) - v) <= r.bound * std::max(std::fabs(v), double(FLT_MIN)));
        }
    }
    for (int m : {1, 3, 6, 9}) {
        CAPTURE(m);
        RoundingRule r;
        r.type = StoredType::Float16;
        r.keep_bits = m;
        r.bound = std::ldexp(1.0, -(m + 1));
        for (double v : values) {
            if (std::isnan(v)) continue;
            CAPTURE(v);
            const std::uint16_t got = round_to_half(v, r);
            CHECK(got == oracle_half(v, m));
            if ((got & 0x7c00) != 0x7c00) {
                CHECK((got & ((1u << (10 - m)) - 1)) == 0);
                if (std::isfinite(v))
                    CHECK(std::fabs(half_to_double(got) - v) <= r.bound * std::max(std::fabs(v), std::ldexp(1.0, -14)));
            }
        }
    }
    // m = 0: powers of two, within half the value.
    RoundingRule r0;
    r0.keep_bits = 0;
    CHECK(round_value(3.0, r0) == 4.0);   // the tie: 2 = 1 x 2, 4 = 2 x 2
    CHECK(round_value(2.9, r0) == 2.0);
    CHECK(round_value(-3.1, r0) == -4.0);
    CHECK(round_value(0.7, r0) == 0.5);
    // Ties go to the even kept bit: 1 + 2^-10 lies halfway between 1 and
    // 1 + 2^-9 on a 9-bit grid and rounds to 1; 1 + 3 2^-10 rounds up to 1 + 2^-8.
    RoundingRule r9;
    r9.keep_bits = 9;
    CHECK(round_value(1 + std::ldexp(1.0, -10), r9) == 1.0);
    CHECK(round_value(1 + 3 * std::ldexp(1.0, -10), r9) == 1 + std::ldexp(1.0, -8));
    // A value whose rounding carries beyond the largest finite float becomes
    // infinite, as the plain conversion does beyond its range.
    CHECK(std::isinf(round_to_float(0.9999 * FLT_MAX, r9)));
    CHECK(round_to_float(0.99 * FLT_MAX, r9) == oracle_float(0.99 * FLT_MAX, 9));
}

TEST_CASE("absolute rounding: the nearest multiple of the quantum (exact integer arithmetic)") {
    const std::vector<double> values = test_values(2, 20000);
    for (double e : {1e-1, 1e-3, 1e-4, 3e-7, 1e-12}) {
        CAPTURE(e);
        const RoundingRule r = value_rounding(StoredType::Float32, e, true);
        REQUIRE(r.active());
        const int k = std::ilogb(r.quantum);
        for (double v : values) {
            if (std::isnan(v)) continue;
            CAPTURE(v);
            const double got = round_value(v, r);
            if (!std::isfinite(v) || std::fabs(v) > FLT_MAX) {
                CHECK(got == double(static_cast<float>(v)));
                continue;
            }
            // Where float's own spacing is coarser than the quantum, the
            // plain conversion; elsewhere the nearest multiple, exactly.
            const int ev = std::max(std::ilogb(v), -126);
            if (ev - 23 >= k) {
                CHECK(got == double(static_cast<float>(v)));
            } else {
                const double want = oracle_multiple(v, k);
                CHECK(got == want);
                CHECK(std::fabs(got - v) <= r.bound);
                // Trailing bits: a multiple of 2^k keeps at most ev - k bits.
                if (got != 0 && std::isfinite(got)) {
                    const int eg = std::max(std::ilogb(got), -126);
                    const int kept = std::min(23, eg - k);
                    if (kept >= 0 && kept < 23) CHECK((bits_of(float(got)) & ((1u << (23 - kept)) - 1)) == 0);
                }
            }
        }
    }
}

TEST_CASE("a rounded table: the stored bits are the rounded values, with the rounding attributes") {
    TableData t;
    t.name = "values";
    t.model = "rough-dielectric";
    t.quantity = "albedo_r";
    t.units = "1";
    Axis x;
    x.name = "x";
    x.count = 400;
    x.min = 0;
    x.max = 1;
    x.spacing = Spacing::Linear;
    for (std::size_t i = 0; i < x.count; ++i) x.values.push_back(double(i) / (x.count - 1));
    t.axes = {x};
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> u(-2, 2);
    for (std::size_t i = 0; i < x.count; ++i) {
        t.value.push_back(u(rng) * std::pow(10.0, u(rng)));
        t.stderr_.push_back(std::fabs(t.value.back()) * 1e-3 * (1 + u(rng)));
    }
    t.value[0] = 0;
    t.value[1] = -0.0;
    t.value[2] = std::numeric_limits<double>::infinity();
    t.value[3] = 1e-42;  // a float subnormal
    for (bool absolute : {false, true}) {
        CAPTURE(absolute);
        TableData r = t;
        r.round_accuracy = absolute ? 1e-3 : 1e-2;
        r.round_absolute = absolute;
        const std::string path = temp_path(absolute ? "abs.h5" : "rel.h5");
        write_tables(path, {r});
        const TableData back = read_table(path, "values");
        CHECK(back.round_accuracy == r.round_accuracy);
        CHECK(back.round_absolute == absolute);
        const RoundingRule vr = value_rounding(r), sr = stderr_rounding(r);
        REQUIRE(vr.active());
        REQUIRE(sr.active());
        CHECK(sr.keep_bits == kStderrKeepBits);
        // The stored float bits, read with the HDF5 C API.
        std::vector<float> raw(x.count), raw_err(x.count);
        hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
        REQUIRE(f >= 0);
        hid_t ds = H5Dopen2(f, "/values/value", H5P_DEFAULT);
        REQUIRE(H5Dread(ds, H5T_NATIVE_FLOAT, H5S_ALL, H5S_ALL, H5P_DEFAULT, raw.data()) >= 0);
        H5Dclose(ds);
        ds = H5Dopen2(f, "/values/stderr", H5P_DEFAULT);
        REQUIRE(H5Dread(ds, H5T_NATIVE_FLOAT, H5S_ALL, H5S_ALL, H5P_DEFAULT, raw_err.data()) >= 0);
        H5Dclose(ds);
        hid_t g = H5Gopen2(f, "/values", H5P_DEFAULT);
        auto int_attr = [&](const char* name) {
            std::int32_t v = -1;
            hid_t a = H5Aopen(g, name, H5P_DEFAULT);
            REQUIRE(a >= 0);
            H5Aread(a, H5T_NATIVE_INT32, &v);
            H5Aclose(a);
            return v;
        };
        auto double_attr = [&](const char* name) {
            double v = -1;
            hid_t a = H5Aopen(g, name, H5P_DEFAULT);
            REQUIRE(a >= 0);
            H5Aread(a, H5T_NATIVE_DOUBLE, &v);
            H5Aclose(a);
            return v;
        };
        const int keep = int_attr("keep_bits");
        CHECK(double_attr("rounding_bound") == vr.bound);
        CHECK(double_attr("rounding_accuracy") == r.round_accuracy);
        CHECK(int_attr("stderr_keep_bits") == kStderrKeepBits);
        H5Gclose(g);
        H5Fclose(f);
        double max_abs = 0;
        for (double v : t.value)
            if (std::isfinite(v)) max_abs = std::max(max_abs, std::fabs(v));
        if (absolute) CHECK(keep == absolute_keep_bits(max_abs, vr));
        else CHECK(keep == vr.keep_bits);
        for (std::size_t i = 0; i < x.count; ++i) {
            CAPTURE(i);
            CAPTURE(t.value[i]);
            CHECK(bits_of(raw[i]) == bits_of(round_to_float(t.value[i], vr)));
            CHECK(back.value[i] == double(raw[i]));
            CHECK(bits_of(raw_err[i]) == bits_of(round_to_float(t.stderr_[i], sr)));
            if (!std::isfinite(t.value[i])) {
                CHECK(raw[i] == t.value[i]);
                continue;
            }
            // Every value within the bound; relative: trailing bits zero.
            if (absolute) {
                CHECK(std::fabs(back.value[i] - t.value[i]) <= vr.bound);
            } else {
                CHECK(std::fabs(back.value[i] - t.value[i]) <= vr.bound * std::max(std::fabs(t.value[i]), double(FLT_MIN)));
                CHECK((bits_of(raw[i]) & ((1u << (23 - keep)) - 1)) == 0);
            }
            CHECK(std::fabs(back.stderr_[i] - t.stderr_[i]) <= sr.bound * std::fabs(t.stderr_[i]));
        }
        // Written again as read, nothing moves (rounding is idempotent).
        const std::string again = temp_path("again.h5");
        write_tables(again, {back});
        const TableData back2 = read_table(again, "values");
        for (std::size_t i = 0; i < x.count; ++i) CHECK(back2.value[i] == back.value[i]);
    }
    // A table without rounding writes no rounding attribute and the plain float cast.
    const std::string plain = temp_path("plain.h5");
    write_tables(plain, {t});
    const TableData p = read_table(plain, "values");
    CHECK(p.round_accuracy == 0);
    for (std::size_t i = 0; i < x.count; ++i) CHECK(p.value[i] == double(static_cast<float>(t.value[i])));
    hid_t f = H5Fopen(plain.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    hid_t g = H5Gopen2(f, "/values", H5P_DEFAULT);
    CHECK(H5Aexists(g, "keep_bits") == 0);
    CHECK(H5Aexists(g, "rounding") == 0);
    H5Gclose(g);
    H5Fclose(f);
}

TEST_CASE("a certificate still passes after rounding, and moves by at most the rounding bound") {
    // A closed-form albedo-like 2-D table (rough-dielectric brdf at fixed
    // directions over alpha and eta would do too): the BSDF over theta_i,
    // theta_o at fixed phi_d, certified in the absolute measure with linear
    // interpolation.  Linear interpolation weights are >= 0 and sum to 1, so
    // the interpolant of the rounded nodes differs from that of the exact
    // nodes by at most the rounding bound at every probe: the rounded
    // certificate's max is at most the exact one's plus the bound.
    const Spec spec = parse_spec_string(R"(
model = "rough-dielectric"
[parameters]
alpha = 0.5
eta = 1.5
phi_d = 180.0
[[tables]]
name = "brdf"
quantity = "brdf"
[[tables.axes]]
name = "theta_i"
range = [0.0, 80.0]
count = 41
[[tables.axes]]
name = "theta_o"
range = [0.0, 80.0]
count = 41
[integration]
method = "closed-form"
[output]
type = "float64"
)",
                                        "<bit rounding test>");
    auto backend = make_backend("host", Precision::Double);
    std::vector<GeneratedTable> g = generate_tables(spec, *backend, spec.integration);
    TableData exact = g.at(0).data;
    CertifyOptions o;
    o.absolute = true;
    o.target = 2e-2;  // 1/sr
    const Certificate c0 = certify_table(exact, *backend, o);
    MESSAGE("exact table: certificate max " << c0.max_error);
    REQUIRE(c0.max_error <= 0.9 * o.target);
    for (StoredType type : {StoredType::Float32, StoredType::Float64}) {
        TableData r = exact;
        r.stored_type = type;
        r.round_accuracy = o.target;
        r.round_absolute = true;
        const std::string path = temp_path("cert.h5");
        write_tables(path, {r});
        const TableData back = read_table(path, "brdf");
        const RoundingRule rule = value_rounding(r);
        REQUIRE(rule.active());
        double moved = 0;
        for (std::size_t i = 0; i < back.value.size(); ++i)
            moved = std::max(moved, std::fabs(back.value[i] - exact.value[i]));
        CHECK(moved <= rule.bound);
        CHECK(moved > 0);
        const Certificate c = certify_table(back, *backend, o);
        MESSAGE(std::string(stored_type_name(type)) << " rounded for " << o.target << ": max moved " << moved << ", certificate max "
                                       << c.max_error);
        CHECK(c.passed);
        CHECK(c.max_error <= c0.max_error + rule.bound * (1 + 1e-9));
    }
}
