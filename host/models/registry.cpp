// registry.cpp — generic registry machinery: the registration list, the
// ModelBuilder checks, lookups, validation and point building.  The model
// entries themselves live in host/models/<model>.cpp, one file per model.
#include "host/models/registry.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <stdexcept>

#include "kernels/common/estimator.h"  // BT_MAX_POINT, BT_MAX_OPTIONS

#include "host/core/error.h"
#include "host/core/text.h"

namespace brdftab {

namespace detail {
namespace {
// Function-local so that registrations from other translation units' static
// initialisers find it constructed, whatever the initialisation order.
std::vector<ModelFactory>& factories() {
    static std::vector<ModelFactory> list;
    return list;
}
}  // namespace

ModelRegistration::ModelRegistration(ModelFactory factory) { factories().push_back(factory); }
}  // namespace detail

namespace {

constexpr double kDegToRad = 3.14159265358979323846 / 180.0;

std::string join(const std::vector<std::string>& items, const char* sep = ", ") {
    std::string out;
    for (std::size_t k = 0; k < items.size(); ++k) {
        if (k) out += sep;
        out += items[k];
    }
    return out;
}

std::string format_number(double v) { return number_text(v, 10); }

// QuantityKind as `models --json` names it, and as messages describe it.
struct QuantityKindNames {
    QuantityKind kind;
    const char* name;
    const char* text;
};
constexpr QuantityKindNames kQuantityKindNames[] = {
    {QuantityKind::ClosedForm, "closed-form", "a closed form"},
    {QuantityKind::Integral, "integral", "an integral without closed form"},
    {QuantityKind::Quadrature, "quadrature", "a quadrature"},
};

const QuantityKindNames& quantity_kind_row(QuantityKind kind) {
    for (const auto& row : kQuantityKindNames)
        if (row.kind == kind) return row;
    throw Error("quantity kind " + std::to_string(static_cast<int>(kind)) + " has no name");
}
const char* quantity_kind_name(QuantityKind kind) { return quantity_kind_row(kind).name; }
const char* quantity_kind_text(QuantityKind kind) { return quantity_kind_row(kind).text; }

}  // namespace

bool ParameterInfo::accepts(double v) const {
    if (!std::isfinite(v)) return false;
    if (min_inclusive ? v < min : v <= min) return false;
    if (max_inclusive ? v > max : v >= max) return false;
    // The kernels round integer parameters; 2.5 would silently become 3.
    if (integer && v != std::floor(v)) return false;
    return true;
}

std::string ParameterInfo::range_text() const {
    return std::string(integer ? "integers in " : "") + (min_inclusive ? "[" : "(") +
           format_number(min) + ", " +
           format_number(max) + (max_inclusive ? "]" : ")") +
           (unit.empty() || unit == "1" ? "" : " " + unit);
}

int OptionInfo::index_of(const std::string& choice) const {
    for (std::size_t k = 0; k < choices.size(); ++k)
        if (choices[k] == choice) return static_cast<int>(k);
    return -1;
}

const QuantityInfo* ModelInfo::find_quantity(const std::string& n) const {
    for (const auto& q : quantities)
        if (q.name == n) return &q;
    return nullptr;
}
const ParameterInfo* ModelInfo::find_parameter(const std::string& n) const {
    for (const auto& p : parameters)
        if (p.name == n) return &p;
    return nullptr;
}
const OptionInfo* ModelInfo::find_option(const std::string& n) const {
    for (const auto& o : options)
        if (o.name == n) return &o;
    return nullptr;
}

const QuantityInfo& ModelInfo::quantity(const std::string& n) const {
    if (const QuantityInfo* q = find_quantity(n)) return *q;
    std::vector<std::string> names;
    for (const auto& q : quantities) names.push_back(q.name);
    throw InputError("model '" + name + "' has no quantity '" + n +
                     "'; allowed: " + join(names));
}

const std::vector<ModelInfo>& all_models() {
    static const std::vector<ModelInfo> models = [] {
        std::vector<ModelInfo> m;
        for (detail::ModelFactory factory : detail::factories()) m.push_back(factory());
        // Registration order depends on link order; the listing must not.
        std::sort(m.begin(), m.end(), [](const ModelInfo& a, const ModelInfo& b) {
            return a.listing_order != b.listing_order ? a.listing_order < b.listing_order
                                                      : a.name < b.name;
        });
        for (std::size_t k = 1; k < m.size(); ++k)
            if (m[k].name == m[k - 1].name)
                throw std::logic_error("model '" + m[k].name + "' is registered twice");
        return m;
    }();
    return models;
}

// ------------------------------------------------------------ ModelBuilder

ModelBuilder::ModelBuilder(std::string name, int listing_order) {
    model_.name = std::move(name);
    model_.listing_order = listing_order;
}
ModelBuilder& ModelBuilder::citation(std::string text) {
    model_.citation = std::move(text);
    return *this;
}
ModelBuilder& ModelBuilder::description(std::string text) {
    model_.description = std::move(text);
    return *this;
}
ModelBuilder& ModelBuilder::kernel(std::string kernel_header, std::string sample_function,
                                   HostSampleFn host_fn) {
    model_.kernel_header = std::move(kernel_header);
    model_.sample_function = std::move(sample_function);
    model_.host_fn = host_fn;
    return *this;
}
ModelBuilder& ModelBuilder::counts(int parameters, int options, int quantities) {
    declared_parameters_ = parameters;
    declared_options_ = options;
    declared_quantities_ = quantities;
    return *this;
}
ModelBuilder& ModelBuilder::parameter(int slot, ParameterInfo info) {
    parameter_slots_.push_back(slot);
    model_.parameters.push_back(std::move(info));
    return *this;
}
ModelBuilder& ModelBuilder::option(int slot, OptionInfo info) {
    option_slots_.push_back(slot);
    model_.options.push_back(std::move(info));
    return *this;
}
ModelBuilder& ModelBuilder::quantity(int id, QuantityInfo info) {
    info.id = id;
    model_.quantities.push_back(std::move(info));
    return *this;
}
ModelBuilder& ModelBuilder::check_point(
    std::string (*fn)(const QuantityInfo&, const std::map<std::string, double>&)) {
    model_.check_point = fn;
    return *this;
}
ModelBuilder& ModelBuilder::check_cell(
    std::string (*fn)(const QuantityInfo&, const double*, const std::vector<int>&)) {
    model_.check_cell = fn;
    return *this;
}
ModelBuilder& ModelBuilder::cells_pass(bool (*fn)(const QuantityInfo&, const double*,
                                                  std::size_t, std::size_t,
                                                  const std::vector<int>&)) {
    model_.cells_pass = fn;
    return *this;
}
ModelBuilder& ModelBuilder::derive(
    CellDerivation (*fn)(const QuantityInfo&, const std::vector<int>&)) {
    model_.derive = fn;
    return *this;
}

ModelBuilder& ModelBuilder::force_inline() {
    model_.force_inline = true;
    return *this;
}
ModelBuilder& ModelBuilder::float_vs_double(int id, double max_rel_diff, std::string note) {
    QuantityInfo& q = quantity_by_id(id);
    q.float_max_rel_diff = max_rel_diff;
    q.float_note = std::move(note);
    return *this;
}
ModelBuilder& ModelBuilder::bench(BenchDeclaration info) {
    model_.bench.push_back(std::move(info));
    return *this;
}

QuantityInfo& ModelBuilder::quantity_by_id(int id) {
    for (auto& q : model_.quantities)
        if (q.id == id) return q;
    throw std::logic_error("model '" + model_.name + "': no quantity with id " +
                           std::to_string(id));
}

namespace {

// Sorts `items` by their slots and checks the slots are first, first+1, ...
// with exactly `declared` entries.
template <class T>
std::vector<T> order_by_slot(const std::string& model, const char* what,
                             const std::vector<int>& slots, const std::vector<T>& items,
                             int first, int declared, int limit) {
    auto fail = [&](const std::string& why) {
        throw std::logic_error("model '" + model + "': " + what + " slots: " + why);
    };
    if (declared < 0) fail("counts() was not called with the kernel header's counts");
    if (static_cast<int>(items.size()) != declared)
        fail(std::to_string(items.size()) + " described but the kernel header declares " +
             std::to_string(declared));
    if (first + declared > limit)
        fail("slots up to " + std::to_string(first + declared - 1) + " exceed the kernel limit " +
             std::to_string(limit - 1));
    std::vector<T> ordered(items.size());
    std::vector<bool> filled(items.size(), false);
    for (std::size_t k = 0; k < items.size(); ++k) {
        const int index = slots[k] - first;
        if (index < 0 || index >= declared)
            fail("slot " + std::to_string(slots[k]) + " is outside [" + std::to_string(first) +
                 ", " + std::to_string(first + declared - 1) + "]");
        if (filled[static_cast<std::size_t>(index)])
            fail("slot " + std::to_string(slots[k]) + " is used twice");
        filled[static_cast<std::size_t>(index)] = true;
        ordered[static_cast<std::size_t>(index)] = items[k];
    }
    return ordered;
}

void require_unique(const std::string& model, const char* what,
                    const std::vector<std::string>& names) {
    std::set<std::string> seen;
    for (const auto& n : names) {
        if (n.empty()) throw std::logic_error("model '" + model + "': a " + what + " has no name");
        if (!seen.insert(n).second)
            throw std::logic_error("model '" + model + "': " + what + " '" + n +
                                   "' is declared twice");
    }
}

}  // namespace

ModelInfo ModelBuilder::build() const {
    ModelInfo m = model_;
    const std::string& name = m.name;
    auto fail = [&](const std::string& why) { throw std::logic_error("model '" + name + "': " + why); };
    if (name.empty()) throw std::logic_error("a model has no name");
    if (m.kernel_header.empty() || m.sample_function.empty() || !m.host_fn)
        fail("kernel() must give the kernel header, its sample function and the host function");
    if (m.cells_pass && !m.check_cell)
        fail("cells_pass() is the fast form of check_cell(), which must be given too");
    m.parameters = order_by_slot(name, "parameter", parameter_slots_, model_.parameters,
                                 kDirectionSlots, declared_parameters_, BT_MAX_POINT);
    m.options = order_by_slot(name, "option", option_slots_, model_.options, 0,
                              declared_options_, BT_MAX_OPTIONS);
    std::vector<int> ids;
    for (const auto& q : m.quantities) ids.push_back(q.id);
    // Quantities keep their listing order; their ids must cover 0..count-1.
    order_by_slot(name, "quantity", ids, ids, 0, declared_quantities_, 1 << 30);

    std::vector<std::string> names;
    for (const auto& p : m.parameters) {
        if (is_direction_coordinate(p.name))
            fail("parameter '" + p.name + "' has the name of a direction coordinate");
        if (!(p.min <= p.max)) fail("parameter '" + p.name + "' has an empty range");
        if (p.default_value && !p.accepts(*p.default_value))
            fail("the default of parameter '" + p.name + "' is outside " + p.range_text());
        names.push_back(p.name);
    }
    require_unique(name, "parameter", names);
    names.clear();
    for (const auto& o : m.options) {
        if (o.choices.empty() || o.index_of(o.default_choice) < 0)
            fail("option '" + o.name + "' has no choice '" + o.default_choice + "'");
        require_unique(name, ("choice of option '" + o.name + "'").c_str(), o.choices);
        names.push_back(o.name);
    }
    require_unique(name, "option", names);
    names.clear();
    for (const auto& q : m.quantities) {
        for (const auto& d : q.directions)
            if (d != "theta_i" && d != "phi_i" && d != "theta_o" && d != "phi_o")
                fail("quantity '" + q.name + "' depends on '" + d + "', not a direction slot");
        for (const auto& o : q.uses_options)
            if (!m.find_option(o)) fail("quantity '" + q.name + "' uses unknown option '" + o + "'");
        if (q.default_method == Method::Auto || !method_suits(q.kind, q.default_method))
            fail("quantity '" + q.name + "' has default method '" + to_string(q.default_method) +
                 "', which does not suit its kind");
        // The launch preferences name existing options and choices.
        auto check_choice = [&](const OptionChoice& c) {
            const OptionInfo* o = m.find_option(c.option);
            if (!o || o->index_of(c.choice) < 0)
                fail("quantity '" + q.name + "': a launch preference names option '" + c.option +
                     "' = '" + c.choice + "', which the model does not have");
        };
        for (const SampleParallelRule& r : q.sample_parallel) {
            if (r.method != Method::MonteCarlo && r.method != Method::Rqmc)
                fail("quantity '" + q.name + "': sample-parallel rules are for mc and rqmc only");
            for (const OptionChoice& c : r.options) check_choice(c);
        }
        for (const OptionChoice& c : q.fixed_step_solver) check_choice(c);
        names.push_back(q.name);
    }
    require_unique(name, "quantity", names);
    int headlines = 0;
    for (const BenchDeclaration& c : m.bench) {
        if (!m.find_quantity(c.quantity)) fail("bench case of unknown quantity '" + c.quantity + "'");
        headlines += c.headline ? 1 : 0;
    }
    if (headlines > 1) fail("more than one headline bench case");
    return m;
}

const ModelInfo& find_model(const std::string& name) {
    std::vector<std::string> names;
    for (const auto& m : all_models()) {
        if (m.name == name) return m;
        names.push_back(m.name);
    }
    throw InputError("unknown model '" + name + "'; allowed: " + join(names));
}

// ---------------------------------------------------------------- directions

namespace {
const CoordinateInfo& direction(const std::string& n) {
    if (const CoordinateInfo* c = find_coordinate(n)) return *c;
    throw Error("'" + n + "' is not a direction coordinate");
}
}  // namespace

bool is_direction_coordinate(const std::string& n) { return find_coordinate(n) != nullptr; }

std::string direction_unit(const std::string& n) { return direction(n).unit; }

bool direction_accepts(const std::string& n, double v) {
    const CoordinateInfo& c = direction(n);
    return std::isfinite(v) && v >= c.min && v <= c.max;
}

std::string direction_range_text(const std::string& n) {
    const CoordinateInfo& c = direction(n);
    // e.g. "[0, 180] deg", "[-1, 1]" (cosines are unitless)
    return "[" + format_number(c.min) + ", " + format_number(c.max) + "]" +
           (std::string(c.unit) == "1" ? "" : std::string(" ") + c.unit);
}

ParameterInfo parameter_info(std::string name, std::string unit, std::string description,
                             double lo, double hi, std::optional<double> default_value) {
    ParameterInfo p;
    p.name = std::move(name);
    p.unit = std::move(unit);
    p.description = std::move(description);
    p.min = lo;
    p.max = hi;
    p.default_value = default_value;
    return p;
}

// -------------------------------------------------------------- PointBuilder

PointBuilder::PointBuilder(const ModelInfo& model, const QuantityInfo& quantity)
    : model_(model), quantity_(quantity) {}

namespace {
bool uses(const QuantityInfo& q, const char* direction) {
    for (const auto& d : q.directions)
        if (d == direction) return true;
    return false;
}
}  // namespace

std::vector<std::string> PointBuilder::required_names() const {
    std::vector<std::string> out;
    if (uses(quantity_, "theta_i")) out.push_back("theta_i");
    if (uses(quantity_, "theta_o")) out.push_back("theta_o");
    for (const auto& p : model_.parameters)
        if (!p.default_value) out.push_back(p.name);
    return out;
}

std::string PointBuilder::check(const std::string& name, double value) const {
    if (is_direction_coordinate(name)) {
        if (!direction_accepts(name, value))
            return "value " + format_number(value) + " of '" + name +
                   "' is out of range; allowed: " + direction_range_text(name);
        return {};
    }
    const ParameterInfo* p = model_.find_parameter(name);
    if (!p) {
        std::vector<std::string> names = {"theta_i", "phi_i", "theta_o", "phi_o",
                                          "phi_d",   "mu_i",  "mu_o"};
        for (const auto& q : model_.parameters) names.push_back(q.name);
        return "'" + name + "' is not a coordinate or parameter of model '" +
               model_.name + "'; allowed: " + join(names);
    }
    if (!p->accepts(value))
        return "value " + format_number(value) + " of '" + name +
               "' is out of range; allowed: " + p->range_text();
    return {};
}

void PointBuilder::build(const std::map<std::string, double>& values,
                         double* out) const {
    for (const auto& [name, value] : values) {
        std::string problem = check(name, value);
        if (!problem.empty()) throw InputError(problem);
    }
    auto get = [&](const char* n) -> const double* {
        auto it = values.find(n);
        return it == values.end() ? nullptr : &it->second;
    };
    auto theta = [&](const char* theta_name, const char* mu_name) -> double {
        const double* t = get(theta_name);
        const double* m = get(mu_name);
        if (t && m)
            throw InputError(std::string("give either '") + theta_name + "' or '" +
                             mu_name + "', not both");
        if (t) return *t * kDegToRad;
        if (m) return std::acos(*m);
        if (uses(quantity_, theta_name))
            throw InputError("quantity '" + quantity_.name + "' needs '" + theta_name +
                             "' (or '" + mu_name + "')");
        return 0.0;
    };
    out[0] = theta("theta_i", "mu_i");
    out[2] = theta("theta_o", "mu_o");
    const double* phi_i = get("phi_i");
    const double* phi_o = get("phi_o");
    const double* phi_d = get("phi_d");
    if (phi_o && phi_d) throw InputError("give either 'phi_o' or 'phi_d', not both");
    out[1] = phi_i ? *phi_i * kDegToRad : 0.0;
    out[3] = phi_o ? *phi_o * kDegToRad : out[1] + (phi_d ? *phi_d * kDegToRad : 0.0);

    std::map<std::string, double> params;  // every parameter, for model_.check_point
    for (std::size_t k = 0; k < model_.parameters.size(); ++k) {
        const ParameterInfo& p = model_.parameters[k];
        double v;
        if (const double* given = get(p.name.c_str()))
            v = *given;
        else if (p.default_value)
            v = *p.default_value;
        else
            throw InputError("model '" + model_.name + "' needs parameter '" + p.name +
                             "' (allowed " + p.range_text() + ")");
        out[kDirectionSlots + k] = p.in_degrees ? v * kDegToRad : v;
        params[p.name] = v;
    }
    if (model_.check_point) {
        const std::string problem = model_.check_point(quantity_, params);
        if (!problem.empty()) throw InputError(problem);
    }
}

std::vector<int> resolve_options(const ModelInfo& model, const nlohmann::json& given,
                                 const std::string& where) {
    std::vector<int> out;
    for (const auto& o : model.options) out.push_back(o.index_of(o.default_choice));
    if (given.is_null()) return out;
    const std::string prefix = where.empty() ? "" : where + ": ";
    for (auto it = given.begin(); it != given.end(); ++it) {
        const OptionInfo* o = model.find_option(it.key());
        if (!o) {
            std::vector<std::string> names;
            for (const auto& x : model.options) names.push_back(x.name);
            throw InputError(prefix + "model '" + model.name + "' has no option '" +
                             it.key() + "'; allowed: " + join(names));
        }
        if (!it.value().is_string())
            throw InputError(prefix + "option '" + it.key() + "' takes a string; allowed: " +
                             join(o->choices));
        int idx = o->index_of(it.value().get<std::string>());
        if (idx < 0)
            throw InputError(prefix + "option '" + it.key() + "' cannot be '" +
                             it.value().get<std::string>() + "'; allowed: " +
                             join(o->choices));
        out[static_cast<std::size_t>(o - model.options.data())] = idx;
    }
    return out;
}

bool method_suits(QuantityKind kind, Method method) {
    switch (method) {
        case Method::Auto: return true;
        case Method::ClosedForm: return kind == QuantityKind::ClosedForm;
        case Method::Quadrature: return kind == QuantityKind::Quadrature;
        case Method::MonteCarlo:
        case Method::Rqmc: return kind != QuantityKind::ClosedForm;
    }
    return false;
}

Method resolve_method(const QuantityInfo& q, Method requested) {
    if (requested == Method::Auto) return q.default_method;
    if (!method_suits(q.kind, requested)) {
        std::string allowed;
        for (const auto& [method, name] : kMethodNames)
            if (method_suits(q.kind, method))
                allowed += (allowed.empty() ? "" : ", ") + std::string(name);
        throw InputError("method '" + to_string(requested) + "' does not suit quantity '" + q.name +
                         "' (" + quantity_kind_text(q.kind) + "); allowed for it: " + allowed);
    }
    return requested;
}

Method resolve_table_method(const QuantityInfo& q, Method requested) {
    if (q.kind == QuantityKind::ClosedForm) return Method::ClosedForm;
    return resolve_method(q, requested);
}

nlohmann::json describe_models() {
    nlohmann::json models = nlohmann::json::array();
    for (const auto& m : all_models()) {
        nlohmann::json jm;
        jm["name"] = m.name;
        jm["citation"] = m.citation;
        jm["description"] = m.description;
        for (const auto& p : m.parameters) {
            nlohmann::json jp = {{"name", p.name},
                                 {"unit", p.unit},
                                 {"range", p.range_text()},
                                 {"description", p.description}};
            if (p.default_value) jp["default"] = *p.default_value;
            jm["parameters"].push_back(jp);
        }
        for (const auto& o : m.options)
            jm["options"].push_back({{"name", o.name},
                                     {"choices", o.choices},
                                     {"default", o.default_choice},
                                     {"description", o.description}});
        for (const auto& q : m.quantities)
            jm["quantities"].push_back(
                {{"name", q.name},
                 {"description", q.description},
                 {"units", q.units},
                 {"kind", quantity_kind_name(q.kind)},
                 {"directions", q.directions},
                 {"options", q.uses_options},
                 {"default_method", to_string(q.default_method)},
                 {"equations", q.equations},
                 {"float_vs_double",
                  q.float_measured()
                      ? nlohmann::json{{"max_relative_difference", q.float_max_rel_diff},
                                       {"float32_storage", q.float_enough_for_float32()},
                                       {"float16_storage", q.float_enough_for_float16()},
                                       {"note", q.float_note}}
                      : nlohmann::json(nullptr)}});
        models.push_back(jm);
    }
    return models;
}

}  // namespace brdftab
