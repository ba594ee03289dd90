// half_float.cpp — binary16 conversion declared in half_float.h.
#include "host/io/half_float.h"

#include <Imath/half.h>

#include <cmath>

namespace brdftab {

// Double -> binary16 bits, correctly rounded (nearest, ties to even).
// HDF5's own double -> half conversion rounds some values wrongly, and
// Imath::half only takes a float: double -> float -> half can round twice.
// That only matters when the float lands exactly on a midpoint between two
// halves although the double did not; then the other float neighbour of the
// double decides, and we keep whichever half is nearer the double.
std::uint16_t half_bits(double d) {
    if (std::isnan(d)) return 0x7e00;  // a quiet NaN
    float f = static_cast<float>(d);
    Imath::half h(f);
    if (std::isfinite(f) && static_cast<double>(f) != d) {
        float g = std::nextafter(f, d < static_cast<double>(f) ? -INFINITY : INFINITY);
        Imath::half h2(g);
        if (h2.bits() != h.bits()) {
            double e1 = std::fabs(static_cast<double>(static_cast<float>(h)) - d);
            double e2 = std::fabs(static_cast<double>(static_cast<float>(h2)) - d);
            if (e2 < e1) h = h2;
        }
    }
    return h.bits();
}

double half_to_double(std::uint16_t bits) {
    Imath::half h;
    h.setBits(bits);
    return static_cast<double>(static_cast<float>(h));  // exact: half ⊂ float ⊂ double
}

}  // namespace brdftab
