// model_registry.h — what models exist, their quantities, parameters (with
// allowed ranges), categorical options and implemented equations.
//
// Point layout shared with the kernels (kernels/common/estimator.h): each cell
// is a vector of REALs
//     [theta_i, phi_i, theta_o, phi_o, <continuous parameters in registry order>]
// with angles in radians.  Categorical options go to the kernel as ints, in
// registry order, each the index of the chosen value in `choices`.
//
// User-facing coordinate names (CLI `eval`, spec axes), all in degrees except mu,
// are the table kCoordinates of host/core/vocabulary.h:
//   theta_i, phi_i, theta_o, phi_o   polar angle in [0, 180] from the macro normal
//                                    (> 90 = below the surface), azimuth
//   phi_d                            phi_o - phi_i (phi_i then defaults to 0)
//   mu_i, mu_o                       cos(theta), in [-1, 1]
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "host/core/vocabulary.h"
#include "kernels/common/compat.h"
#include "kernels/common/sampler.h"

namespace brdftab {

typedef REAL (*HostSampleFn)(const REAL* point, const int* options, int quantity,
                             const bt_sampler* sampler);

constexpr int kDirectionSlots = 4;

struct ParameterInfo {
    std::string name;
    std::string unit;  // "1", "deg"
    std::string description;
    double min = 0, max = 0;
    bool min_inclusive = true, max_inclusive = true;
    std::optional<double> default_value;
    bool in_degrees = false;  // converted to radians before reaching the kernel

    bool accepts(double v) const;
    std::string range_text() const;  // e.g. "(0, 4]"

    // Chainable adjustments of a parameter_info() result.
    ParameterInfo& open_min() { min_inclusive = false; return *this; }
    ParameterInfo& open_max() { max_inclusive = false; return *this; }
    ParameterInfo& degrees() { in_degrees = true; return *this; }
};

// Registry shorthand: a parameter with the closed range [lo, hi]; chain
// .open_min() / .open_max() / .degrees() for the other cases, e.g.
//   parameter_info("alpha", "1", "roughness", 0, 4, 0.3).open_min()
ParameterInfo parameter_info(std::string name, std::string unit, std::string description,
                             double lo, double hi,
                             std::optional<double> default_value = std::nullopt);

struct OptionInfo {
    std::string name;
    std::string description;
    std::vector<std::string> choices;
    std::string default_choice;
    int index_of(const std::string& choice) const;  // -1 when absent
};

// ClosedForm: one evaluation, no error.  Integral: Monte Carlo / RQMC with
// standard errors.  Quadrature: a deterministic rule evaluated twice (accurate
// and coarse, see BT_METHOD_QUADRATURE); the difference is the error estimate.
enum class QuantityKind { ClosedForm, Integral, Quadrature };

// A quantity's default integration method: a Method that may also be given by
// its name (q.default_method = "rqmc"), checked when the registry is built.
// Never Method::Auto.
class DefaultMethod {
public:
    DefaultMethod(Method method = Method::ClosedForm);
    DefaultMethod(const char* name);
    DefaultMethod(const std::string& name) : DefaultMethod(name.c_str()) {}
    operator Method() const { return method_; }

private:
    Method method_;
};

struct QuantityInfo {
    std::string name;
    int id = 0;  // the `quantity` argument of the model's sample function
    std::string description;
    std::string units;  // "1/sr" or "1"
    QuantityKind kind = QuantityKind::ClosedForm;
    std::vector<std::string> directions;  // subset of theta_i, phi_i, theta_o, phi_o it depends on
    std::vector<std::string> uses_options;  // options that matter (others ignored)
    std::string equations;                  // e.g. "eqs. 20-21 (Walter 2007)"
    DefaultMethod default_method = Method::ClosedForm;
    unsigned dimensions = 0;  // random dimensions per sample (integrals)
};

struct ModelInfo {
    std::string name;
    std::string citation;
    std::string description;
    std::string kernel_file;  // relative to kernels/, e.g. "rough_dielectric.cl"
    std::string kernel_name;  // entry point
    std::vector<ParameterInfo> parameters;
    std::vector<OptionInfo> options;
    std::vector<QuantityInfo> quantities;
    HostSampleFn host_fn = nullptr;
    // Optional check across parameters that a per-parameter range cannot
    // express (e.g. lambert-sphere's tail_order > max_order).  `params` holds
    // every parameter's value (given or default, user units); returns an error
    // text, or empty when the point is valid.  PointBuilder::build calls it.
    std::string (*check_point)(const QuantityInfo& q,
                               const std::map<std::string, double>& params) = nullptr;

    const QuantityInfo* find_quantity(const std::string& name) const;
    const ParameterInfo* find_parameter(const std::string& name) const;
    const OptionInfo* find_option(const std::string& name) const;
    // Throwing variants: InputError listing the valid names.
    const QuantityInfo& quantity(const std::string& name) const;
    std::size_t point_stride() const { return kDirectionSlots + parameters.size(); }
};

const std::vector<ModelInfo>& all_models();
// Throws InputError listing known models.
const ModelInfo& find_model(const std::string& name);

// Names that can be a spec axis or an `eval` argument for directions (the
// names of kCoordinates, host/core/vocabulary.h).
bool is_direction_coordinate(const std::string& name);
// Unit and allowed range of a direction coordinate ("deg", [0,180] etc.).
// `name` must be a direction coordinate (brdftab::Error otherwise).
std::string direction_unit(const std::string& name);
bool direction_accepts(const std::string& name, double value);
std::string direction_range_text(const std::string& name);

// Turns named user values into a kernel point.  `values` maps coordinate and
// parameter names (user units) to numbers; missing directions default to 0
// (phi) or must be given when the quantity uses them; missing parameters take
// their default or raise InputError.  `where` prefixes error messages (e.g.
// "spec.toml:12: key 'alpha'" or "argument").
class PointBuilder {
public:
    PointBuilder(const ModelInfo& model, const QuantityInfo& quantity);
    // The names a caller must supply (directions the quantity needs and
    // parameters without defaults).
    std::vector<std::string> required_names() const;
    // Validate a single name/value; returns an error text or empty.
    std::string check(const std::string& name, double value) const;
    void build(const std::map<std::string, double>& values, double* out_point) const;

private:
    const ModelInfo& model_;
    const QuantityInfo& quantity_;
};

// Options as kernel ints from a JSON object of name -> choice string; absent
// options take their default.  Throws InputError on unknown choice.
std::vector<int> resolve_options(const ModelInfo& model, const nlohmann::json& given,
                                 const std::string& where);

// Whether `method` can estimate a quantity of `kind` (Auto always can):
//   ClosedForm  closed-form
//   Quadrature  quadrature, mc, rqmc
//   Integral    mc, rqmc
bool method_suits(QuantityKind kind, Method method);
// Resolve Auto to the quantity's default; reject impossible combinations
// (closed-form method for an integral) with InputError.  Never returns Auto.
Method resolve_method(const QuantityInfo& q, Method requested);
// The same for a table of a spec, whose one [integration] method serves all its
// tables: closed-form quantities ignore it (they have nothing to integrate),
// every other quantity must suit it.
Method resolve_table_method(const QuantityInfo& q, Method requested);

// JSON description of every model (for `brdftab models --json` and docs).
nlohmann::json describe_models();

}  // namespace brdftab
