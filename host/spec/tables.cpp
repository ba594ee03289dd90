// tables.cpp — [parameters] blocks and [[tables]] entries of a spec: fixed
// values and options checked against the model, and each table merged with
// the global [parameters] / [[axes]] and checked against its quantity.
#include <cmath>
#include <set>

#include "host/core/error.h"
#include "host/spec/parser.h"

namespace brdftab::spec_detail {

std::string group_of(const std::string& name) {
    if (const CoordinateInfo* c = find_coordinate(name)) return to_string(c->direction);
    return name;
}

bool depends_on(const QuantityInfo& q, const std::string& coordinate) {
    // QuantityInfo::directions names kernel direction slots, i.e. groups.
    const std::string s = group_of(coordinate);
    for (const auto& d : q.directions)
        if (d == s) return true;
    return false;
}

std::string depends_text(const QuantityInfo& q) {
    if (q.directions.empty()) return "it depends on no direction";
    return "it depends on " + join(q.directions);
}

std::string Parser::allowed_names() const {
    std::vector<std::string> params, opts;
    for (const auto& p : model_->parameters) params.push_back(p.name);
    for (const auto& o : model_->options) opts.push_back(o.name);
    std::string s = join(coordinate_names()) + " (directions)";
    if (!params.empty()) s += ", " + join(params) + " (parameters)";
    if (!opts.empty()) s += ", " + join(opts) + " (options)";
    return s;
}

Parser::Block Parser::parse_parameters(const toml::table& t, const std::string& prefix) const {
    Block b;
    std::map<std::string, Fixed> by_group;
    std::vector<Pos> kposs;
    const auto entries = in_file_order(t, &kposs);
    for (std::size_t n = 0; n < entries.size(); ++n) {
        const std::string& name = entries[n].first;
        const toml::node& v = *entries[n].second;
        const std::string key = sub(prefix, name);
        const Pos kpos = kposs[n];
        const Pos vpos = pos_of(v);
        if (const OptionInfo* o = model_->find_option(name)) {
            if (!v.is_string())
                fail(vpos, key, "option '" + name + "' takes a string; allowed: " +
                                    join(o->choices));
            const std::string choice = v.as_string()->get();
            if (o->index_of(choice) < 0)
                fail(vpos, key, "'" + choice + "' is not a choice of option '" + name +
                                    "'; allowed: " + join(o->choices));
            b.options.push_back({name, choice, vpos, key});
            continue;
        }
        const bool is_dir = is_direction_coordinate(name);
        const ParameterInfo* p = model_->find_parameter(name);
        if (!is_dir && !p)
            fail(kpos, key, "not a direction, parameter or option of model '" + model_->name +
                                "'; allowed: " + allowed_names());
        double value;
        if (v.is_integer())
            value = double(v.as_integer()->get());
        else if (v.is_floating_point())
            value = v.as_floating_point()->get();
        else
            fail(vpos, key, "must be a number (" +
                                std::string(is_dir ? direction_unit(name) == "deg"
                                                         ? "degrees"
                                                         : "a cosine"
                                                   : "parameter value") +
                                ")");
        if (is_dir && !direction_accepts(name, value))
            fail(vpos, key, "value " + num(value) + " is out of range; allowed: " +
                                direction_range_text(name));
        if (p && !p->accepts(value))
            fail(vpos, key, "value " + num(value) + " is out of range; allowed: " +
                                p->range_text());
        const std::string g = group_of(name);
        auto it = by_group.find(g);
        if (it != by_group.end())
            fail(kpos, key, "'" + name + "' and '" + it->second.name + "' (line " +
                                std::to_string(it->second.pos.line) +
                                ") describe the same direction; give only one of them");
        Fixed f{name, value, vpos, key};
        by_group.emplace(g, f);
        b.fixed.push_back(f);
    }
    return b;
}

TableSpec Parser::build_table(const toml::table& t, const std::string& prefix,
                              const Block& global_params,
                              const std::vector<AxisSrc>& global_axes,
                              const IntegrationSettings& integration, Pos method_pos) const {
    check_keys(t, prefix, {"name", "quantity", "description", "parameters", "axes", "round_to_accuracy",
                           "adaptive"});
    const Pos tpos = pos_of(t);
    TableSpec ts;
    if (auto e = get_number(t, prefix, "round_to_accuracy")) {
        if (!(*e > 0) || !std::isfinite(*e))
            fail(pos_of(*t.get("round_to_accuracy")), sub(prefix, "round_to_accuracy"),
                 "value " + num(*e) + " is out of range; allowed: > 0 (the accuracy the stored "
                 "values are rounded for)");
        ts.round_accuracy = *e;
    }

    const auto qname = get_string(t, prefix, "quantity");
    std::vector<std::string> qnames;
    for (const auto& q : model_->quantities) qnames.push_back(q.name);
    if (!qname)
        fail(tpos, sub(prefix, "quantity"),
             "missing; every table needs a quantity; allowed: " + join(qnames));
    const QuantityInfo* q = model_->find_quantity(*qname);
    if (!q)
        fail(pos_of(*t.get("quantity")), sub(prefix, "quantity"),
             "model '" + model_->name + "' has no quantity '" + *qname + "'; allowed: " +
                 join(qnames));
    ts.quantity = q->name;
    ts.name = q->name;
    if (auto n = get_string(t, prefix, "name")) {
        bool ok = !n->empty();
        for (char c : *n)
            ok = ok && ((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') ||
                        (c >= '0' && c <= '9') || c == '_' || c == '-');
        if (!ok)
            fail(pos_of(*t.get("name")), sub(prefix, "name"),
                 "invalid table name '" + *n + "'; allowed: letters, digits, '_' and '-'");
        ts.name = *n;
    }
    if (auto d = get_string(t, prefix, "description")) ts.description = *d;
    const std::string tlabel = "table '" + ts.name + "'";

    // --- fixed values: global, then per-table overrides -------------------
    Block local;
    if (const toml::table* pt = get_table(t, prefix, "parameters"))
        local = parse_parameters(*pt, sub(prefix, "parameters"));
    const bool own_axes = t.get("axes") != nullptr;
    std::vector<AxisSrc> axes;
    if (const toml::array* aa = get_table_array(t, prefix, "axes"))
        axes = parse_axes(*aa, sub(prefix, "axes"));
    else
        axes = global_axes;

    // Fixed values by group: the table's own first, then global ones whose
    // group the table does not already set (a table-level value or a
    // table-level axis overrides a global value of the same coordinate).
    std::map<std::string, Fixed> fixed;  // group -> value
    for (const Fixed& f : local.fixed) {
        if (is_direction_coordinate(f.name) && !depends_on(*q, f.name))
            fail(f.pos, f.key,
                 "quantity '" + q->name + "' does not depend on '" + f.name + "' (" +
                     depends_text(*q) + "); remove it from this table's parameters");
        fixed[group_of(f.name)] = f;
    }
    std::set<std::string> local_axis_groups;
    if (own_axes)
        for (const AxisSrc& a : axes) local_axis_groups.insert(group_of(a.axis.name));
    for (const Fixed& f : global_params.fixed) {
        const std::string g = group_of(f.name);
        // Global directions a quantity ignores are simply not used by it:
        // [parameters] is shared by tables of different quantities.
        if (is_direction_coordinate(f.name) && !depends_on(*q, f.name)) continue;
        if (fixed.count(g) || local_axis_groups.count(g)) continue;
        fixed[g] = f;
    }

    // Axes: a table-level fixed value removes an inherited global axis (a
    // slice of the global grid); with the table's own axes it is a conflict.
    std::vector<AxisSrc> kept;
    for (const AxisSrc& a : axes) {
        const std::string g = group_of(a.axis.name);
        auto it = fixed.find(g);
        if (it != fixed.end()) {
            const Fixed& f = it->second;
            const bool f_local = f.key.rfind(prefix + ".", 0) == 0;
            if (!own_axes && f_local) continue;  // table slice of a global axis
            // Same level (or a global value against a global axis): ambiguous.
            fail(a.pos, sub(a.key, "name"),
                 "'" + a.axis.name + "' is an axis but '" + f.name + "' is also given as a " +
                     "fixed value (" + f.key + ", line " + std::to_string(f.pos.line) +
                     "); a coordinate is either fixed or an axis, remove one of them");
        }
        if (is_direction_coordinate(a.axis.name) && !depends_on(*q, a.axis.name)) {
            std::string why = "quantity '" + q->name + "' of " + tlabel +
                              " does not depend on '" + a.axis.name + "' (" + depends_text(*q) +
                              "), so every node along this axis would hold the same value";
            if (!own_axes)
                why += "; the axis is inherited from the global [[axes]]: give this table "
                       "its own [[tables.axes]] list";
            else
                why += "; remove this axis";
            fail(a.pos, sub(a.key, "name"), why);
        }
        kept.push_back(a);
    }
    if (kept.empty())
        fail(tpos, sub(prefix, "axes"),
             tlabel + " has no axes; give at least one [[axes]] or [[tables.axes]] entry "
                      "(for a single value use `brdftab eval`)");

    // --- everything the quantity needs must be given --------------------------
    std::set<std::string> have;
    for (const auto& [g, f] : fixed) have.insert(g);
    for (const AxisSrc& a : kept) have.insert(group_of(a.axis.name));
    for (const CoordinateInfo& c : kCoordinates) {
        if (c.encoding != CoordinateEncoding::Cosine) continue;
        // A polar angle, given as theta or as its cosine mu.
        const std::string d = to_string(c.direction), mu = c.name;
        if (depends_on(*q, d) && !have.count(d))
            fail(tpos, prefix,
                 "quantity '" + q->name + "' of " + tlabel + " needs '" + d + "': give " + d +
                     " or " + mu + " in [parameters] or as an axis (allowed: " +
                     direction_range_text(d) + " or " + direction_range_text(mu) + ")");
    }
    for (const ParameterInfo& p : model_->parameters)
        if (!p.default_value && !have.count(p.name))
            fail(tpos, prefix,
                 "model '" + model_->name + "' needs parameter '" + p.name + "' for " +
                     tlabel + ": give it in [parameters] or as an axis (allowed: " +
                     p.range_text() + ")");

    // The engine's own rule decides which methods suit the quantity.
    try {
        resolve_table_method(*q, integration.method);
    } catch (const InputError& e) {
        fail(method_pos, "integration.method", tlabel + ": " + e.what());
    }

    // The kernels index cells with 32-bit integers.
    std::uint64_t cells = 1;
    for (const AxisSrc& a : kept) {
        cells *= a.axis.count;
        if (cells > kMaxU32)
            fail(tpos, prefix,
                 tlabel + " has more than " + std::to_string(kMaxU32) +
                     " cells; allowed: at most that many (split it into several tables)");
    }

    // --- fill the TableSpec -------------------------------------------------
    for (const auto& [g, f] : fixed) ts.fixed[f.name] = f.value;
    // Parameters left at their defaults are recorded too, so the output
    // file states every value the table was computed with.
    for (const ParameterInfo& p : model_->parameters)
        if (p.default_value && !have.count(p.name)) ts.fixed[p.name] = *p.default_value;
    ts.options = nlohmann::json::object();
    for (const OptionInfo& o : model_->options) ts.options[o.name] = o.default_choice;
    for (const Choice& c : global_params.options) ts.options[c.name] = c.value;
    for (const Choice& c : local.options) ts.options[c.name] = c.value;
    resolve_critical_axes(kept, ts.fixed);
    for (const AxisSrc& a : kept) ts.axes.push_back(a.axis);
    if (const toml::table* at = get_table(t, prefix, "adaptive"))
        ts.adaptive = parse_adaptive(*at, sub(prefix, "adaptive"), false, {&ts});
    return ts;
}

}  // namespace brdftab::spec_detail
