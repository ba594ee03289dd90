// text.h — numbers in messages, labels and attributes.
#pragma once

#include <string>

namespace brdftab {

// v with `digits` significant digits, printf "%g" style (no trailing zeros;
// exponent form for very large or small magnitudes).  17 digits round-trip
// any double.
std::string number_text(double v, int digits = 10);

// v in iostream's scientific form with `digits` digits after the point
// ("1.235e-03" for digits = 3), for plan and scene messages.
std::string scientific_text(double v, int digits = 3);

// " deg" after a number or range; "" for a pure number (unit "1" or none),
// which would read as a count ("1 to 3 1").
std::string unit_suffix(const std::string& unit);

}  // namespace brdftab
