// registry.h — what models exist, their quantities, parameters (with allowed
// ranges), categorical options and implemented equations.
//
// The model contract.  A model is one kernel header (kernels/models/<model>.h)
// and one registration file (host/models/<model>.cpp); nothing else names it.
// The kernel header declares the slot of every continuous parameter in the
// point, of every option and the id of every quantity as named constants
// (e.g. MG_P_TAU0, MG_O_GRAIN, MG_Q_BRDF, MG_NUM_PARAMS); the registration
// file describes the model with ModelBuilder, addressing each entry by those
// constants, and registers itself with BRDFTAB_REGISTER_MODEL.  ModelBuilder
// checks the description against the declared counts when the registry is
// first used.  docs/adding-a-model.md walks through it.
//
// Point layout shared with the kernels (kernels/common/estimator.h): each cell
// is a vector of REALs
//     [theta_i, phi_i, theta_o, phi_o, <continuous parameters by slot>]
// with angles in radians.  Categorical options go to the kernel as ints, by
// slot, each the index of the chosen value in `choices`.
//
// User-facing coordinate names (CLI `eval`, spec axes), all in degrees except mu,
// are the table kCoordinates of host/core/vocabulary.h:
//   theta_i, phi_i, theta_o, phi_o   polar angle in [0, 180] from the macro normal
//                                    (> 90 = below the surface), azimuth
//   phi_d                            phi_o - phi_i (phi_i then defaults to 0)
//   mu_i, mu_o                       cos(theta), in [-1, 1]
#pragma once

#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "host/core/vocabulary.h"

// The sampler state of kernels/common/sampler.h; host code outside the engine
// and the model files only passes pointers to it.
struct bt_sampler;

namespace brdftab {

// A model's sample function compiled as C++ (REAL is double on the host): the
// `--device host` serial reference path.  Model files pass the kernel
// function itself, e.g. &micrograin_sample.
typedef double (*HostSampleFn)(const double* point, const int* options, int quantity,
                               const bt_sampler* sampler);

constexpr int kDirectionSlots = 4;

// Node-parallel quadrature (OpenCL backend only; kernels/common/node_parallel.h,
// host/engine/launch/node_parallel*.cpp): a quantity whose value is an in-order sum of
// data-dependent length, value = finish(term(0) + term(1) + ... +
// term(count - 1)), names the four functions of its kernel header that
// compute it and the size of the state its terms share (signatures in
// node_parallel.h), and the count function compiled for the host, by which
// the engine lays out one work item per node.
// The model's sample function must compute exactly that composition (same
// calls, same order), so that both paths give the same bits.  Empty (no
// host_count): the quantity runs the usual kernel only.
typedef int (*HostNodeCountFn)(const double* point, const int* options, int quantity,
                               const bt_sampler* sampler);
struct NodeParallelFunctions {
    std::string count, prepare, term, finish;  // function names in the kernel header
    int state_size = 0;                        // REAL values prepare writes
    HostNodeCountFn host_count = nullptr;
    // Nested sums (kernels/common/node_parallel.h, "Nested sums"; set
    // group_prepare to use them): host_count counts a work item's groups,
    // the device each group's nodes.  The group functions (prepare, reduce
    // its nodes' terms to partial sums, add those to the accumulators), the
    // model's sample function, the group state's size, the terms per node,
    // the partial sums per group, the accumulators and the most groups of a
    // work item.
    std::string group_prepare = {}, group_reduce = {}, group_add = {}, sample = {};
    int group_state_size = 0, terms = 1, partials = 1, acc_size = 1, max_groups = 0;
    // The table prepare reads (nested sums only; computed on the device once
    // per program): its function (void table(int entry, REAL* values)), its
    // entries and the values per entry.  Empty: a one-value table of zeros.
    std::string table = {};
    int table_entries = 0, table_size = 0;
    // Split terms (flat sums only; node_parallel.h, "Split terms"): the two
    // forms of a term, each NaN at the other form's nodes, and how many
    // leading nodes of a work item the host takes to be of the first form
    // (a guess: a wrong one costs time, not bits).  Empty: one node kernel.
    std::string term_first = {}, term_second = {};
    HostNodeCountFn host_split = nullptr;
    bool split() const { return host_split != nullptr && !term_first.empty() && !term_second.empty(); }
    // Whether it runs with BRDFTAB_NODE_PARALLEL unset (and
    // node_parallel_by_default()); false: only with BRDFTAB_NODE_PARALLEL=1.
    bool by_default = true;
    bool nested() const { return !group_prepare.empty(); }
    bool enabled() const { return host_count != nullptr; }
};

// One option set to one of its choices, by name (the launch preferences below).
struct OptionChoice {
    std::string option, choice;
};

// A sample-parallel default (QuantityInfo::sample_parallel): Monte Carlo or
// RQMC batches of the quantity by `method` run sample-parallel on OpenCL
// devices when every listed option has its listed choice (none: any options).
struct SampleParallelRule {
    Method method = Method::MonteCarlo;
    std::vector<OptionChoice> options = {};
};

// Walk-parallel launches (OpenCL backend only; kernels/common/walk_parallel.h,
// host/engine/launch/): a random-walk quantity names its walk's state type
// and the functions of its kernel header that set it up, begin a sample,
// advance it one collision and read its value.  Empty: the usual kernel only.
struct WalkParallelFunctions {
    std::string state, setup, begin, step, value;
    bool enabled() const { return !state.empty(); }
};

// A quantity's per-cell invariants (ModelInfo::derive): `slots` values that
// follow the parameters in every kernel point, written by `fill` into a point
// whose first point_stride() values are set.
struct CellDerivation {
    int slots = 0;
    std::function<void(double* point)> fill;
};

struct ParameterInfo {
    std::string name;
    std::string unit;  // "1", "deg"
    std::string description;
    double min = 0, max = 0;
    bool min_inclusive = true, max_inclusive = true;
    std::optional<double> default_value;
    bool in_degrees = false;  // converted to radians before reaching the kernel
    bool integer = false;     // only whole numbers (orders, node counts, modes)

    bool accepts(double v) const;
    std::string range_text() const;  // e.g. "(0, 4]", "integers in [0, 128]"

    // Chainable adjustments of a parameter_info() result.
    ParameterInfo& open_min() { min_inclusive = false; return *this; }
    ParameterInfo& open_max() { max_inclusive = false; return *this; }
    ParameterInfo& degrees() { in_degrees = true; return *this; }
    ParameterInfo& whole() { integer = true; return *this; }
};

// Registry shorthand: a parameter with the closed range [lo, hi]; chain
// .open_min() / .open_max() / .degrees() / .whole() (integers only) for the
// other cases, e.g.
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

struct QuantityInfo {
    std::string name;
    int id = 0;  // the `quantity` argument of the model's sample function
    std::string description;
    std::string units;  // "1/sr" or "1"
    QuantityKind kind = QuantityKind::ClosedForm;
    std::vector<std::string> directions;  // subset of theta_i, phi_i, theta_o, phi_o it depends on
    std::vector<std::string> uses_options;  // options that matter (others ignored)
    std::string equations;                  // e.g. "eqs. 20-21 (Walter 2007)"
    Method default_method = Method::ClosedForm;  // never Method::Auto
    unsigned dimensions = 0;  // random dimensions per sample (integrals)
    // Float against double (`--precision float`), as measured on the shrunk
    // presets in docs/precision.md ("Float against double"; seed 7, PoCL CPU
    // device): the largest relative |float - double| over every preset table
    // of this quantity; negative where it was not measured.  Set by the model
    // file (ModelBuilder::float_vs_double) from that measurement, never
    // estimated.  float_note: where float fails, when it does.
    double float_max_rel_diff = -1;
    std::string float_note = {};  // = {}: aggregates that stop before it stay warning-free
    // Node-parallel quadrature functions (see NodeParallelFunctions); set by
    // the model file after registering the quantity.
    NodeParallelFunctions node_parallel = {};
    // Staged samples (kernels/common/staged_samples.cl):
    // the kernel header's stage and rest functions, whose composition is the
    // sample function's value, and the stage's size; the engine runs them in
    // sample-parallel launches whose search takes fixed steps.  size 0: none.
    struct StagedSample {
        std::string stage, rest;
        int size = 0;
        bool enabled() const { return size > 0; }
    };
    StagedSample staged = {};
    // Launch preferences on OpenCL devices (host/engine/launch/), each a
    // measured choice that changes no result (docs/benchmarks.md): where its
    // Monte Carlo / RQMC batches run sample-parallel by default; the option
    // choices (any one suffices) under which its sample-parallel kernels use
    // kernels/common/microfacet.h's fixed-step visible-normal search, with a
    // redo kernel for the samples whose search had not ended (double
    // precision only; a staged quantity runs sample-parallel only then); and
    // its walk-parallel functions.
    std::vector<SampleParallelRule> sample_parallel = {};
    std::vector<OptionChoice> fixed_step_solver = {};
    WalkParallelFunctions walk_parallel = {};
    bool float_measured() const { return float_max_rel_diff >= 0; }
    // Whether float reaches the precision of a stored float32 (2^-24 relative)
    // or float16 (2^-11) table over the measured domains.
    bool float_enough_for_float32() const {
        return float_measured() && float_max_rel_diff <= 5.9604644775390625e-08;
    }
    bool float_enough_for_float16() const {
        return float_measured() && float_max_rel_diff <= 4.8828125e-04;
    }
};

// One case of `brdftab bench` (host/engine/bench.h, BenchCase): a quantity
// whose speed the bench measures.  per_cell: quadratures report cells per
// second (one cell = the accurate and the coarse rule), others evaluations
// per second.  flops_estimate: arithmetic operations of one evaluation,
// counted by hand from the kernel source (0: not counted).  theta_o_max: the
// range of theta_o in degrees (89: upper hemisphere, 179: both sides).
// method: the one measured (Auto: the quantity's default).  headline: the
// case whose device rate the bench's targets judge (at most one).
struct BenchDeclaration {
    std::string quantity;
    bool per_cell = false;
    double flops_estimate = 0;
    double theta_o_max = 89;
    Method method = Method::Auto;
    bool headline = false;
};

struct ModelInfo {
    std::string name;
    std::string citation;
    std::string description;
    // Position in `brdftab models` listings (ascending; ties by name).
    int listing_order = 0;
    // The kernel header, relative to kernels/ (e.g. "models/micrograin.h"), and
    // the name of its sample function; the engine generates the OpenCL entry
    // point around them (kernels/common/estimate.cl).
    std::string kernel_header;
    std::string sample_function;
    std::vector<ParameterInfo> parameters;
    std::vector<OptionInfo> options;
    std::vector<QuantityInfo> quantities;
    HostSampleFn host_fn = nullptr;
    // Whether its OpenCL programs are built with forced inlining
    // (BT_FORCE_INLINE, kernels/common/estimator.h), which lets PoCL run the
    // work items of a group as SIMD lanes where calls kept them scalar.  Set
    // only where measured faster with every preset bit-identical
    // (docs/contributing.md, PoCL findings); extra kernel options naming
    // BT_FORCE_INLINE (EngineTuning) decide instead.
    bool force_inline = false;
    // The cases of `brdftab bench` (host/engine/bench.h) for this model's
    // quantities, in the order the bench runs them.
    std::vector<BenchDeclaration> bench = {};
    // Optional check across parameters that a per-parameter range cannot
    // express (e.g. lambert-sphere's tail_order > max_order).  `params` holds
    // every parameter's value (given or default, user units); returns an error
    // text, or empty when the point is valid.  PointBuilder::build calls it.
    std::string (*check_point)(const QuantityInfo& q,
                               const std::map<std::string, double>& params) = nullptr;
    // Optional check of one cell as the kernel will see it, for rules that
    // involve options (e.g. rough-dielectric: Phong needs alpha < 1).
    // `point` is the kernel point (point_stride() values, parameters by slot,
    // angles in radians), `options` the option indices; returns an error text
    // naming the parameter, its value and the allowed range, or empty.  The
    // engine (estimate()) checks every cell with it (or with cells_pass,
    // below) before any kernel launch (closed forms without a checkpoint: on
    // each launch's cells as the launch is built), so eval, generate and
    // validate refuse the same cells.
    std::string (*check_cell)(const QuantityInfo& q, const double* point,
                              const std::vector<int>& options) = nullptr;
    // Optional fast form of check_cell over many cells at once: `count`
    // kernel points, point k at points + k * stride; true when check_cell
    // accepts every one of them.  It must agree with check_cell (build()
    // refuses it without one).  The engine asks it first, once per span of
    // cells, and calls check_cell, which builds the message, only on a span
    // it refuses, to find that span's first refused cell: the same cell and
    // message as a check of every cell, without a std::string per cell.
    bool (*cells_pass)(const QuantityInfo& q, const double* points, std::size_t count,
                       std::size_t stride, const std::vector<int>& options) = nullptr;
    // Optional per-cell invariants hoisted out of the kernel: values that
    // depend on a cell's parameters alone and cost far more than the rest of
    // the cell (lambert-sphere: the exact Horak-Chandrasekhar constants, a
    // 0.5-6 ms solve per value of c).  For (q, options) it returns how many
    // values to append to the kernel point (0: none) and the function that
    // computes them from the point; estimate() calls that function on the
    // host once per cell, before the cell's first launch, and the kernel
    // reads the values instead of solving them in every batch.  The function
    // may memoise (one solve per distinct c); point_stride() + slots must not
    // exceed BT_MAX_POINT.
    CellDerivation (*derive)(const QuantityInfo& q, const std::vector<int>& options) = nullptr;

    const QuantityInfo* find_quantity(const std::string& name) const;
    const ParameterInfo* find_parameter(const std::string& name) const;
    const OptionInfo* find_option(const std::string& name) const;
    // Throwing variants: InputError listing the valid names.
    const QuantityInfo& quantity(const std::string& name) const;
    std::size_t point_stride() const { return kDirectionSlots + parameters.size(); }
};

// Every registered model, in listing order.  The first call builds them (and
// throws std::logic_error naming the model if a description breaks the
// contract: a programming error, caught by tests/test_model_registry.cpp).
const std::vector<ModelInfo>& all_models();
// Throws InputError listing known models.
const ModelInfo& find_model(const std::string& name);

// Describes one model; build() checks it against the counts its kernel header
// declares.  Slots and ids are the kernel header's constants:
//   parameter(MG_P_TAU0, parameter_info(...))   slot in the point, >= kDirectionSlots
//   option(MG_O_GRAIN, OptionInfo{...})          index in the options array
//   quantity(MG_Q_BRDF, QuantityInfo{...})       the `quantity` argument (its
//                                                `id` field is set from here)
// build() requires: parameter slots dense from kDirectionSlots, option slots
// and quantity ids dense from 0, each exactly as many as declared with
// counts(); the point within BT_MAX_POINT and options within BT_MAX_OPTIONS
// (kernels/common/estimator.h); unique names; defaults inside their ranges;
// quantities that name only existing directions and options.
class ModelBuilder {
public:
    ModelBuilder(std::string name, int listing_order);
    ModelBuilder& citation(std::string text);
    ModelBuilder& description(std::string text);
    // kernel_header relative to kernels/, e.g. "models/micrograin.h".
    ModelBuilder& kernel(std::string kernel_header, std::string sample_function,
                         HostSampleFn host_fn);
    // The counts the kernel header declares (<PFX>_NUM_PARAMS, ..._OPTIONS, ..._QUANTITIES).
    ModelBuilder& counts(int parameters, int options, int quantities);
    ModelBuilder& parameter(int slot, ParameterInfo info);
    ModelBuilder& option(int slot, OptionInfo info);
    ModelBuilder& quantity(int id, QuantityInfo info);
    // The same with the id already in `info` (aggregate initialisation).
    ModelBuilder& quantity(QuantityInfo info) { return quantity(info.id, std::move(info)); }
    ModelBuilder& check_point(std::string (*fn)(const QuantityInfo&,
                                                const std::map<std::string, double>&));
    ModelBuilder& check_cell(std::string (*fn)(const QuantityInfo&, const double*,
                                               const std::vector<int>&));
    ModelBuilder& cells_pass(bool (*fn)(const QuantityInfo&, const double*, std::size_t,
                                        std::size_t, const std::vector<int>&));
    ModelBuilder& derive(CellDerivation (*fn)(const QuantityInfo&, const std::vector<int>&));
    // ModelInfo::force_inline (set it only with the measurement that chose it).
    ModelBuilder& force_inline();
    // QuantityInfo::float_max_rel_diff and float_note of quantity `id`.
    ModelBuilder& float_vs_double(int id, double max_rel_diff, std::string note = "");
    // A `brdftab bench` case (ModelInfo::bench).
    ModelBuilder& bench(BenchDeclaration info);
    // The quantity registered under `id` (to adjust it after a shared factory).
    QuantityInfo& quantity_by_id(int id);
    ModelInfo build() const;

private:
    ModelInfo model_;
    int declared_parameters_ = -1, declared_options_ = -1, declared_quantities_ = -1;
    std::vector<int> parameter_slots_, option_slots_;
};

namespace detail {
using ModelFactory = ModelInfo (*)();
// Adds a factory to the registry; BRDFTAB_REGISTER_MODEL creates one per model.
struct ModelRegistration {
    explicit ModelRegistration(ModelFactory factory);
};
}  // namespace detail

}  // namespace brdftab

// In a host/models/<model>.cpp, at namespace scope:
//     BRDFTAB_REGISTER_MODEL(micrograin_model);
// where micrograin_model is a function returning the ModelInfo.  The build
// links host/models/ as a whole archive (CMakeLists.txt: bt_model_set), so
// every registration runs even though nothing refers to it by name.
#define BRDFTAB_REGISTER_MODEL(factory)                                              \
    static const ::brdftab::detail::ModelRegistration brdftab_model_registration_##factory{ \
        &(factory)}

namespace brdftab {

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
