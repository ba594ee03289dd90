// generate.h — turn a parsed spec into computed tables (no I/O, no printing).
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "host/engine/engine.h"
#include "host/spec/spec.h"
#include "host/core/table.h"

namespace brdftab {

struct GenerateEvent {
    std::size_t table_index = 0, table_count = 0;
    const TableSpec* table = nullptr;
    Progress progress;
};
using GenerateProgressFn = std::function<void(const GenerateEvent&)>;

// What an [[errors]] table found (also stored in its parameters["comparison"]).
struct ErrorSummary {
    std::string table, reference, measure;  // measure: "relative" | "absolute"
    std::size_t cells = 0;
    std::size_t nonfinite = 0;      // cells where either table is NaN/inf (left out below)
    double max_abs = 0;             // largest |error|
    double rms = 0;                 // root mean square error
    double mean = 0;                // mean signed error (bias)
    std::vector<double> worst;      // axis values of the cell with the largest |error|
    double median_stderr = 0;       // median standard error of the error: the noise level
    std::size_t beyond_2sigma = 0;  // cells whose |error| exceeds 2 standard errors
    struct Node {
        double value = 0, max_abs = 0, rms = 0;
    };
    std::string by;              // the spec's `by` axis, or empty
    std::vector<Node> by_nodes;  // one per node of `by`
};

struct GeneratedTable {
    TableData data;
    std::size_t cells_unconverged = 0;
    std::optional<ErrorSummary> error;  // set for [[errors]] tables
    // Smallest and largest value (for the summary; NaNs skipped unless the
    // first cell is one), set by set_value_range: a streamed table
    // (host/generate/chunked.h) no longer holds its values.
    double value_min = 0, value_max = 0;
    // Largest per-cell standard error (the quadrature's difference), absolute
    // and relative to |value| (cells with value 0 left out), for the summary.
    double stderr_max_abs = 0, stderr_max_rel = 0;
};
// The same fold for standard errors (stderr_max_abs/_rel of GeneratedTable).
void fold_stderr_max(const double* value, const double* stderr_, std::size_t n, double& max_abs,
                     double& max_rel);

// value_min/value_max of `g` from g.data.value.
void set_value_range(GeneratedTable& g);
// The same fold over values given piece by piece: start with `first` = true.
void fold_value_range(const double* value, std::size_t n, bool& first, double& lo, double& hi);

class Checkpoint;

// Computes every table of `spec` with `settings` (then its [[recombined]],
// [[errors]] and [[inverted]] tables, in that order) (the spec's integration
// settings with any command-line overrides applied).
// With `checkpoint` (host/generate/checkpoint.h), each table's estimator
// state is stored while it is computed and continued from where stored.
std::vector<GeneratedTable> generate_tables(const Spec& spec, Backend& backend,
                                            const IntegrationSettings& settings,
                                            const GenerateProgressFn& progress = nullptr,
                                            Checkpoint* checkpoint = nullptr);

// What generate_tables() and the final write will need, estimated from the
// spec alone before anything is computed, so that a table too large for the
// machine is refused up front, not with bad_alloc after starting or only
// when writing.  Counts
// are doubles so that absurd grids (65536^4 cells) do not wrap.
struct ResourceEstimate {
    double cells = 0;         // cells of every table, derived ones included
    double largest_cells = 0; // cells of the largest computed table
    double memory_bytes = 0;  // peak resident memory of the tables
    double disk_bytes = 0;    // datasets as stored, before compression
};
// Memory model of `brdftab generate` (generate_to_file, host/generate/
// chunked.h; measured with /usr/bin/time -v, docs/spec.md "Memory and disk"):
// tables are computed in chunks of `chunk_cells` cells (0: automatic) and
// each finished chunk is written to the file, so what is held is the
// engine's per-cell state of one chunk, its results, their conversion for
// the file and its checkpoint buffer; plus HDF5's chunk cache of every open
// dataset, and, whole, the computed tables a derived table reads and the
// derived tables.  Disk: cells x stored type size for value and stderr
// (kept, not closed form) plus 4 B for samples (estimated tables), plus the
// checkpoint's 65 B per computed cell.
ResourceEstimate estimate_resources(const Spec& spec, const IntegrationSettings& settings,
                                    std::size_t chunk_cells = 0);

// Kernel point of one table cell: fixed values + the cell's axis values.
// The full PointBuilder (validation, defaults, name resolution) runs once, on
// the first node; each cell then only rewrites the slots its axes feed, which
// keeps point building off the critical path of large closed-form tables.
class CellPoints {
public:
    CellPoints(const ModelInfo& model, const QuantityInfo& quantity, const TableSpec& table);
    std::size_t cell_count() const { return grid_.cell_count(); }
    void point(std::size_t cell, double* out) const;
    // The points of cells first .. first + count - 1, point k at
    // out + k * model.point_stride(): point()'s values, found by stepping
    // the grid's multi-index from cell to cell instead of dividing per cell.
    void points(std::size_t first, std::size_t count, double* out) const;

private:
    // How an axis value reaches its kernel slot (CoordinateEncoding for
    // directions; parameters are Plain, or Degrees when in_degrees).
    enum class Feed { Degrees, Cosine, AzimuthOffset, Plain };
    struct AxisFeed {
        Feed feed;
        std::size_t slot;
    };
    // Axis a's value v into its kernel slot of `out` (or into phi_d).
    void feed(std::size_t a, double v, double* out, double& phi_d) const;
    Grid grid_;
    std::vector<double> base_;      // point at the first node of every axis
    std::vector<AxisFeed> feeds_;   // one per axis
    bool phi_o_from_phi_d_ = false; // phi_o = phi_i + phi_d (phi_d given)
    double fixed_phi_d_ = 0;        // radians, when phi_d is fixed, not an axis
};

}  // namespace brdftab
