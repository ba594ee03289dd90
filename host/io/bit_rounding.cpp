// bit_rounding.cpp — see bit_rounding.h.
#include "host/io/bit_rounding.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "host/io/half_float.h"

namespace brdftab {

int mantissa_bits(StoredType type) {
    switch (type) {
        case StoredType::Float64: return 52;
        case StoredType::Float32: return 23;
        case StoredType::Float16: return 10;
    }
    throw std::logic_error("unknown stored type");
}

int min_normal_exponent(StoredType type) {
    switch (type) {
        case StoredType::Float64: return -1022;
        case StoredType::Float32: return -126;
        case StoredType::Float16: return -14;
    }
    throw std::logic_error("unknown stored type");
}

RoundingRule value_rounding(StoredType type, double accuracy, bool absolute) {
    RoundingRule r;
    r.type = type;
    if (!(accuracy > 0) || !std::isfinite(accuracy)) return r;
    const double allowed = kRoundingShare * accuracy;
    if (!absolute) {
        // The smallest m with 2^-(m+1) <= allowed: half a unit in the last
        // kept place, relative to the value.
        int m = 0;
        while (std::ldexp(1.0, -(m + 1)) > allowed) ++m;
        if (m >= mantissa_bits(type)) return r;
        r.keep_bits = m;
        r.bound = std::ldexp(1.0, -(m + 1));
        return r;
    }
    // The largest power of two q with q/2 <= allowed: 2^floor(log2(2 allowed)).
    const int e = std::ilogb(2 * allowed);
    // A quantum below the type's smallest spacing rounds nothing.
    if (e <= min_normal_exponent(type) - mantissa_bits(type)) return r;
    r.quantum = std::ldexp(1.0, e);
    r.bound = r.quantum / 2;
    return r;
}

RoundingRule value_rounding(const TableData& t) {
    return value_rounding(t.stored_type, t.round_accuracy, t.round_absolute);
}

RoundingRule stderr_rounding(const TableData& t) {
    RoundingRule r;
    r.type = t.stored_type;
    if (!value_rounding(t).active() || kStderrKeepBits >= mantissa_bits(t.stored_type)) return r;
    r.keep_bits = kStderrKeepBits;
    r.bound = std::ldexp(1.0, -(kStderrKeepBits + 1));
    return r;
}

namespace {

// v rounded to the nearest multiple of the power of two `spacing`, ties to
// the even multiple.  v / spacing is exact (a power-of-two scaling that stays
// within double's range for the magnitudes rounded here), and so are its
// floor and the remainder.
double round_to_multiple(double v, double spacing) {
    const double t = v / spacing;
    const double f = std::floor(t);
    const double d = t - f;
    double k = f;
    if (d > 0.5 || (d == 0.5 && std::fmod(f, 2.0) != 0)) k = f + 1;
    return k == 0 ? std::copysign(0.0, v) : k * spacing;
}

// The rounded value in double (before the exact conversion to the type).
double rounded(double v, const RoundingRule& rule) {
    if (!rule.active() || v == 0 || !std::isfinite(v)) return v;
    const int p = mantissa_bits(rule.type), emin = min_normal_exponent(rule.type);
    // Beyond the type's range: the plain conversion gives the infinity.
    const int emax = rule.type == StoredType::Float16 ? 15 : rule.type == StoredType::Float32 ? 127 : 1023;
    const int e = std::max(std::ilogb(v), emin);
    if (e > emax) return v;
    double spacing = std::ldexp(1.0, e - p);  // the type's own spacing at v
    if (rule.relative())
        spacing = std::max(spacing, std::ldexp(1.0, e - rule.keep_bits));
    else
        spacing = std::max(spacing, rule.quantum);
    return round_to_multiple(v, spacing);
}

}  // namespace

double round_value(double v, const RoundingRule& rule) {
    switch (rule.type) {
        case StoredType::Float64: return rounded(v, rule);
        case StoredType::Float32: return double(static_cast<float>(rounded(v, rule)));
        case StoredType::Float16: return half_to_double(half_bits(rounded(v, rule)));
    }
    throw std::logic_error("unknown stored type");
}

float round_to_float(double v, const RoundingRule& rule) {
    // rounded() has at most 24 significant bits within float's exponent
    // range, so this conversion is exact (or overflows to infinity).
    return static_cast<float>(rounded(v, rule));
}

std::uint16_t round_to_half(double v, const RoundingRule& rule) { return half_bits(rounded(v, rule)); }

int absolute_keep_bits(double max_abs, const RoundingRule& rule) {
    const int p = mantissa_bits(rule.type);
    if (rule.relative()) return rule.keep_bits;
    if (!rule.active()) return p;
    if (!(max_abs > 0) || !std::isfinite(max_abs)) return 0;
    const int e = std::max(std::ilogb(max_abs), min_normal_exponent(rule.type));
    return std::clamp(e - std::ilogb(rule.quantum), 0, p);
}

}  // namespace brdftab
