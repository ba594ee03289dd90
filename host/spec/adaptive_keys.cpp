// adaptive_keys.cpp — [adaptive] and a [[tables]] entry's `adaptive`: the
// settings of adaptive tables (docs/spec.md "Adaptive tables",
// docs/adaptive.md), checked key by key against the tables they apply to.
#include <algorithm>
#include <cmath>

#include "host/spec/parser.h"

namespace brdftab::spec_detail {

namespace {

// "1.01 < x < 3" for an axis' open range.
std::string open_range_text(const Axis& a) {
    return num(std::min(a.min, a.max)) + " < x < " + num(std::max(a.min, a.max));
}

}  // namespace

AdaptiveSpecSettings Parser::parse_adaptive(const toml::table& t, const std::string& prefix, bool spec_level,
                                            const std::vector<const TableSpec*>& tables) const {
    std::vector<std::string> keys = {"max_values", "patch_nodes", "patch_order", "breakpoints", "jumps",
                                     "initial_level"};
    if (spec_level) {
        keys.push_back("accuracy");
        keys.push_back("measure");
    }
    check_keys(t, prefix, keys);
    AdaptiveSpecSettings s;
    if (auto e = get_number(t, prefix, "accuracy")) {
        if (!(*e > 0) || !std::isfinite(*e))
            fail(pos_of(*t.get("accuracy")), sub(prefix, "accuracy"),
                 "value " + num(*e) + " is out of range; allowed: a finite number > 0 (the max error the "
                 "refinement aims at)");
        s.accuracy = *e;
    }
    if (auto m = get_string(t, prefix, "measure")) {
        if (*m != "relative" && *m != "absolute")
            fail(pos_of(*t.get("measure")), sub(prefix, "measure"),
                 "unknown measure '" + *m + "'; allowed: relative, absolute");
        s.absolute = *m == "absolute";
    }
    if (auto v = get_integer(t, prefix, "max_values")) {
        if (*v < 2 || *v > (std::int64_t(1) << 31))
            fail(pos_of(*t.get("max_values")), sub(prefix, "max_values"),
                 "value " + std::to_string(*v) + " is out of range; allowed: integer 2 .. 2147483648");
        s.max_values = std::size_t(*v);
    }
    if (auto v = get_integer(t, prefix, "patch_nodes")) {
        if (*v != 3 && *v != 5 && *v != 9)
            fail(pos_of(*t.get("patch_nodes")), sub(prefix, "patch_nodes"),
                 "value " + std::to_string(*v) + " is not allowed; allowed: 3, 5, 9 (nodes per axis of a patch)");
        s.patch_nodes = std::size_t(*v);
    }
    if (auto v = get_integer(t, prefix, "patch_order")) {
        if (*v != 1 && *v != 2)
            fail(pos_of(*t.get("patch_order")), sub(prefix, "patch_order"),
                 "value " + std::to_string(*v) + " is not allowed; allowed: 1 (multilinear), 2 (piecewise "
                 "quadratic)");
        s.patch_order = int(*v);
    }

    // The axis an entry names, in every table the settings apply to.
    auto axes_named = [&](const std::string& name, Pos p, const std::string& key) {
        std::vector<const Axis*> found;
        std::string names;
        for (const TableSpec* ts : tables)
            for (const Axis& a : ts->axes) {
                if (a.name == name) found.push_back(&a);
                if (names.find(a.name) == std::string::npos) names += (names.empty() ? "" : ", ") + a.name;
            }
        if (found.empty())
            fail(p, key, "'" + name + "' is no axis of " +
                             (spec_level ? std::string("any table") : "table '" + tables.front()->name + "'") +
                             "; allowed: " + names);
        return found;
    };
    // breakpoints / jumps = { NAME = X or [X, ...] }.
    auto positions = [&](const char* key, std::vector<std::pair<std::string, double>>& out, bool& given) {
        const toml::node* n = t.get(key);
        if (!n) return;
        given = true;
        const std::string k = sub(prefix, key);
        const toml::table* tt = n->as_table();
        if (!tt) fail(pos_of(*n), k, "must be a table of axis name = position or [positions], e.g. { eta = [1.5] }");
        for (const auto& [name, node] : in_file_order(*tt, nullptr)) {
            const std::string kk = sub(k, name);
            std::vector<std::pair<double, Pos>> xs;
            if (const toml::array* arr = node->as_array()) {
                for (const toml::node& e : *arr) xs.push_back({number(e, kk), pos_of(e)});
            } else {
                xs.push_back({number(*node, kk), pos_of(*node)});
            }
            for (const Axis* a : axes_named(name, pos_of(*node), kk)) {
                if (a->dependent())
                    fail(pos_of(*node), kk,
                         "axis '" + name + "' follows '" + a->depends_on + "' (its warp depends on it), so a fixed "
                         "value is no plane of the table; its critical node is a patch face already; allowed: "
                         "axes whose warp depends on no other axis");
                for (const auto& [x, p] : xs)
                    if (!(x > std::min(a->min, a->max) && x < std::max(a->min, a->max)))
                        fail(p, kk, "value " + num(x) + " lies outside the axis' open range; allowed: " +
                                        open_range_text(*a));
            }
            for (const auto& [x, p] : xs) out.push_back({name, x});
        }
    };
    positions("breakpoints", s.breakpoints, s.breakpoints_given);
    positions("jumps", s.jumps, s.jumps_given);
    if (const toml::node* n = t.get("initial_level")) {
        const std::string k = sub(prefix, "initial_level");
        const toml::table* tt = n->as_table();
        if (!tt) fail(pos_of(*n), k, "must be a table of axis name = level, e.g. { mu_i = 2 }");
        for (const auto& [name, node] : in_file_order(*tt, nullptr)) {
            const std::string kk = sub(k, name);
            axes_named(name, pos_of(*node), kk);
            const std::optional<std::int64_t> lv = node->value<std::int64_t>();
            if (!node->is_integer() || !lv || *lv < 0 || *lv > 16)
                fail(pos_of(*node), kk, "must be an integer 0 .. 16 (uniform halvings of the axis to start from)");
            s.initial_level[name] = int(*lv);
        }
    }
    return s;
}

}  // namespace brdftab::spec_detail
