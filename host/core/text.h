// text.h — numbers in messages, labels and attributes.
#pragma once

#include <string>

namespace brdftab {

// v with `digits` significant digits, printf "%g" style (no trailing zeros;
// exponent form for very large or small magnitudes).  17 digits round-trip
// any double.
std::string number_text(double v, int digits = 10);

}  // namespace brdftab
