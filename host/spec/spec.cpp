// spec.cpp — TOML table specifications -> Spec (see spec.h, docs/spec.md):
// the entry points, the file's top level section by section, and the
// [integration] and [output] settings.  parser.h lists where the other
// sections are read.
//
// Every failure is an InputError of the form
//   FILE:LINE:COL: key 'dotted.key': what is wrong; allowed: ...
#include "host/spec/spec.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "host/core/error.h"
#include "host/spec/parser.h"

namespace brdftab {

namespace spec_detail {

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
                          "errors", "inverted", "integration", "output", "adaptive"});

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
    // round_measure is the measure of a round_to_accuracy ([output]'s or a
    // table's); alone it would round nothing.
    if (const toml::table* ot = get_table(root, "", "output"))
        if (const toml::node* m = ot->get("round_measure"))
            if (!(spec.output.round_accuracy > 0) &&
                std::none_of(spec.tables.begin(), spec.tables.end(),
                             [](const TableSpec& ts) { return ts.round_accuracy > 0; }))
                fail(pos_of(*m), "output.round_measure",
                     "needs round_to_accuracy (in [output] or in a [[tables]] entry)");
    // [adaptive]: the settings of adaptive tables, for every table with the
    // axes it names (a table's own `adaptive` key wins field by field).
    if (const toml::table* at = get_table(root, "", "adaptive")) {
        std::vector<const TableSpec*> all;
        for (const TableSpec& ts : spec.tables) all.push_back(&ts);
        spec.adaptive = parse_adaptive(*at, "adaptive", true, all);
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
                 "value " + std::to_string(*v) + " is out of range; allowed: " +
                     (hi == kMaxSampleCount ? sample_count_range_text()
                                            : "integer " + std::to_string(lo) + " .. " +
                                                  std::to_string(hi)));
        return std::uint64_t(*v);
    };
    const auto samples = u64("samples", 1, kMaxSampleCount);
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
    if (auto mx = u64("max_samples", 1, kMaxSampleCount)) {
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
    check_keys(t, pre, {"path", "type", "compression", "keep_stderr", "round_to_accuracy", "round_measure",
                        "representation"});
    if (auto r = get_string(t, pre, "representation")) {
        if (*r != "tensor" && *r != "adaptive" && *r != "auto")
            fail(pos_of(*t.get("representation")), sub(pre, "representation"),
                 "unknown representation '" + *r + "'; allowed: tensor, adaptive, auto");
        o.representation = *r;
        o.representation_given = true;
    }
    if (auto p = get_string(t, pre, "path")) {
        if (p->empty()) fail(pos_of(*t.get("path")), sub(pre, "path"), "must not be empty");
        // A relative path is relative to the spec file's directory, so a spec
        // writes to the same place from any working directory (an absolute
        // path, or one with "..", is kept; `generate` prints the result before
        // computing).  Specs parsed from a string have no directory.
        const std::filesystem::path given(*p), dir = std::filesystem::path(file_).parent_path();
        o.path = given.is_absolute() || dir.empty() || file_.front() == '<'
                     ? *p
                     : (dir / given).lexically_normal().string();
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
    if (auto e = get_number(t, pre, "round_to_accuracy")) {
        if (!(*e > 0) || !std::isfinite(*e))
            fail(pos_of(*t.get("round_to_accuracy")), sub(pre, "round_to_accuracy"),
                 "value " + num(*e) + " is out of range; allowed: > 0 (the accuracy the stored "
                 "values are rounded for)");
        o.round_accuracy = *e;
    }
    if (auto m = get_string(t, pre, "round_measure")) {
        if (*m != "relative" && *m != "absolute")
            fail(pos_of(*t.get("round_measure")), sub(pre, "round_measure"),
                 "unknown measure '" + *m + "'; allowed: relative, absolute");
        o.round_absolute = *m == "absolute";
    }
}

}  // namespace spec_detail

Spec parse_spec_string(const std::string& text, const std::string& file_name) {
    return spec_detail::Parser(file_name, text).run();
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
