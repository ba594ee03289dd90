// spec.h — table specifications (TOML).  Full key reference: docs/spec.md.
//
// Every error is an InputError whose message starts with
// "<file>:<line>:<column>: key '<dotted.key>': " and states the allowed values
// or range, so the CLI can print it as is and exit with code 2.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "host/engine/engine.h"
#include "host/core/grid.h"
#include "host/core/table.h"

namespace brdftab {

struct OutputSettings {
    std::string path;  // a relative output.path is resolved against the spec file's
                       // directory; the default (<stem>.h5) is in the current directory
    StoredType stored_type = StoredType::Float32;
    int compression = 6;  // deflate level 0..9
    bool keep_stderr = true;
    // round_to_accuracy / round_measure: stored values keep only the
    // mantissa bits this accuracy needs (host/io/bit_rounding.h); 0: off.
    double round_accuracy = 0;
    bool round_absolute = false;
    // representation: "tensor" (one grid per table, the default), "adaptive"
    // (docs/adaptive.md) or "auto" (the planner compares both and generates
    // the one predicted to store fewer values; docs/adaptive.md, "Choosing").
    std::string representation = "tensor";
    bool representation_given = false;  // the key was written
};

// Settings of adaptive tables ([adaptive] and a [[tables]] entry's
// `adaptive`, docs/spec.md): an unset field takes the command line's value,
// else the default of AdaptiveCliOptions.  Positions are in user units.
struct AdaptiveSpecSettings {
    std::optional<double> accuracy;   // the refinement's target ([adaptive] only)
    std::optional<bool> absolute;     // measure = "absolute" | "relative" ([adaptive] only)
    std::optional<std::size_t> max_values;
    std::optional<std::size_t> patch_nodes;  // 3, 5 or 9
    std::optional<int> patch_order;          // 1 or 2
    // axis name -> position; `*_given`: the key was present (an empty table
    // then declares none, overriding [adaptive]'s list).
    std::vector<std::pair<std::string, double>> breakpoints, jumps;
    bool breakpoints_given = false, jumps_given = false;
    std::map<std::string, int> initial_level;  // axis name -> uniform halvings
};

struct TableSpec {
    std::string name;      // group name in the file (default: the quantity)
    std::string quantity;
    std::string description;
    // Fixed continuous parameters and directions (user units), name -> value.
    std::map<std::string, double> fixed;
    // Categorical options, name -> choice (validated against the model).
    nlohmann::json options = nlohmann::json::object();
    std::vector<Axis> axes;
    // The table's own round_to_accuracy (0: [output]'s), in [output]'s
    // round_measure.
    double round_accuracy = 0;
    // The table's own adaptive settings (its `adaptive` key): each field set
    // here wins over [adaptive]'s.
    AdaptiveSpecSettings adaptive;
};

// A table formed from other tables of the same spec, with no computing of its
// own: value = sum_k C_k(p) * table_k, C_k polynomials in one user parameter p
// (e.g. Oren-Nayar's rho * direct + rho^2 * interreflection).  The file stores
// the recipe (parameters["recombine"], the format brdftab::LookupTable reads)
// and, as `value`, the recombination at p = stored_at.
struct RecombinedSpec {
    std::string name, description;
    std::string parameter;
    std::optional<std::pair<double, double>> range;
    double stored_at = 1;
    std::vector<std::pair<std::string, std::vector<double>>> terms;  // table, coeffs of p^0, p^1, ...
};

// A table comparing two tables of the same spec cell by cell, with no
// computing of its own (e.g. an analytic model against its Monte Carlo
// reference).  relative: (table - reference) / max(|reference|, floor);
// absolute: table - reference.  The standard error is propagated from both
// tables, treated as independent.  The file stores the recipe and a summary
// (max |error|, RMS, worst cell, cells beyond 2 standard errors, and per node
// of the `by` axis) in parameters["comparison"].
struct ErrorTableSpec {
    std::string name, description;
    std::string table, reference;
    bool relative = true;
    double floor = 0;
    std::string by;  // axis name for the per-node summary; empty: none
};

// A table that inverts a strictly monotone 1-D table of the same spec: for
// the source y(x), the values x(y) on a new axis of y values (e.g. the
// particle albedo c from the spherical albedo kd).  Inverts the library's
// linear interpolation of the source exactly; standard error
// sigma_x = sigma_y / |dy/dx|.
struct InvertedSpec {
    std::string name, description;
    std::string table;  // the source, a [[tables]] entry with one axis
    Axis axis;          // the new axis (the source's values)
};

struct Spec {
    std::string file;  // path as given (for messages); "<string>" when parsed from text
    std::string text;  // the spec's full text (stored in the output file)
    std::string model;
    std::string description;
    std::vector<TableSpec> tables;
    std::vector<RecombinedSpec> recombined;
    std::vector<ErrorTableSpec> errors;
    std::vector<InvertedSpec> inverted;
    IntegrationSettings integration;
    OutputSettings output;
    AdaptiveSpecSettings adaptive;  // [adaptive]
};

Spec parse_spec_file(const std::string& path);
Spec parse_spec_string(const std::string& text, const std::string& file_name);

}  // namespace brdftab
