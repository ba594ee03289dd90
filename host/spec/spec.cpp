// spec.cpp — TOML table specifications -> Spec (see spec.h, docs/spec.md).
//
// Parsing is done in two stages: first every section is read and checked on
// its own (types, names, ranges), keeping the source position of everything;
// then each [[tables]] entry is merged with the global [parameters] and
// [[axes]] and checked against its quantity (which directions it depends on,
// what must be given).  Every failure is an InputError of the form
//   FILE:LINE:COL: key 'dotted.key': what is wrong; allowed: ...
#include "host/spec/spec.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>
#include <set>
#include <sstream>

#include <toml++/toml.h>

#include "host/core/error.h"
#include "host/core/text.h"
#include "host/models/registry.h"

namespace brdftab {

namespace {

// Per-cell sample counts and the kernel's cell index are 32-bit.
constexpr std::uint64_t kMaxU32 = std::numeric_limits<std::uint32_t>::max();
constexpr std::uint64_t kDefaultSamples = 4096;
constexpr std::size_t kMaxAxisCount = std::size_t(1) << 24;

struct Pos {
    std::uint32_t line = 1, column = 1;
};

Pos pos_of(const toml::source_region& r) {
    Pos p;
    if (r.begin.line > 0) {
        p.line = r.begin.line;
        p.column = r.begin.column > 0 ? r.begin.column : 1;
    }
    return p;
}
Pos pos_of(const toml::node& n) { return pos_of(n.source()); }

std::string join(const std::vector<std::string>& items) {
    std::string out;
    for (std::size_t k = 0; k < items.size(); ++k) {
        if (k) out += ", ";
        out += items[k];
    }
    return out;
}

std::string num(double v) { return number_text(v, 10); }

std::string sub(const std::string& prefix, const std::string& key) {
    return prefix.empty() ? key : prefix + "." + key;
}

std::string indexed(const std::string& prefix, std::size_t k) {
    return prefix + "[" + std::to_string(k) + "]";
}

// Which group of mutually exclusive names a coordinate belongs to: theta and
// mu describe the same direction, phi_d replaces phi_o (CoordinateInfo::direction);
// a parameter is a group of its own.
std::string group_of(const std::string& name) {
    if (const CoordinateInfo* c = find_coordinate(name)) return to_string(c->direction);
    return name;
}

// The kernel direction slot a coordinate feeds (QuantityInfo::directions).
std::string slot_of(const std::string& direction) { return group_of(direction); }

bool depends_on(const QuantityInfo& q, const std::string& direction) {
    const std::string s = slot_of(direction);
    for (const auto& d : q.directions)
        if (d == s) return true;
    return false;
}

// A table's entries in the order they appear in the file (toml++ iterates in
// key order), so that the first problem reported is the first one typed and a
// conflict is reported at the later of the two lines.
std::vector<std::pair<std::string, const toml::node*>> in_file_order(const toml::table& t,
                                                                    std::vector<Pos>* key_pos) {
    struct Entry {
        Pos kpos;
        std::string key;
        const toml::node* node;
    };
    std::vector<Entry> es;
    for (auto&& [k, v] : t) es.push_back({pos_of(k.source()), std::string(k.str()), &v});
    std::stable_sort(es.begin(), es.end(), [](const Entry& a, const Entry& b) {
        return a.kpos.line != b.kpos.line ? a.kpos.line < b.kpos.line
                                          : a.kpos.column < b.kpos.column;
    });
    std::vector<std::pair<std::string, const toml::node*>> out;
    for (const Entry& e : es) {
        out.emplace_back(e.key, e.node);
        if (key_pos) key_pos->push_back(e.kpos);
    }
    return out;
}

std::string depends_text(const QuantityInfo& q) {
    if (q.directions.empty()) return "it depends on no direction";
    return "it depends on " + join(q.directions);
}

// Tables combined cell by cell must have the same axes and nodes.
bool same_axes(const TableSpec& a, const TableSpec& b) {
    bool same = a.axes.size() == b.axes.size();
    for (std::size_t k = 0; same && k < a.axes.size(); ++k)
        same = a.axes[k].name == b.axes[k].name && a.axes[k].values == b.axes[k].values;
    return same;
}

class Parser {
public:
    Parser(std::string file, std::string text) : file_(std::move(file)), text_(std::move(text)) {}
    Spec run();

private:
    // A fixed value from a [parameters] block.
    struct Fixed {
        std::string name;
        double value = 0;
        Pos pos;
        std::string key;
    };
    struct Choice {
        std::string name, value;
        Pos pos;
        std::string key;
    };
    struct Block {
        std::vector<Fixed> fixed;
        std::vector<Choice> options;
    };
    struct AxisSrc {
        Axis axis;
        Pos pos;          // position of the axis' `name` value
        std::string key;  // e.g. "axes[2]"
    };

    [[noreturn]] void fail(Pos p, const std::string& key, const std::string& what) const {
        throw InputError(file_ + ":" + std::to_string(p.line) + ":" + std::to_string(p.column) +
                         ": key '" + key + "': " + what);
    }

    void check_keys(const toml::table& t, const std::string& prefix,
                    const std::vector<std::string>& allowed) const;
    std::optional<std::string> get_string(const toml::table& t, const std::string& prefix,
                                          const char* key) const;
    std::optional<double> get_number(const toml::table& t, const std::string& prefix,
                                     const char* key) const;
    std::optional<std::int64_t> get_integer(const toml::table& t, const std::string& prefix,
                                            const char* key) const;
    const toml::table* get_table(const toml::table& t, const std::string& prefix,
                                 const char* key) const;
    // An array of tables ([[x]] or x = [{...}]); nullptr when absent.
    const toml::array* get_table_array(const toml::table& t, const std::string& prefix,
                                       const char* key) const;

    std::string allowed_names() const;
    Block parse_parameters(const toml::table& t, const std::string& prefix) const;
    std::vector<AxisSrc> parse_axes(const toml::array& a, const std::string& prefix) const;
    // free_unit: an axis that is no model coordinate (e.g. the value axis of an
    // [[inverted]] table), with that unit and no range limit.
    AxisSrc parse_axis(const toml::table& t, const std::string& prefix,
                       const char* free_unit = nullptr) const;
    void parse_integration(const toml::table& t, IntegrationSettings& s) const;
    void parse_output(const toml::table& t, OutputSettings& o) const;
    RecombinedSpec parse_recombined(const toml::table& t, const std::string& prefix,
                                    const Spec& spec, std::map<std::string, Pos>& names) const;
    ErrorTableSpec parse_error_table(const toml::table& t, const std::string& prefix,
                                     const Spec& spec, std::map<std::string, Pos>& names) const;
    InvertedSpec parse_inverted(const toml::table& t, const std::string& prefix,
                                const Spec& spec, std::map<std::string, Pos>& names) const;
    // The `name` of a table formed from others: present, valid, unique.
    std::string derived_name(const toml::table& t, const std::string& prefix,
                             std::map<std::string, Pos>& names, const char* what) const;
    // The table a string key names: a [[tables]] entry (for recombined terms),
    // or also a [[recombined]] one (then its first term's axes and quantity).
    const TableSpec& source_table(const toml::table& t, const std::string& prefix,
                                  const char* key, const Spec& spec, bool allow_recombined,
                                  const std::string& hint) const;
    TableSpec build_table(const toml::table& t, const std::string& prefix,
                          const Block& global_params, const std::vector<AxisSrc>& global_axes,
                          const IntegrationSettings& integration, Pos method_pos) const;

    std::string file_, text_;
    const ModelInfo* model_ = nullptr;
};

void Parser::check_keys(const toml::table& t, const std::string& prefix,
                        const std::vector<std::string>& allowed) const {
    std::vector<Pos> kpos;
    const auto entries = in_file_order(t, &kpos);
    for (std::size_t n = 0; n < entries.size(); ++n) {
        const std::string& k = entries[n].first;
        bool ok = false;
        for (const auto& a : allowed) ok = ok || (k == a);
        if (!ok) fail(kpos[n], sub(prefix, k), "unknown key; allowed: " + join(allowed));
    }
}

std::optional<std::string> Parser::get_string(const toml::table& t, const std::string& prefix,
                                              const char* key) const {
    const toml::node* n = t.get(key);
    if (!n) return std::nullopt;
    if (!n->is_string()) fail(pos_of(*n), sub(prefix, key), "must be a string");
    return n->as_string()->get();
}

std::optional<double> Parser::get_number(const toml::table& t, const std::string& prefix,
                                         const char* key) const {
    const toml::node* n = t.get(key);
    if (!n) return std::nullopt;
    if (n->is_integer()) return double(n->as_integer()->get());
    if (n->is_floating_point()) return n->as_floating_point()->get();
    fail(pos_of(*n), sub(prefix, key), "must be a number");
}

std::optional<std::int64_t> Parser::get_integer(const toml::table& t, const std::string& prefix,
                                                const char* key) const {
    const toml::node* n = t.get(key);
    if (!n) return std::nullopt;
    if (!n->is_integer()) fail(pos_of(*n), sub(prefix, key), "must be an integer");
    return n->as_integer()->get();
}

const toml::table* Parser::get_table(const toml::table& t, const std::string& prefix,
                                     const char* key) const {
    const toml::node* n = t.get(key);
    if (!n) return nullptr;
    if (!n->is_table())
        fail(pos_of(*n), sub(prefix, key),
             std::string("must be a table ([") + sub(prefix, key) + "] section or inline {...})");
    return n->as_table();
}

const toml::array* Parser::get_table_array(const toml::table& t, const std::string& prefix,
                                           const char* key) const {
    const toml::node* n = t.get(key);
    if (!n) return nullptr;
    const toml::array* a = n->as_array();
    if (!a)
        fail(pos_of(*n), sub(prefix, key),
             std::string("must be an array of tables ([[") + sub(prefix, key) + "]] sections)");
    for (std::size_t k = 0; k < a->size(); ++k)
        if (!(*a)[k].is_table())
            fail(pos_of((*a)[k]), indexed(sub(prefix, key), k),
                 "must be a table (one [[" + sub(prefix, key) + "]] section)");
    return a;
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

Parser::AxisSrc Parser::parse_axis(const toml::table& t, const std::string& prefix,
                                   const char* free_unit) const {
    check_keys(t, prefix, {"name", "range", "count", "spacing", "values"});
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
            double x;
            if (e.is_integer())
                x = double(e.as_integer()->get());
            else if (e.is_floating_point())
                x = e.as_floating_point()->get();
            else
                fail(pos_of(e), indexed(vkey, k), "must be a number");
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
    for (std::size_t k = 0; k < 2; ++k) {
        const toml::node& e = (*ra)[k];
        if (e.is_integer())
            ends[k] = double(e.as_integer()->get());
        else if (e.is_floating_point())
            ends[k] = e.as_floating_point()->get();
        else
            fail(pos_of(e), indexed(rkey, k), "must be a number");
    }
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
    try {
        out.axis = make_axis(*name, unit, ends[0], ends[1], std::size_t(*count), spacing);
    } catch (const InputError& e) {
        fail(pos_of(*rn), rkey, e.what());
    }
    return out;
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

void Parser::parse_integration(const toml::table& t, IntegrationSettings& s) const {
    const std::string pre = "integration";
    check_keys(t, pre, {"method", "samples", "tolerance", "abs_floor", "max_samples", "seed",
                        "batch_size"});
    if (auto m = get_string(t, pre, "method")) {
        const std::optional<Method> method = find_method(*m);
        if (!method)
            fail(pos_of(*t.get("method")), sub(pre, "method"),
                 "unknown method '" + *m + "'; allowed: " + join(method_names()));
        s.method = *method;
    }
    auto u64 = [&](const char* key, std::uint64_t lo, std::uint64_t hi) -> std::optional<std::uint64_t> {
        auto v = get_integer(t, pre, key);
        if (!v) return std::nullopt;
        if (*v < 0 || std::uint64_t(*v) < lo || std::uint64_t(*v) > hi)
            fail(pos_of(*t.get(key)), sub(pre, key),
                 "value " + std::to_string(*v) + " is out of range; allowed: integer " +
                     std::to_string(lo) + " .. " + std::to_string(hi));
        return std::uint64_t(*v);
    };
    const auto samples = u64("samples", 1, kMaxU32);
    if (samples) s.samples = *samples;
    if (auto tol = get_number(t, pre, "tolerance")) {
        if (!(*tol > 0 && *tol < 1))
            fail(pos_of(*t.get("tolerance")), sub(pre, "tolerance"),
                 "value " + num(*tol) + " is out of range; allowed: (0, 1) (relative standard error)");
        s.tolerance = *tol;
    }
    if (auto fl = get_number(t, pre, "abs_floor")) {
        if (!(*fl > 0) || !std::isfinite(*fl))
            fail(pos_of(*t.get("abs_floor")), sub(pre, "abs_floor"),
                 "value " + num(*fl) + " is out of range; allowed: > 0");
        s.abs_floor = *fl;
    }
    if (auto mx = u64("max_samples", 1, kMaxU32)) {
        if (samples && *mx < *samples)
            fail(pos_of(*t.get("max_samples")), sub(pre, "max_samples"),
                 "max_samples " + std::to_string(*mx) + " is below samples " +
                     std::to_string(*samples) + "; allowed: >= samples");
        s.max_samples = *mx;
    } else if (samples && *samples > s.max_samples) {
        // A first round larger than the default cap: the cap follows it.
        s.max_samples = *samples;
    }
    if (auto seed = get_integer(t, pre, "seed")) {
        if (*seed < 0)
            fail(pos_of(*t.get("seed")), sub(pre, "seed"),
                 "value " + std::to_string(*seed) + " is out of range; allowed: integer >= 0");
        s.seed = std::uint64_t(*seed);
    }
    if (auto bs = u64("batch_size", 1, 65536)) s.batch_size = std::uint32_t(*bs);
}

void Parser::parse_output(const toml::table& t, OutputSettings& o) const {
    const std::string pre = "output";
    check_keys(t, pre, {"path", "type", "compression", "keep_stderr"});
    if (auto p = get_string(t, pre, "path")) {
        if (p->empty()) fail(pos_of(*t.get("path")), sub(pre, "path"), "must not be empty");
        o.path = *p;
    }
    if (auto ty = get_string(t, pre, "type")) {
        if (*ty == "float64")
            o.stored_type = StoredType::Float64;
        else if (*ty == "float32")
            o.stored_type = StoredType::Float32;
        else if (*ty == "float16")
            o.stored_type = StoredType::Float16;
        else
            fail(pos_of(*t.get("type")), sub(pre, "type"),
                 "unknown type '" + *ty + "'; allowed: float64, float32, float16");
    }
    if (auto c = get_integer(t, pre, "compression")) {
        if (*c < 0 || *c > 9)
            fail(pos_of(*t.get("compression")), sub(pre, "compression"),
                 "value " + std::to_string(*c) + " is out of range; allowed: 0 .. 9");
        o.compression = int(*c);
    }
    if (const toml::node* k = t.get("keep_stderr")) {
        if (!k->is_boolean())
            fail(pos_of(*k), sub(pre, "keep_stderr"), "must be true or false");
        o.keep_stderr = k->as_boolean()->get();
    }
}

TableSpec Parser::build_table(const toml::table& t, const std::string& prefix,
                              const Block& global_params,
                              const std::vector<AxisSrc>& global_axes,
                              const IntegrationSettings& integration, Pos method_pos) const {
    check_keys(t, prefix, {"name", "quantity", "description", "parameters", "axes"});
    const Pos tpos = pos_of(t);
    TableSpec ts;

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
    for (const AxisSrc& a : kept) ts.axes.push_back(a.axis);
    return ts;
}

Spec Parser::run() {
    Spec spec;
    spec.file = file_;
    spec.text = text_;

    toml::table root;
    try {
        root = toml::parse(text_, file_);
    } catch (const toml::parse_error& e) {
        const Pos p = pos_of(e.source());
        throw InputError(file_ + ":" + std::to_string(p.line) + ":" + std::to_string(p.column) +
                         ": TOML syntax error: " + std::string(e.description()));
    }

    check_keys(root, "", {"model", "description", "parameters", "axes", "tables", "recombined",
                          "errors", "inverted", "integration", "output"});

    std::vector<std::string> model_names;
    for (const auto& m : all_models()) model_names.push_back(m.name);
    const auto model = get_string(root, "", "model");
    if (!model)
        fail(Pos{}, "model", "missing; the spec must name a model; allowed: " + join(model_names));
    for (const auto& m : all_models())
        if (m.name == *model) model_ = &m;
    if (!model_)
        fail(pos_of(*root.get("model")), "model",
             "unknown model '" + *model + "'; allowed: " + join(model_names));
    spec.model = model_->name;
    if (auto d = get_string(root, "", "description")) spec.description = *d;

    Block global_params;
    if (const toml::table* pt = get_table(root, "", "parameters"))
        global_params = parse_parameters(*pt, "parameters");
    std::vector<AxisSrc> global_axes;
    if (const toml::array* aa = get_table_array(root, "", "axes"))
        global_axes = parse_axes(*aa, "axes");
    // A global axis that is also a global fixed value can never be resolved.
    for (const AxisSrc& a : global_axes)
        for (const Fixed& f : global_params.fixed)
            if (group_of(f.name) == group_of(a.axis.name))
                fail(a.pos, sub(a.key, "name"),
                     "'" + a.axis.name + "' is an axis but '" + f.name + "' is also given as " +
                         "a fixed value (" + f.key + ", line " + std::to_string(f.pos.line) +
                         "); a coordinate is either fixed or an axis, remove one of them");

    Pos method_pos;
    if (const toml::table* it = get_table(root, "", "integration")) {
        parse_integration(*it, spec.integration);
        if (const toml::node* m = it->get("method")) method_pos = pos_of(*m);
    }
    if (const toml::table* ot = get_table(root, "", "output")) parse_output(*ot, spec.output);
    if (spec.output.path.empty()) {
        std::string stem = std::filesystem::path(file_).stem().string();
        if (stem.empty() || stem.front() == '<') stem = "table";  // "<string>" etc.
        spec.output.path = stem + ".h5";
    }

    const toml::array* tables = get_table_array(root, "", "tables");
    if (!tables || tables->empty())
        fail(tables ? pos_of(*tables) : Pos{}, "tables",
             "missing; give at least one [[tables]] entry with a quantity");
    std::map<std::string, Pos> names;
    for (std::size_t k = 0; k < tables->size(); ++k) {
        const std::string prefix = indexed("tables", k);
        const toml::table& t = *(*tables)[k].as_table();
        TableSpec ts =
            build_table(t, prefix, global_params, global_axes, spec.integration, method_pos);
        auto it = names.find(ts.name);
        if (it != names.end()) {
            const toml::node* n = t.get("name");
            fail(n ? pos_of(*n) : pos_of(t), sub(prefix, "name"),
                 "duplicate table name '" + ts.name + "' (first used by the table at line " +
                     std::to_string(it->second.line) +
                     "); give each table a unique name = \"...\"");
        }
        names.emplace(ts.name, pos_of(t));
        spec.tables.push_back(std::move(ts));
    }
    if (const toml::array* rs = get_table_array(root, "", "recombined"))
        for (std::size_t k = 0; k < rs->size(); ++k)
            spec.recombined.push_back(
                parse_recombined(*(*rs)[k].as_table(), indexed("recombined", k), spec, names));
    if (const toml::array* es = get_table_array(root, "", "errors"))
        for (std::size_t k = 0; k < es->size(); ++k)
            spec.errors.push_back(
                parse_error_table(*(*es)[k].as_table(), indexed("errors", k), spec, names));
    if (const toml::array* is = get_table_array(root, "", "inverted"))
        for (std::size_t k = 0; k < is->size(); ++k)
            spec.inverted.push_back(
                parse_inverted(*(*is)[k].as_table(), indexed("inverted", k), spec, names));
    return spec;
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

    auto number = [&](const toml::node& e, const std::string& key) {
        if (e.is_integer()) return double(e.as_integer()->get());
        if (e.is_floating_point()) return e.as_floating_point()->get();
        fail(pos_of(e), key, "must be a number");
    };
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

}  // namespace

Spec parse_spec_string(const std::string& text, const std::string& file_name) {
    return Parser(file_name, text).run();
}

Spec parse_spec_file(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw InputError(path + ": cannot open the spec file");
    std::ostringstream ss;
    ss << in.rdbuf();
    if (in.bad()) throw InputError(path + ": cannot read the spec file");
    return parse_spec_string(ss.str(), path);
}

}  // namespace brdftab
