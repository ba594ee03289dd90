// derived.cpp — the tables a spec forms from its other tables, with no
// computing of their own: [[recombined]] (polynomial combinations),
// [[errors]] (cell-by-cell comparisons) and [[inverted]] (inverse of a 1-D
// table).  Each names its sources, which must exist and fit together.
#include <algorithm>
#include <cmath>

#include "host/spec/parser.h"

namespace brdftab::spec_detail {

namespace {

// Tables combined cell by cell must have the same axes and nodes.
bool same_axes(const TableSpec& a, const TableSpec& b) {
    bool same = a.axes.size() == b.axes.size();
    for (std::size_t k = 0; same && k < a.axes.size(); ++k)
        same = a.axes[k].name == b.axes[k].name && a.axes[k].values == b.axes[k].values &&
               // a critical axis on an eta axis holds t_k: its warp must match too
               a.axes[k].depends_on == b.axes[k].depends_on &&
               (!a.axes[k].dependent() || (a.axes[k].critical_node == b.axes[k].critical_node &&
                                           a.axes[k].grading == b.axes[k].grading &&
                                           a.axes[k].min == b.axes[k].min &&
                                           a.axes[k].max == b.axes[k].max));
    return same;
}

}  // namespace

std::string Parser::derived_name(const toml::table& t, const std::string& prefix,
                                 std::map<std::string, Pos>& names, const char* what) const {
    auto name = get_string(t, prefix, "name");
    if (!name || name->empty())
        fail(pos_of(t), sub(prefix, "name"), std::string("missing; give the ") + what + " a name");
    for (char c : *name)
        if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
              c == '_' || c == '-'))
            fail(pos_of(*t.get("name")), sub(prefix, "name"),
                 "invalid table name '" + *name + "'; allowed: letters, digits, '_' and '-'");
    if (names.count(*name))
        fail(pos_of(*t.get("name")), sub(prefix, "name"),
             "duplicate table name '" + *name + "' (used at line " +
                 std::to_string(names.at(*name).line) + ")");
    names.emplace(*name, pos_of(t));
    return *name;
}

const TableSpec& Parser::source_table(const toml::table& t, const std::string& prefix,
                                      const char* key, const Spec& spec, bool allow_recombined,
                                      const std::string& hint) const {
    auto tname = get_string(t, prefix, key);
    if (!tname) fail(pos_of(t), sub(prefix, key), "missing; " + hint);
    std::vector<std::string> allowed;
    for (const TableSpec& x : spec.tables) {
        allowed.push_back(x.name);
        if (x.name == *tname) return x;
    }
    if (allow_recombined)
        for (const RecombinedSpec& r : spec.recombined) {
            allowed.push_back(r.name);
            if (r.name == *tname)
                for (const TableSpec& x : spec.tables)  // terms were checked to exist
                    if (x.name == r.terms.front().first) return x;
        }
    fail(pos_of(*t.get(key)), sub(prefix, key),
         "no table '" + *tname + "' in this spec; allowed: " + join(allowed));
}

RecombinedSpec Parser::parse_recombined(const toml::table& t, const std::string& prefix,
                                        const Spec& spec,
                                        std::map<std::string, Pos>& names) const {
    check_keys(t, prefix, {"name", "description", "parameter", "range", "stored_at", "terms"});
    const Pos tpos = pos_of(t);
    RecombinedSpec r;
    r.name = derived_name(t, prefix, names, "recombined table");
    if (auto d = get_string(t, prefix, "description")) r.description = *d;
    auto param = get_string(t, prefix, "parameter");
    if (!param || param->empty())
        fail(tpos, sub(prefix, "parameter"), "missing; name the user parameter, e.g. \"rho\"");
    r.parameter = *param;

    if (const toml::node* rn = t.get("range")) {
        const toml::array* ra = rn->as_array();
        const std::string rkey = sub(prefix, "range");
        if (!ra || ra->size() != 2) fail(pos_of(*rn), rkey, "must be [min, max]");
        const double lo = number((*ra)[0], indexed(rkey, 0)), hi = number((*ra)[1], indexed(rkey, 1));
        if (!(lo < hi)) fail(pos_of(*rn), rkey, "min must be less than max");
        r.range = std::make_pair(lo, hi);
    }
    r.stored_at = r.range ? r.range->second : 1.0;
    if (auto at = get_number(t, prefix, "stored_at")) {
        if (r.range && (*at < r.range->first || *at > r.range->second))
            fail(pos_of(*t.get("stored_at")), sub(prefix, "stored_at"),
                 "value " + num(*at) + " is outside range [" + num(r.range->first) + ", " +
                     num(r.range->second) + "]");
        r.stored_at = *at;
    }

    const toml::array* terms = get_table_array(t, prefix, "terms");
    if (!terms || terms->empty())
        fail(tpos, sub(prefix, "terms"),
             "missing; give [[recombined.terms]] entries with table and coeffs");
    const TableSpec* first = nullptr;
    for (std::size_t k = 0; k < terms->size(); ++k) {
        const std::string tp = indexed(sub(prefix, "terms"), k);
        const toml::table& term = *(*terms)[k].as_table();
        check_keys(term, tp, {"table", "coeffs"});
        const TableSpec* ts =
            &source_table(term, tp, "table", spec, false, "name a table of this spec");
        const std::string* tname = &ts->name;
        if (!first) {
            first = ts;
        } else if (!same_axes(*first, *ts)) {
            fail(pos_of(*term.get("table")), sub(tp, "table"),
                 "table '" + *tname + "' has other axes than '" + first->name +
                     "'; recombined terms must share every axis and node");
        }
        const toml::node* cn = term.get("coeffs");
        if (!cn || !cn->as_array() || cn->as_array()->empty())
            fail(cn ? pos_of(*cn) : pos_of(term), sub(tp, "coeffs"),
                 "must be a non-empty array of numbers: coefficients of p^0, p^1, ...");
        std::vector<double> coeffs;
        for (std::size_t j = 0; j < cn->as_array()->size(); ++j)
            coeffs.push_back(number((*cn->as_array())[j], indexed(sub(tp, "coeffs"), j)));
        r.terms.emplace_back(*tname, coeffs);
    }
    return r;
}

ErrorTableSpec Parser::parse_error_table(const toml::table& t, const std::string& prefix,
                                         const Spec& spec,
                                         std::map<std::string, Pos>& names) const {
    check_keys(t, prefix, {"name", "description", "table", "reference", "measure", "floor", "by"});
    ErrorTableSpec e;
    e.name = derived_name(t, prefix, names, "error table");
    if (auto d = get_string(t, prefix, "description")) e.description = *d;
    const TableSpec& approx = source_table(t, prefix, "table", spec, true,
                                           "name the table to measure, e.g. \"brdf_fit\"");
    const TableSpec& ref = source_table(t, prefix, "reference", spec, true,
                                        "name the reference table, e.g. \"brdf_mc\"");
    e.table = *get_string(t, prefix, "table");
    e.reference = *get_string(t, prefix, "reference");
    const Pos rpos = pos_of(*t.get("reference"));
    if (e.table == e.reference)
        fail(rpos, sub(prefix, "reference"),
             "'" + e.reference + "' is also the measured table; name a different reference");
    if (!same_axes(approx, ref))
        fail(rpos, sub(prefix, "reference"),
             "table '" + e.reference + "' has other axes than '" + e.table +
                 "'; compared tables must share every axis and node");
    const std::string ua = model_->quantity(approx.quantity).units;
    const std::string ur = model_->quantity(ref.quantity).units;
    if (ua != ur)
        fail(rpos, sub(prefix, "reference"),
             "'" + e.table + "' is in " + ua + " but '" + e.reference + "' in " + ur +
                 "; compared tables must have the same units");
    if (auto m = get_string(t, prefix, "measure")) {
        if (*m != "relative" && *m != "absolute")
            fail(pos_of(*t.get("measure")), sub(prefix, "measure"),
                 "unknown measure '" + *m + "'; allowed: relative, absolute");
        e.relative = *m == "relative";
    }
    if (auto f = get_number(t, prefix, "floor")) {
        if (!(*f >= 0) || !std::isfinite(*f))
            fail(pos_of(*t.get("floor")), sub(prefix, "floor"),
                 "value " + num(*f) + " is out of range; allowed: a number >= 0");
        if (!e.relative)
            fail(pos_of(*t.get("floor")), sub(prefix, "floor"),
                 "applies to measure = \"relative\" only");
        e.floor = *f;
    }
    if (auto by = get_string(t, prefix, "by")) {
        std::vector<std::string> axis_names;
        for (const Axis& a : approx.axes) axis_names.push_back(a.name);
        if (std::find(axis_names.begin(), axis_names.end(), *by) == axis_names.end())
            fail(pos_of(*t.get("by")), sub(prefix, "by"),
                 "'" + *by + "' is not an axis of '" + e.table + "'; allowed: " +
                     join(axis_names));
        e.by = *by;
    }
    return e;
}

InvertedSpec Parser::parse_inverted(const toml::table& t, const std::string& prefix,
                                    const Spec& spec, std::map<std::string, Pos>& names) const {
    check_keys(t, prefix, {"name", "description", "table", "axis"});
    InvertedSpec v;
    v.name = derived_name(t, prefix, names, "inverted table");
    if (auto d = get_string(t, prefix, "description")) v.description = *d;
    const TableSpec& src = source_table(t, prefix, "table", spec, false,
                                       "name the 1-D table to invert, e.g. \"kd_mc\"");
    v.table = src.name;
    if (src.axes.size() != 1)
        fail(pos_of(*t.get("table")), sub(prefix, "table"),
             "table '" + src.name + "' has " + std::to_string(src.axes.size()) +
                 " axes; only a table with one axis can be inverted");
    const toml::table* at = get_table(t, prefix, "axis");
    if (!at)
        fail(pos_of(t), sub(prefix, "axis"),
             "missing; give the new axis of " + src.name + "'s values, e.g. [" + prefix +
                 ".axis] with name, range and count");
    const std::string units = model_->quantity(src.quantity).units;
    v.axis = parse_axis(*at, sub(prefix, "axis"), units.c_str()).axis;
    if (v.axis.name == src.axes.front().name)
        fail(pos_of(*at->get("name")), sub(sub(prefix, "axis"), "name"),
             "'" + v.axis.name + "' is the axis of '" + src.name +
                 "'; name the new axis after its values (e.g. the quantity)");
    return v;
}

}  // namespace brdftab::spec_detail
