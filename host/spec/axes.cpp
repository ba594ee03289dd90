// axes.cpp — [[axes]] entries of a spec: the coordinate or parameter an axis
// runs along, its range or explicit nodes, and its spacing, checked against
// the model's allowed ranges before the axis is built (host/core/grid.h).
#include <cmath>
#include <limits>
#include <map>

#include "host/core/error.h"
#include "host/spec/parser.h"

namespace brdftab::spec_detail {

Parser::AxisSrc Parser::parse_axis(const toml::table& t, const std::string& prefix,
                                   const char* free_unit) const {
    check_keys(t, prefix,
               {"name", "range", "count", "spacing", "values", "pivot", "critical_fraction",
                "grading"});
    const Pos tpos = pos_of(t);
    const std::optional<std::string> name = get_string(t, prefix, "name");
    if (!name) fail(tpos, sub(prefix, "name"), "missing; every axis needs a name");
    const Pos npos = pos_of(*t.get("name"));
    const std::string nkey = sub(prefix, "name");

    std::string unit;
    const ParameterInfo* p = free_unit ? nullptr : model_->find_parameter(*name);
    if (free_unit) {
        unit = free_unit;
    } else if (is_direction_coordinate(*name)) {
        unit = direction_unit(*name);
    } else if (p) {
        unit = p->unit.empty() ? "1" : p->unit;
    } else if (model_->find_option(*name)) {
        fail(npos, nkey, "'" + *name + "' is a categorical option and cannot be an axis; " +
                             "write one [[tables]] entry per choice instead");
    } else {
        std::vector<std::string> names = coordinate_names();
        for (const auto& q : model_->parameters) names.push_back(q.name);
        fail(npos, nkey, "'" + *name + "' is not a direction coordinate or continuous " +
                             "parameter of model '" + model_->name + "'; allowed: " + join(names));
    }
    auto accepts = [&](double v) {
        if (free_unit) return std::isfinite(v);
        return p ? p->accepts(v) : direction_accepts(*name, v);
    };
    const std::string range_text = free_unit ? std::string("finite numbers")
                                   : p       ? p->range_text()
                                             : direction_range_text(*name);

    Spacing spacing = Spacing::Linear;
    if (auto s = get_string(t, prefix, "spacing")) {
        try {
            spacing = parse_spacing(*s);
        } catch (const InputError& e) {
            fail(pos_of(*t.get("spacing")), sub(prefix, "spacing"), e.what());
        }
    }

    // Keys of one spacing only (also refused with explicit nodes).
    if (spacing != Spacing::LogComplement && t.get("pivot"))
        fail(pos_of(*t.get("pivot")), sub(prefix, "pivot"),
             "only allowed with spacing = \"log-complement\"");
    for (const char* k : {"critical_fraction", "grading"})
        if (spacing != Spacing::Critical && t.get(k))
            fail(pos_of(*t.get(k)), sub(prefix, k), "only allowed with spacing = \"critical\"");

    AxisSrc out;
    out.pos = npos;
    out.key = prefix;
    if (spacing == Spacing::Explicit) {
        if (t.get("range"))
            fail(pos_of(*t.get("range")), sub(prefix, "range"),
                 "not allowed with spacing = \"explicit\" (the nodes come from 'values')");
        if (t.get("count"))
            fail(pos_of(*t.get("count")), sub(prefix, "count"),
                 "not allowed with spacing = \"explicit\" (the count is the number of "
                 "'values')");
        const toml::node* vn = t.get("values");
        const std::string vkey = sub(prefix, "values");
        if (!vn)
            fail(tpos, vkey, "missing; spacing = \"explicit\" needs the node list "
                             "values = [v0, v1, ...] (at least 2, strictly increasing)");
        const toml::array* va = vn->as_array();
        if (!va) fail(pos_of(*vn), vkey, "must be an array of numbers");
        std::vector<double> vals;
        for (std::size_t k = 0; k < va->size(); ++k) {
            const toml::node& e = (*va)[k];
            const double x = number(e, indexed(vkey, k));
            if (!accepts(x))
                fail(pos_of(e), indexed(vkey, k),
                     "value " + num(x) + " is outside the allowed range of '" + *name +
                         "'; allowed: " + range_text);
            vals.push_back(x);
        }
        if (vals.size() > kMaxAxisCount)
            fail(pos_of(*vn), vkey,
                 "too many nodes; allowed: at most " + std::to_string(kMaxAxisCount));
        try {
            out.axis = make_axis(*name, unit, 0, 0, 0, spacing, vals);
        } catch (const InputError& e) {
            fail(pos_of(*vn), vkey, e.what());
        }
        return out;
    }

    if (const toml::node* vn = t.get("values"))
        fail(pos_of(*vn), sub(prefix, "values"),
             "only allowed with spacing = \"explicit\"; use range and count otherwise");

    const toml::node* rn = t.get("range");
    const std::string rkey = sub(prefix, "range");
    if (!rn) fail(tpos, rkey, "missing; give range = [min, max] (allowed: " + range_text + ")");
    const toml::array* ra = rn->as_array();
    if (!ra || ra->size() != 2)
        fail(pos_of(*rn), rkey, "must be an array of two numbers [min, max]");
    double ends[2];
    for (std::size_t k = 0; k < 2; ++k) ends[k] = number((*ra)[k], indexed(rkey, k));
    if (!(ends[0] < ends[1]))
        fail(pos_of(*rn), rkey,
             "min must be less than max, got [" + num(ends[0]) + ", " + num(ends[1]) + "]");
    for (std::size_t k = 0; k < 2; ++k)
        if (!accepts(ends[k]))
            fail(pos_of((*ra)[k]), indexed(rkey, k),
                 std::string(k == 0 ? "min " : "max ") + num(ends[k]) +
                     " is outside the allowed range of '" + *name + "'; allowed: " +
                     range_text);
    if (spacing == Spacing::Log && !(ends[0] > 0))
        fail(pos_of(*rn), rkey, "log spacing needs min > 0, got " + num(ends[0]));
    if (spacing == Spacing::Cos) {
        if (unit != "deg")
            fail(pos_of(*t.get("spacing")), sub(prefix, "spacing"),
                 "cos spacing is uniform in the cosine of an angle in degrees; '" + *name +
                     "' is not an angle (for mu_i/mu_o use linear spacing, which is "
                     "already uniform in the cosine)");
        if (ends[0] < 0 || ends[1] > 180)
            fail(pos_of(*rn), rkey, "cos spacing needs a range within [0, 180] deg");
    }
    const std::optional<std::int64_t> count = get_integer(t, prefix, "count");
    const std::string ckey = sub(prefix, "count");
    if (!count) fail(tpos, ckey, "missing; give count = <number of nodes, >= 2>");
    if (*count < 2 || std::uint64_t(*count) > kMaxAxisCount)
        fail(pos_of(*t.get("count")), ckey,
             "count " + std::to_string(*count) + " is out of range; allowed: 2 .. " +
                 std::to_string(kMaxAxisCount));
    if (spacing == Spacing::LogComplement) {
        // Default pivot: the name's upper limit (1 for a scattering albedo c
        // or a cosine), where such quantities have their square-root edge.
        double pivot = std::numeric_limits<double>::quiet_NaN();
        Pos ppos = pos_of(*t.get("spacing"));
        std::string pkey = sub(prefix, "spacing");
        if (const toml::node* pn = t.get("pivot")) {
            pkey = sub(prefix, "pivot");
            ppos = pos_of(*pn);
            pivot = number(*pn, pkey);
        } else if (p) {
            pivot = p->max;
        } else if (!free_unit) {
            pivot = unit == "deg" ? 180.0 : 1.0;
        }
        if (!std::isfinite(pivot) || (pivot >= ends[0] && pivot <= ends[1]))
            fail(ppos, pkey,
                 "log-complement spacing crowds the nodes towards a pivot outside the range; "
                 "give pivot = <a number above " + num(ends[1]) + " or below " + num(ends[0]) +
                     ">" + (std::isfinite(pivot) ? " (the default, " + num(pivot) +
                                                       ", lies within the range)"
                                                 : std::string()));
        try {
            out.axis = make_log_complement_axis(*name, unit, ends[0], ends[1],
                                                std::size_t(*count), pivot);
        } catch (const InputError& e) {
            fail(pos_of(*rn), rkey, e.what());
        }
        return out;
    }
    if (spacing == Spacing::Critical) {
        const Pos spos = pos_of(*t.get("spacing"));
        const std::string skey = sub(prefix, "spacing");
        if (free_unit || (*name != "mu_i" && *name != "mu_o"))
            fail(spos, skey,
                 "critical spacing places a node on the cosine of the critical angle of total "
                 "internal reflection; it is for a mu_i or mu_o axis, not '" + *name + "'");
        if (!model_->find_parameter("eta"))
            fail(spos, skey,
                 "critical spacing needs the relative index 'eta', which model '" +
                     model_->name + "' does not have");
        double fraction = 0.5, grading = 2.0;
        if (const toml::node* fn = t.get("critical_fraction")) {
            fraction = number(*fn, sub(prefix, "critical_fraction"));
            if (!(fraction > 0 && fraction < 1))
                fail(pos_of(*fn), sub(prefix, "critical_fraction"),
                     "value " + num(fraction) + " is out of range; allowed: (0, 1)");
        }
        if (const toml::node* gn = t.get("grading")) {
            grading = number(*gn, sub(prefix, "grading"));
            if (!(grading >= 1 && grading <= 4))
                fail(pos_of(*gn), sub(prefix, "grading"),
                     "value " + num(grading) + " is out of range; allowed: [1, 4]");
        }
        // eta is taken as an axis for now; resolve_critical_axes() fixes it
        // when the table holds eta fixed instead.
        try {
            const std::size_t n = std::size_t(*count);
            out.axis = make_critical_axis(*name, ends[0], ends[1], n,
                                          critical_node_for(n, fraction), grading, 0.0, "eta");
        } catch (const InputError& e) {
            fail(pos_of(*rn), rkey, e.what());
        }
        return out;
    }
    try {
        out.axis = make_axis(*name, unit, ends[0], ends[1], std::size_t(*count), spacing);
    } catch (const InputError& e) {
        fail(pos_of(*rn), rkey, e.what());
    }
    return out;
}

void Parser::resolve_critical_axes(std::vector<AxisSrc>& axes,
                                   const std::map<std::string, double>& fixed) const {
    for (AxisSrc& src : axes) {
        Axis& a = src.axis;
        if (a.spacing != Spacing::Critical) continue;
        const AxisSrc* eta_axis = nullptr;
        for (const AxisSrc& b : axes)
            if (b.axis.name == a.depends_on) eta_axis = &b;
        try {
            if (eta_axis) {
                // Every node column of the eta axis must give increasing nodes.
                check_dependent_nodes(a, eta_axis->axis.values);
            } else {
                const auto it = fixed.find(a.depends_on);
                if (it == fixed.end())
                    throw InputError("critical spacing needs '" + a.depends_on +
                                     "' as an axis or a fixed parameter of the table");
                a = make_critical_axis(a.name, a.min, a.max, a.count, a.critical_node,
                                       a.grading, it->second);
            }
        } catch (const InputError& e) {
            fail(src.pos, sub(src.key, "spacing"), e.what());
        }
    }
}

std::vector<Parser::AxisSrc> Parser::parse_axes(const toml::array& a,
                                                const std::string& prefix) const {
    std::vector<AxisSrc> out;
    for (std::size_t k = 0; k < a.size(); ++k) {
        AxisSrc ax = parse_axis(*a[k].as_table(), indexed(prefix, k));
        for (const AxisSrc& prev : out) {
            if (prev.axis.name == ax.axis.name)
                fail(ax.pos, sub(ax.key, "name"),
                     "duplicate axis '" + ax.axis.name + "' (already " + prev.key + ", line " +
                         std::to_string(prev.pos.line) + ")");
            if (group_of(prev.axis.name) == group_of(ax.axis.name))
                fail(ax.pos, sub(ax.key, "name"),
                     "axes '" + prev.axis.name + "' (" + prev.key + ", line " +
                         std::to_string(prev.pos.line) + ") and '" + ax.axis.name +
                         "' describe the same direction; use only one of them");
        }
        out.push_back(std::move(ax));
    }
    return out;
}

}  // namespace brdftab::spec_detail
