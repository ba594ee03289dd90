#include "host/core/text.h"

#include <cstdio>

namespace brdftab {

std::string number_text(double v, int digits) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.*g", digits, v);
    return buf;
}

}  // namespace brdftab
