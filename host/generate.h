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
class CellPoints {
public:
    CellPoints(const ModelInfo& model, const QuantityInfo& quantity, const TableSpec& table);
    std::size_t cell_count() const { return grid_.cell_count(); }
    void point(std::size_t cell, double* out) const;

private:
    PointBuilder builder_;
    std::map<std::string, double> fixed_;
    Grid grid_;
};

}  // namespace brdftab
