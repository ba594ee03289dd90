#include "generate.h"

#include "error.h"

#ifndef BRDFTAB_VERSION
#define BRDFTAB_VERSION "unknown"
#endif

namespace brdftab {

CellPoints::CellPoints(const ModelInfo& model, const QuantityInfo& quantity,
                       const TableSpec& table)
    : builder_(model, quantity), fixed_(table.fixed), grid_(table.axes) {}

void CellPoints::point(std::size_t cell, double* out) const {
    std::map<std::string, double> values = fixed_;
    const std::vector<double> coords = grid_.coordinates(cell);
    for (std::size_t a = 0; a < coords.size(); ++a) values[grid_.axes()[a].name] = coords[a];
    builder_.build(values, out);
}

std::vector<GeneratedTable> generate_tables(const Spec& spec, Backend& backend,
                                            const IntegrationSettings& settings,
                                            const GenerateProgressFn& progress) {
    const ModelInfo& model = find_model(spec.model);
    std::vector<GeneratedTable> out;
    for (std::size_t t = 0; t < spec.tables.size(); ++t) {
        const TableSpec& ts = spec.tables[t];
        const QuantityInfo& q = model.quantity(ts.quantity);
        const std::vector<int> options =
            resolve_options(model, ts.options, spec.file + ": table '" + ts.name + "'");
        CellPoints points(model, q, ts);
        ProgressFn cb;
        if (progress)
            cb = [&](const Progress& p) {
                GenerateEvent e;
                e.table_index = t;
                e.table_count = spec.tables.size();
                e.table = &ts;
                e.progress = p;
                progress(e);
            };
        EstimateResult r = estimate(
            backend, model, q, options, points.cell_count(),
            [&](std::size_t cell, double* p) { points.point(cell, p); }, settings, cb);

        GeneratedTable g;
        TableData& d = g.data;
        d.name = ts.name;
        d.model = model.name;
        d.quantity = q.name;
        d.units = q.units;
        d.description = ts.description.empty() ? q.description : ts.description;
        nlohmann::json params = nlohmann::json::object();
        for (const auto& [k, v] : ts.fixed) params[k] = v;
        // Record every option actually used (defaults included), by name.
        for (std::size_t k = 0; k < model.options.size(); ++k)
            params[model.options[k].name] = model.options[k].choices[options[k]];
        d.parameters = params;
        d.axes = ts.axes;
        d.value = std::move(r.value);
        d.stderr_ = std::move(r.stderr_);
        if (r.method != "closed-form") d.samples = std::move(r.samples);
        d.method = r.method;
        d.samples_requested = r.method == "closed-form"
                                  ? 1
                                  : (settings.tolerance > 0 ? settings.max_samples
                                                            : (settings.samples ? settings.samples : 4096));
        d.tolerance_requested = r.method == "closed-form" ? 0 : settings.tolerance;
        d.abs_floor = settings.abs_floor;
        d.tolerance_achieved = r.tolerance_achieved;
        d.seed = settings.seed;
        d.precision = precision_name(backend.precision());
        d.device = backend.device_name();
        d.version = BRDFTAB_VERSION;
        d.spec_file = spec.file;
        d.elapsed_seconds = r.elapsed_seconds;
        d.total_samples = r.total_samples;
        d.stored_type = spec.output.stored_type;
        d.compression = spec.output.compression;
        d.keep_stderr = spec.output.keep_stderr && r.method != "closed-form";
        g.cells_unconverged = r.cells_unconverged;
        out.push_back(std::move(g));
    }
    return out;
}

}  // namespace brdftab
