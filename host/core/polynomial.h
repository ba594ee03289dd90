// polynomial.h — a polynomial in one variable from its coefficients of p^0,
// p^1, ... (Horner's rule), the one evaluation of a [[recombined]] recipe's
// coefficients C_k(p): where generate stores a recombined table
// (host/generate/derived.cpp), where the planner bounds its error
// (host/plan/plan.cpp), where a certificate recomputes its cells
// (host/plan/certify.cpp) and where a lookup combines its terms
// (host/lookup/recombine.cpp).  One evaluation order, so all four agree bit
// for bit.
#pragma once

#include <cstddef>
#include <vector>

namespace brdftab {

inline double polynomial_at(const std::vector<double>& coeffs, double p) {
    double v = 0;
    for (std::size_t k = coeffs.size(); k-- > 0;) v = v * p + coeffs[k];
    return v;
}

}  // namespace brdftab
