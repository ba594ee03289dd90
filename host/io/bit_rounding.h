// bit_rounding.h — storage rounded to what a table's accuracy needs.
//
// A table generated for an accuracy E (spec [output] round_to_accuracy, and
// `generate --accuracy E` by default) keeps only the mantissa bits that E
// needs: each value is rounded to nearest (ties to even on the last kept bit)
// on a grid coarser than the stored type's own, and the bits below are zero,
// so HDF5's shuffle + deflate store them in almost no space (the idea of
// Kloewer et al., "Compressing atmospheric data into its real information
// content", Nature Computational Science 2021).  The grid is chosen so that
// the rounding error of every value stays within 10 % of E in E's measure:
//   relative: `keep_bits` m mantissa bits for every value, the smallest m
//     with 2^-(m+1) <= 0.1 E, so |stored - v| <= 2^-(m+1) max(|v|, 2^emin)
//     (emin: the type's smallest normal exponent);
//   absolute: a fixed quantum q, the largest power of two with
//     q/2 <= 0.1 E, so |stored - v| <= q/2 for every value; a value keeps
//     the mantissa bits its magnitude needs on that grid (never more than the
//     type has), the largest values the most.
// A grid finer than the stored type's own is the type's (plain rounding).
// Zero, infinities and NaN are stored as they are; a finite value whose
// rounding goes beyond the type's largest finite number becomes infinite, as
// the plain conversion does beyond its range.  docs/format.md, "Rounded
// storage".  Not installed.
#pragma once

#include <cstdint>

#include "host/core/table.h"

namespace brdftab {

// The fraction of the accuracy the rounding may use.
constexpr double kRoundingShare = 0.1;
// Mantissa bits a rounded table keeps in its stderr dataset: a standard
// error estimate from N samples is itself uncertain by about 1/sqrt(2N)
// (1.1 % at N = 4096); 6 bits round it by at most 2^-7 = 0.78 %.
constexpr int kStderrKeepBits = 6;

// How one dataset of a table is rounded.  `keep_bits` < 0 and `quantum` = 0:
// the stored type's own rounding.
struct RoundingRule {
    StoredType type = StoredType::Float32;
    int keep_bits = -1;   // relative: mantissa bits kept (0 .. the type's)
    double quantum = 0;   // absolute: the grid spacing (a power of two)
    double bound = 0;     // relative: 2^-(m+1); absolute: quantum / 2; 0: none
    bool relative() const { return keep_bits >= 0; }
    bool active() const { return keep_bits >= 0 || quantum > 0; }
};

// Explicit mantissa bits of a stored type (52, 23, 10) and its smallest
// normal exponent (-1022, -126, -14).
int mantissa_bits(StoredType type);
int min_normal_exponent(StoredType type);

// The rule for values stored as `type` under accuracy `accuracy` (> 0) in
// the relative or absolute measure.  A rule needing at least the type's
// bits is returned inactive (the type's own rounding is already finer).
RoundingRule value_rounding(StoredType type, double accuracy, bool absolute);
// The rule for a table's value dataset (inactive when round_accuracy is 0)
// and for its stderr dataset (kStderrKeepBits, relative; inactive when the
// values are not rounded).
RoundingRule value_rounding(const TableData& t);
RoundingRule stderr_rounding(const TableData& t);

// `v` rounded by `rule` and converted to the rule's type, returned as a
// double (exactly the value read back from the file).
double round_value(double v, const RoundingRule& rule);
// The same as the stored type's bits: binary32 bits, binary16 bits.
float round_to_float(double v, const RoundingRule& rule);
std::uint16_t round_to_half(double v, const RoundingRule& rule);

// Mantissa bits the largest |value| of a table keeps under an absolute rule
// (the `keep_bits` attribute of such a table); `max_abs` finite.
int absolute_keep_bits(double max_abs, const RoundingRule& rule);

}  // namespace brdftab
