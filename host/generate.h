// generate.h — turn a parsed spec into computed tables (no I/O, no printing).
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "engine.h"
#include "spec.h"
#include "table.h"

namespace brdftab {

struct GenerateEvent {
    std::size_t table_index = 0, table_count = 0;
    const TableSpec* table = nullptr;
    Progress progress;
};
using GenerateProgressFn = std::function<void(const GenerateEvent&)>;

struct GeneratedTable {
    TableData data;
    std::size_t cells_unconverged = 0;
};

// Computes every table of `spec` with `settings` (the spec's integration
// settings with any command-line overrides applied).
std::vector<GeneratedTable> generate_tables(const Spec& spec, Backend& backend,
                                            const IntegrationSettings& settings,
                                            const GenerateProgressFn& progress = nullptr);

// Kernel point of one table cell: fixed values + the cell's axis values.
// The full PointBuilder (validation, defaults, name resolution) runs once, on
// the first node; each cell then only rewrites the slots its axes feed, which
// keeps point building off the critical path of large closed-form tables.
class CellPoints {
public:
    CellPoints(const ModelInfo& model, const QuantityInfo& quantity, const TableSpec& table);
    std::size_t cell_count() const { return grid_.cell_count(); }
    void point(std::size_t cell, double* out) const;

private:
    enum class Feed { ThetaDeg, Mu, PhiIDeg, PhiODeg, PhiDDeg, Param, ParamDeg };
    struct AxisFeed {
        Feed feed;
        std::size_t slot;
    };
    Grid grid_;
    std::vector<double> base_;      // point at the first node of every axis
    std::vector<AxisFeed> feeds_;   // one per axis
    bool phi_o_from_phi_d_ = false; // phi_o = phi_i + phi_d (phi_d given)
    double fixed_phi_d_ = 0;        // radians, when phi_d is fixed, not an axis
};

}  // namespace brdftab
