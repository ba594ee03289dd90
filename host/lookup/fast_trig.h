// fast_trig.h — the inverse and forward trigonometry of direction lookups
// (host/lookup/directions.cpp, sample.cpp): atan2 and sin/cos as short
// branch-free polynomials, several times cheaper than the C library's
// correctly rounded functions and within a few 1e-15 rad of them
// (docs/lookup.md, "Direction lookups"; tests/test_lookup_trig.cpp measures
// the bounds against std::atan2, std::acos, std::sin and std::cos).
//
// Plain double arithmetic in a fixed order, no table and no state: the
// results depend only on the inputs (deterministic, thread safe).
//
// Coefficients: Chebyshev fits of degree 8 (atan) and 5 (sin, cos) in
// z = r^2, computed with mpmath's chebyfit at 50 digits by
// host/lookup/fast_trig_fit.py, which also prints the fits' error bounds.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace brdftab::fast_trig {

namespace detail {

// pi, pi/2, pi/4 and 3 pi/4 as double + the rest of the true value.
constexpr double kPi = 3.141592653589793, kPiLo = 1.2246467991473532e-16;
constexpr double kPi2 = 1.5707963267948966, kPi2Lo = 6.123233995736766e-17;
constexpr double kPi4 = 0.7853981633974483, kPi4Lo = 3.061616997868383e-17;
constexpr double k3Pi4 = 2.356194490192345, k3Pi4Lo = 9.184850993605148e-17;
constexpr double kTanPi8 = 0.41421356237309503;

// atan(t) = t + t z h(z), z = t^2, |t| <= tan(pi/8), where the fit of h
// errs by less than 1.7e-15 in atan(t).
inline double atan_reduced(double t) {
    const double z = t * t, z2 = z * z, z4 = z2 * z2;
    // Estrin's scheme: the pairs are independent, the chain short.
    const double p01 = -0.3333333333333093 + 0.19999999997724888 * z;
    const double p23 = -0.14285713930378566 + 0.11111089649211055 * z;
    const double p45 = -0.09090255952690657 + 0.07681045202742948 * z;
    const double p67 = -0.0655090730756309 + 0.05168834935919362 * z;
    const double p8 = -0.02723288406057488;
    const double h = (p01 + p23 * z2) + z4 * ((p45 + p67 * z2) + p8 * z4);
    return t + t * z * h;
}

}  // namespace detail

// atan2(y, x) in [-pi, pi] for finite y, x, within 2.5e-15 rad of
// std::atan2 (signed zeros as there: atan2(+-0, -0) = +-pi,
// atan2(+-0, +0) = +-0).  NaN in, NaN out.  Branch-free: the octant's
// choices are 0/1 factors and table entries, not conditional jumps, which
// would be mispredicted half of the time on random directions.
inline double atan2(double y, double x) {
    using namespace detail;
    const double ax = std::fabs(x), ay = std::fabs(y);
    const int swap = ay > ax;
    const double mx = std::max(ax, ay), mn = std::min(ax, ay);
    // Into |t| <= tan(pi/8) with one division: mn/mx, or past tan(pi/8)
    // atan(mn/mx) = pi/4 + atan((mn - mx)/(mn + mx)).
    const int big = mn > kTanPi8 * mx;
    const double b = double(big);
    const double num = mn - b * mx;
    const double den = (mx + b * mn) + double(mx == 0);  // x = y = 0: t = 0
    double a = atan_reduced(num / den);
    // a + pi/4 (big), then pi/2 - a where |y| > |x|, then pi - a where x < 0
    // (or -0): together m pi/4 + sign a, from one table entry per octant,
    // m pi/4 as a double and the rest of its true value.
    struct Octant {
        double hi, lo, sign;
    };
    static constexpr Octant kOctant[8] = {
        {0, 0, 1},          {kPi4, kPi4Lo, 1},    {kPi2, kPi2Lo, -1}, {kPi4, kPi4Lo, -1},
        {kPi, kPiLo, -1},   {k3Pi4, k3Pi4Lo, -1}, {kPi2, kPi2Lo, 1},  {k3Pi4, k3Pi4Lo, 1}};
    const Octant& o = kOctant[big | swap << 1 | int(std::signbit(x)) << 2];
    a = o.hi + (o.sign * a + o.lo);
    a += (x - x) + (y - y);  // NaN in (which max and min drop), NaN out
    return std::copysign(a, y);
}

// acos(c) for c in [-1, 1] (clamped there), as atan2(sqrt(1 - c^2), c).
inline double acos(double c) {
    c = c < -1 ? -1.0 : (c > 1 ? 1.0 : c);
    return fast_trig::atan2(std::sqrt((1 - c) * (1 + c)), c);
}

// sin(x) and cos(x) for |x| <= 1e6, within 5e-16 of std::sin, std::cos
// (absolute).  x is reduced by the nearest multiple of pi/2 (Cody and
// Waite's two-part constant: the product with its 33-bit leading part is
// exact for these x).
inline void sincos(double x, double& s, double& c) {
    constexpr double kTwoOverPi = 0.6366197723675814;
    constexpr double kPio2Hi = 1.5707963267341256, kPio2Lo = 6.077100506506192e-11;
    constexpr double kRound = 6755399441055744.0;  // 1.5 * 2^52: rounds to an integer
    const double k = (x * kTwoOverPi + kRound) - kRound;
    const double r = (x - k * kPio2Hi) - k * kPio2Lo;
    const double z = r * r, z2 = z * z;
    const double sp = (-0.16666666666666666 + 0.008333333333330948 * z) +
                      z2 * ((-0.00019841269836758574 + 2.755731610255244e-06 * z) +
                            z2 * (-2.5051131845003624e-08 + 1.5918129294866608e-10 * z));
    const double cp = (0.041666666666666664 + -0.0013888888888887398 * z) +
                      z2 * ((2.480158729876569e-05 + -2.7557317271729793e-07 * z) +
                            z2 * (2.08761462684032e-09 + -1.1382632425521717e-11 * z));
    const double sr = r + r * z * sp;
    const double cr = (1 - 0.5 * z) + z2 * cp;
    // Quadrant q: (sin, cos) = (sr, cr), (cr, -sr), (-sr, -cr), (-cr, sr),
    // chosen by index (branch-free).
    const unsigned q = unsigned(std::int64_t(k)) & 3u;
    const double v[2] = {sr, cr};
    static constexpr double kSign[2] = {1, -1};
    s = kSign[q >> 1] * v[q & 1];
    c = kSign[((q + 1) >> 1) & 1] * v[(q & 1) ^ 1];
}

}  // namespace brdftab::fast_trig
