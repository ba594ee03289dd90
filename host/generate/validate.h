// validate.h — accuracy certificate of a stored table: its interpolated
// values (linear and cubic) against the model evaluated directly on the
// device at random off-grid points (`brdftab validate`).
//
// Two steps so that a caller can report input problems before it opens a
// device: ValidationPlan reads and checks the table and draws the points;
// run() computes the reference on a backend and the error statistics.  The
// library never prints: the caller formats the report (or to_json()).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "host/adaptive/adaptive_table.h"
#include "host/engine/engine.h"
#include "host/lookup/lookup.h"
#include "host/models/registry.h"

namespace brdftab {

struct ValidateOptions {
    std::size_t points = 1000;   // random points
    std::uint64_t seed = 1;      // of the points (and offset of the reference's seed)
    std::uint64_t samples = 0;   // integrals: fixed budget per reference point; 0 = the table's own
    // Cap on the table's own budget per reference point (its samples_requested,
    // or its max_samples under a tolerance), so that a file declaring
    // unbounded work (2^40 samples, tolerance 1e-12) cannot make validate run
    // forever: at most points x max_samples samples in all.  An explicit
    // `samples` is not capped.  The default is the engine's own cap under a
    // tolerance (IntegrationSettings::max_samples), above every preset.
    std::uint64_t max_samples = std::uint64_t{1} << 22;
    double rel_floor = 1e-3;     // relative errors divide by max(|ref|, rel_floor * max|table|)
    std::size_t worst = 5;       // worst points kept per interpolation
};

// Nearest-rank percentiles of |x|, its maximum and RMS.
struct ErrorStats {
    double max = 0, rms = 0, p50 = 0, p95 = 0, p99 = 0;
};
ErrorStats error_stats(std::vector<double> x);

// Errors of one interpolation at every point.
struct InterpolationErrors {
    const char* name = "";  // "linear" | "cubic"
    std::vector<double> value, abs, rel;  // table value, table - reference, abs / max(|ref|, floor)
    ErrorStats abs_stats, rel_stats;
    std::vector<std::size_t> worst;  // point indices, largest |rel| first
    // RMS with the reference's own noise removed (it adds in quadrature).
    double rms_abs_corrected = 0, rms_rel_corrected = 0;
    std::size_t significant = 0;  // points with |diff| > 3 reference stderr
};

struct ValidationReport {
    std::string file;
    // The validated (stored) table: name, model, quantity, units, axes.
    std::string table, model, quantity, units;
    std::vector<Axis> axes;
    std::string quantity_units;  // units of the model quantity (the registry's)
    bool recombination_skipped = false;  // the table has a recipe that was not applied
    // The table's own per-point budget was above ValidateOptions::max_samples
    // and the reference used the cap instead (table_budget: what it asked).
    bool samples_capped = false;
    std::uint64_t table_budget = 0, sample_cap = 0;
    std::size_t points = 0;
    std::uint64_t seed = 0;
    std::vector<double> coords;  // points * axes.size(), axis order
    double rel_floor_factor = 0, relative_floor = 0, max_abs_table_value = 0;

    EstimateResult reference;
    std::string device;
    Precision precision = Precision::Double;
    bool noisy = false;                   // the reference has standard errors
    std::vector<double> reference_stderr;  // per point (0 when not noisy)
    ErrorStats reference_noise;
    bool has_table_stderr = false;  // the table stores per-cell stderr
    ErrorStats table_stderr;        // interpolated at the points
    std::array<InterpolationErrors, 2> results;  // linear, cubic
    // An adaptive table (docs/adaptive.md): its patches interpolate linearly
    // only, so results[1] (cubic) is empty and not reported.
    bool adaptive = false;

    // Coordinate a of point k.
    double coord(std::size_t k, std::size_t a) const { return coords[k * axes.size() + a]; }
};

class ValidationPlan {
public:
    // Reads table `table` of `file` (tensor or adaptive), checks that it has
    // a model quantity of its own (not an error or inverted table), and draws
    // the points.
    // Throws InputError.
    ValidationPlan(const std::string& file, const std::string& table,
                   const ValidateOptions& options);

    // True when the reference is an integral (worth a progress display).
    bool integral() const { return quantity_->kind != QuantityKind::ClosedForm; }

    // The reference on `backend` (the table's own method and budget, a seed
    // independent of the table's) and the statistics.
    ValidationReport run(Backend& backend, const ProgressFn& progress = nullptr) const;

private:
    std::string file_;
    ValidateOptions options_;
    bool recombination_skipped_ = false;  // set while table_ is initialised
    // Exactly one of the two: a tensor table's stored values (recipe
    // removed), or an adaptive table.
    std::optional<LookupTable> table_;
    std::optional<AdaptiveTable> adaptive_;
    const TableData& data() const { return table_ ? table_->table() : adaptive_->data; }
    const ModelInfo* model_ = nullptr;
    const QuantityInfo* quantity_ = nullptr;
    std::vector<int> model_options_;
    std::vector<double> coords_, kernel_points_;
    IntegrationSettings reference_settings_;
    bool samples_capped_ = false;
    std::uint64_t table_budget_ = 0;
};

// The report as JSON (`brdftab validate --json`).
nlohmann::json to_json(const ValidationReport& report);

}  // namespace brdftab
