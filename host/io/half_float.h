// half_float.h — IEEE binary16 ("half") conversion for tables stored with
// stored_type = float16.  Kept apart from the HDF5 code: the rounding rule is
// ours (see half_float.cpp) and testable without a file.  Not installed.
#pragma once

#include <cstdint>

namespace brdftab {

// Double -> binary16 bits, correctly rounded (nearest, ties to even); NaN
// becomes a quiet NaN.
std::uint16_t half_bits(double d);

// binary16 bits -> double (exact: every half is a float and a double).
double half_to_double(std::uint16_t bits);

}  // namespace brdftab
