// recombine.cpp — tables formed on lookup from several stored tables:
// value = N(p)/D(p) * sum_k C_k(p) * table_k(x), polynomials in a user
// parameter p (the "recombine" object described in lookup.h): reading the
// recipe, the parameter's range policy and the combination itself.
#include <algorithm>
#include <cmath>

#include "host/core/error.h"
#include "host/core/polynomial.h"
#include "host/lookup/lookup.h"
#include "host/lookup/lookup_internal.h"

namespace brdftab {

namespace {

std::vector<double> number_list(const nlohmann::json& j, const std::string& where) {
    if (!j.is_array() || j.empty())
        throw InputError(where + ": expected a non-empty array of numbers");
    std::vector<double> v;
    for (const auto& e : j) {
        if (!e.is_number()) throw InputError(where + ": expected a non-empty array of numbers");
        v.push_back(e.get<double>());
    }
    return v;
}

}  // namespace

namespace lookup_internal {

// Table names a "recombine" object refers to (validated shape).
std::vector<std::string> recombine_tables(const TableData& head) {
    std::vector<std::string> names;
    if (!head.parameters.is_object() || !head.parameters.contains("recombine")) return names;
    const auto& r = head.parameters["recombine"];
    const std::string where = "table '" + head.name + "': parameters.recombine";
    if (!r.is_object() || !r.contains("terms") || !r["terms"].is_array() || r["terms"].empty())
        throw InputError(where + ": expected an object with a non-empty 'terms' array");
    for (const auto& t : r["terms"]) {
        if (!t.is_object() || !t.contains("table") || !t["table"].is_string())
            throw InputError(where + ".terms: each term needs a string 'table'");
        names.push_back(t["table"].get<std::string>());
    }
    return names;
}

}  // namespace lookup_internal

using namespace lookup_internal;

// Reads the head table's "recombine" object into terms_, rparam_, the
// parameter range and the prefactor (called by init() once the pieces are
// loaded and checked).
void LookupTable::init_recombination() {
    TableData& head = pieces_.front();
    if (head.parameters.is_object() && head.parameters.contains("recombine")) {
        const auto& r = head.parameters["recombine"];
        const std::string where = "table '" + head.name + "': parameters.recombine";
        recombine_tables(head);  // shape check
        if (!r.contains("parameter") || !r["parameter"].is_string() ||
            r["parameter"].get<std::string>().empty())
            throw InputError(where + ": needs a string 'parameter'");
        rparam_ = r["parameter"].get<std::string>();
        for (const auto& a : head.axes)
            if (a.name == rparam_)
                throw InputError(where + ": parameter '" + rparam_ + "' is also a table axis");
        if (r.contains("range")) {
            auto rg = number_list(r["range"], where + ".range");
            if (rg.size() != 2 || !(rg[0] <= rg[1]))
                throw InputError(where + ".range: expected [min, max] with min <= max");
            rmin_ = rg[0];
            rmax_ = rg[1];
        }
        for (const auto& t : r["terms"]) {
            Term term;
            const std::string name = t["table"].get<std::string>();
            term.piece = pieces_.size();
            for (std::size_t k = 0; k < pieces_.size(); ++k)
                if (pieces_[k].name == name) term.piece = k;
            if (term.piece == pieces_.size())
                throw InputError(where + ": term table '" + name + "' is missing");
            if (!t.contains("coeffs"))
                throw InputError(where + ".terms: term '" + name + "' needs 'coeffs'");
            term.coeffs = number_list(t["coeffs"], where + ".terms." + name + ".coeffs");
            terms_.push_back(term);
        }
        if (r.contains("prefactor")) {
            const auto& pf = r["prefactor"];
            if (!pf.is_object()) throw InputError(where + ".prefactor: expected an object");
            if (pf.contains("num")) num_ = number_list(pf["num"], where + ".prefactor.num");
            if (pf.contains("den")) den_ = number_list(pf["den"], where + ".prefactor.den");
        }
    }
}

void LookupTable::resolve_param(double& p, OutOfRange mode) const {
    if (std::isnan(p))
        throw InputError("table '" + table().name + "': parameter '" + rparam_ + "' is NaN");
    if (p < rmin_ || p > rmax_) {
        if (mode == OutOfRange::Reject)
            throw InputError("table '" + table().name + "': parameter '" + rparam_ + "' value " +
                             fmt_num(p) + " is outside [" + fmt_num(rmin_) + ", " +
                             fmt_num(rmax_) + "]");
        p = std::min(std::max(p, rmin_), rmax_);
    }
}

double LookupTable::combine(const double* pv, double p) const {
    if (terms_.empty()) return pv[0];
    double sum = 0;
    for (const auto& t : terms_) sum += polynomial_at(t.coeffs, p) * pv[t.piece];
    const double den = polynomial_at(den_, p);
    if (den == 0)
        throw InputError("table '" + table().name + "': recombination prefactor has a zero "
                         "denominator at " + rparam_ + " = " + fmt_num(p));
    return polynomial_at(num_, p) / den * sum;
}

}  // namespace brdftab
