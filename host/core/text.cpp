#include "host/core/text.h"

#include <cstdio>
#include <sstream>

namespace brdftab {

std::string number_text(double v, int digits) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.*g", digits, v);
    return buf;
}

}  // namespace brdftab

namespace brdftab {

std::string unit_suffix(const std::string& unit) {
    return unit.empty() || unit == "1" ? std::string() : " " + unit;
}

std::string scientific_text(double v, int digits) {
    std::ostringstream s;
    s.precision(digits);
    s << std::scientific << v;
    return s.str();
}

}  // namespace brdftab
