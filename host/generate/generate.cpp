// generate.cpp — a spec's computed tables: kernel points of each cell
// (CellPoints) and one engine run per [[tables]] entry, with the provenance
// the file stores; then the derived tables (derived.cpp).
#include "host/generate/generate.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <optional>

#include "host/core/error.h"
#include "host/core/text.h"
#include "host/generate/checkpoint.h"
#include "host/generate/chunked.h"
#include "host/generate/derived.h"

#ifndef BRDFTAB_VERSION
#define BRDFTAB_VERSION "unknown"
#endif

namespace brdftab {

namespace {
constexpr double kRadPerDeg = 3.14159265358979323846 / 180.0;
// Where the light comes from when the incident direction says so: "inside"
// when every theta_i > 90 (mu_i < 0), "outside" when every theta_i <= 90;
// null when the table spans both or has no incident direction.
const char* incident_side(const TableSpec& ts) {
    double lo = 0, hi = 0;  // as mu_i
    if (ts.fixed.count("theta_i")) lo = hi = std::cos(ts.fixed.at("theta_i") * kRadPerDeg);
    if (ts.fixed.count("mu_i")) lo = hi = ts.fixed.at("mu_i");
    bool found = ts.fixed.count("theta_i") || ts.fixed.count("mu_i");
    for (const Axis& a : ts.axes)
        if (a.name == "theta_i" || a.name == "mu_i") {
            const bool mu = a.name == "mu_i";
            lo = mu ? a.min : std::cos(a.max * kRadPerDeg);
            hi = mu ? a.max : std::cos(a.min * kRadPerDeg);
            found = true;
        }
    if (!found) return nullptr;
    if (hi < 0) return "inside";
    if (lo >= -1e-12) return "outside";
    return nullptr;
}
}  // namespace

namespace {
constexpr double kDegToRad = 3.14159265358979323846 / 180.0;
}

CellPoints::CellPoints(const ModelInfo& model, const QuantityInfo& quantity,
                       const TableSpec& table)
    : grid_(table.axes), base_(model.point_stride()) {
    // Validate everything once through the general builder, at the first node.
    std::map<std::string, double> values = table.fixed;
    const std::vector<double> first = grid_.coordinates(0);
    for (std::size_t a = 0; a < table.axes.size(); ++a) values[table.axes[a].name] = first[a];
    PointBuilder(model, quantity).build(values, base_.data());

    const std::string phi_d = to_string(Coordinate::PhiD);
    phi_o_from_phi_d_ = values.count(phi_d) != 0;
    if (phi_o_from_phi_d_ && table.fixed.count(phi_d))
        fixed_phi_d_ = table.fixed.at(phi_d) * kDegToRad;
    for (const Axis& a : table.axes) {
        if (const CoordinateInfo* c = find_coordinate(a.name)) {
            const std::size_t slot = static_cast<std::size_t>(c->slot);
            switch (c->encoding) {
                case CoordinateEncoding::Degrees: feeds_.push_back({Feed::Degrees, slot}); break;
                case CoordinateEncoding::Cosine: feeds_.push_back({Feed::Cosine, slot}); break;
                case CoordinateEncoding::AzimuthOffset:
                    feeds_.push_back({Feed::AzimuthOffset, slot});
                    break;
            }
            continue;
        }
        const ParameterInfo* p = model.find_parameter(a.name);
        if (!p) throw InputError("axis '" + a.name + "' is not a coordinate or parameter of '" +
                                 model.name + "'");
        const std::size_t slot = kDirectionSlots + static_cast<std::size_t>(p - model.parameters.data());
        feeds_.push_back({p->in_degrees ? Feed::Degrees : Feed::Plain, slot});
    }
}

inline void CellPoints::feed(std::size_t a, double v, double* out, double& phi_d) const {
    switch (feeds_[a].feed) {
        case Feed::Degrees: out[feeds_[a].slot] = v * kDegToRad; break;
        case Feed::Cosine: out[feeds_[a].slot] = std::acos(v); break;
        case Feed::AzimuthOffset: phi_d = v * kDegToRad; break;
        case Feed::Plain: out[feeds_[a].slot] = v; break;
    }
}

void CellPoints::points(std::size_t first, std::size_t count, double* out) const {
    const std::size_t stride = base_.size();
    const std::vector<Axis>& axes = grid_.axes();
    bool independent = !axes.empty() && axes.size() == feeds_.size() &&
                       first <= grid_.cell_count() && count <= grid_.cell_count() - first;
    for (std::size_t a = 0; independent && a < axes.size(); ++a)
        independent = grid_.dependency(a) < 0;
    if (!independent) {
        for (std::size_t k = 0; k < count; ++k) point(first + k, out + k * stride);
        return;
    }
    // The multi-index of `first` (row-major, last axis fastest), then one
    // step per cell; each point gets the values point() gives it, fed in the
    // same order.
    std::vector<std::size_t> index(axes.size());
    std::size_t rest = first;
    for (std::size_t a = axes.size(); a-- > 0;) {
        index[a] = rest % axes[a].count;
        rest /= axes[a].count;
    }
    for (std::size_t k = 0; k < count; ++k) {
        double* const p = out + k * stride;
        std::copy(base_.begin(), base_.end(), p);
        double phi_d = fixed_phi_d_;
        for (std::size_t a = axes.size(); a-- > 0;) feed(a, axes[a].values[index[a]], p, phi_d);
        if (phi_o_from_phi_d_) p[3] = p[1] + phi_d;
        for (std::size_t a = axes.size(); a-- > 0;) {
            if (++index[a] < axes[a].count) break;
            index[a] = 0;
        }
    }
}

void CellPoints::point(std::size_t cell, double* out) const {
    std::copy(base_.begin(), base_.end(), out);
    double phi_d = fixed_phi_d_;
    auto feed = [&](std::size_t a, double v) { this->feed(a, v, out, phi_d); };
    // Without dependent axes a cell's axis values are the nodes at its
    // multi-index, as Grid::coordinates gives them, found here without the
    // two vectors that call allocates: this runs once or twice per cell and
    // is the largest host cost of a closed-form table when it allocates.
    const std::vector<Axis>& axes = grid_.axes();
    bool independent = cell < grid_.cell_count() && axes.size() == feeds_.size();
    for (std::size_t a = 0; independent && a < axes.size(); ++a)
        independent = grid_.dependency(a) < 0;
    if (independent) {
        std::size_t rest = cell;
        for (std::size_t a = axes.size(); a-- > 0;) {  // row-major, last axis fastest
            feed(a, axes[a].values[rest % axes[a].count]);
            rest /= axes[a].count;
        }
        if (phi_o_from_phi_d_) out[3] = out[1] + phi_d;
        return;
    }
    // The grid places an axis whose nodes depend on another (critical) too.
    const std::vector<double> coords = grid_.coordinates(cell);
    for (std::size_t a = 0; a < feeds_.size(); ++a) feed(a, coords[a]);
    // Same rule as PointBuilder: phi_o = phi_i + phi_d when phi_d is given.
    if (phi_o_from_phi_d_) out[3] = out[1] + phi_d;
}

namespace {

// Bytes per cell, measured (docs/spec.md, "Memory and disk"): the engine's
// state of the chunk being computed (CellState, the round's work lists and
// the result vectors).
constexpr double kEngineBytesPerCell = 100;
// A chunk's results (value, stderr: 8 B each, samples: 4 B) as the engine
// returns them, and a table kept whole for a derived table (the same).
constexpr double kResultBytesPerCell = 8 + 8 + 4;
// A derived table: value and stderr, and the copy its computation makes.
constexpr double kDerivedBytesPerCell = 2 * (8 + 8);
// HDF5's chunk cache: up to 1 MiB for each of the (at most 3) datasets of
// every computed table, all open while the tables are computed.
constexpr double kCacheBytesPerTable = 3.0 * 1024 * 1024;
// One device launch (host/engine/launch/): per work item its point
// (point_stride doubles), cell and batch numbers and two results, held three
// times: the launch, its copy with the chunk's cell numbers (chunked.cpp) and
// the device's buffers (host memory on a CPU device).  The OpenCL backend's
// preferred launch is 2^17 work items.
constexpr double kLaunchCopies = 3;
constexpr double kLaunchWorkItems = 131072;
// Fixed overhead: the program, libhdf5, the OpenCL runtime and its compiled
// kernels (measured: 97 MiB resident for a 4-cell run on PoCL; rounded up).
constexpr double kBaseBytes = 128.0 * 1024 * 1024;
// The checkpoint beside the output (host/generate/checkpoint.cpp, kCellBytes):
// 65 B per cell of every computed table's state on disk until the output is
// written, and a buffer of that size for the chunk being saved.  Counted for
// every table (an upper bound: quick closed forms are not stored).
constexpr double kCheckpointBytesPerCell = 65;

double stored_size(StoredType t) {
    switch (t) {
        case StoredType::Float64: return 8;
        case StoredType::Float32: return 4;
        case StoredType::Float16: return 2;
    }
    return 8;
}

double grid_cells(const std::vector<Axis>& axes) {
    double n = 1;
    for (const Axis& a : axes) n *= static_cast<double>(a.count);
    return n;
}

}  // namespace

ResourceEstimate estimate_resources(const Spec& spec, const IntegrationSettings& settings,
                                    std::size_t chunk_cells) {
    const ModelInfo& model = find_model(spec.model);
    const double type_size = stored_size(spec.output.stored_type);
    const std::vector<std::string> kept = tables_read_by_derived(spec);
    ResourceEstimate r;
    double held = 0, largest_chunk = 0;
    std::map<std::string, double> cells_of;  // computed table name -> cells
    auto add_disk = [&](double cells, bool has_stderr, bool has_samples) {
        r.cells += cells;
        r.disk_bytes += cells * (type_size * (has_stderr && spec.output.keep_stderr ? 2 : 1) +
                                 (has_samples ? 4 : 0));
    };
    for (const TableSpec& ts : spec.tables) {
        const double cells = grid_cells(ts.axes);
        cells_of[ts.name] = cells;
        const Method m = resolve_table_method(model.quantity(ts.quantity), settings.method);
        const bool closed = m == Method::ClosedForm;
        add_disk(cells, !closed, !closed);
        r.disk_bytes += cells * kCheckpointBytesPerCell;
        r.largest_cells = std::max(r.largest_cells, cells);
        const double chunk = chunk_cells ? static_cast<double>(chunk_cells)
                                         : static_cast<double>(kDefaultChunkCells);
        largest_chunk = std::max(largest_chunk, std::min(cells, chunk));
        held += kCacheBytesPerTable;
        if (std::find(kept.begin(), kept.end(), ts.name) != kept.end())
            held += cells * kResultBytesPerCell;
    }
    // Derived tables live on their sources' grids (inverted: its new axis).
    auto add_derived = [&](double cells) {
        add_disk(cells, true, false);
        held += cells * kDerivedBytesPerCell;
    };
    for (const RecombinedSpec& rs : spec.recombined)
        add_derived(rs.terms.empty() ? 0 : cells_of[rs.terms.front().first]);
    for (const ErrorTableSpec& es : spec.errors) add_derived(cells_of[es.table]);
    for (const InvertedSpec& is : spec.inverted) add_derived(static_cast<double>(is.axis.count));
    const double launch_items = settings.slab_work_items
                                    ? static_cast<double>(settings.slab_work_items)
                                    : kLaunchWorkItems;
    const double launch_bytes =
        kLaunchCopies * launch_items * (8.0 * static_cast<double>(model.point_stride()) + 4 + 4 + 16);
    r.memory_bytes = kBaseBytes + held + launch_bytes +
                     largest_chunk * (kEngineBytesPerCell + kResultBytesPerCell + type_size +
                                      kCheckpointBytesPerCell);
    return r;
}

void fold_value_range(const double* value, std::size_t n, bool& first, double& lo, double& hi) {
    if (n == 0) return;
    if (first) {
        lo = hi = value[0];
        first = false;
    }
    for (std::size_t k = 0; k < n; ++k) lo = std::min(lo, value[k]), hi = std::max(hi, value[k]);
}

void fold_stderr_max(const double* value, const double* stderr_, std::size_t n, double& max_abs,
                     double& max_rel) {
    for (std::size_t k = 0; k < n; ++k) {
        const double se = std::fabs(stderr_[k]);
        if (!(se == se)) continue;
        max_abs = std::max(max_abs, se);
        if (value[k] != 0 && value[k] == value[k]) max_rel = std::max(max_rel, se / std::fabs(value[k]));
    }
}

void set_value_range(GeneratedTable& g) {
    bool first = true;
    g.value_min = g.value_max = 0;
    fold_value_range(g.data.value.data(), g.data.value.size(), first, g.value_min, g.value_max);
    if (g.data.stderr_.size() == g.data.value.size())
        fold_stderr_max(g.data.value.data(), g.data.stderr_.data(), g.data.value.size(),
                        g.stderr_max_abs, g.stderr_max_rel);
}

namespace generate_detail {

TableData describe_table(const Spec& spec, const Backend& backend,
                         const IntegrationSettings& settings, std::size_t table,
                         const std::vector<int>& options, Method method) {
    const ModelInfo& model = find_model(spec.model);
    const TableSpec& ts = spec.tables.at(table);
    const QuantityInfo& q = model.quantity(ts.quantity);
    TableData d;
    d.name = ts.name;
    d.model = model.name;
    d.quantity = q.name;
    d.units = q.units;
    d.description = ts.description.empty() ? q.description : ts.description;
    nlohmann::json params = nlohmann::json::object();
    for (const auto& [k, v] : ts.fixed) params[k] = v;
    // Record every option actually used (defaults included), by name;
    // options the quantity ignores are left out (a "side" default would
    // misstate a table of light from inside).
    for (std::size_t k = 0; k < model.options.size(); ++k)
        if (std::count(q.uses_options.begin(), q.uses_options.end(), model.options[k].name))
            params[model.options[k].name] = model.options[k].choices[options[k]];
    // A model with a "side" option: state the side the table's light comes from.
    if (model.find_option("side") && !params.contains("side") && incident_side(ts))
        params["side"] = incident_side(ts);
    d.parameters = params;
    d.axes = ts.axes;
    const bool closed_form = method == Method::ClosedForm;
    d.method = method;
    d.samples_requested = closed_form || method == Method::Quadrature
                              ? 1
                              : (settings.tolerance > 0 ? settings.max_samples
                                                        : (settings.samples ? settings.samples : kDefaultSamplesPerCell));
    d.tolerance_requested = closed_form ? 0 : settings.tolerance;
    d.abs_floor = settings.abs_floor;
    d.seed = settings.seed;
    d.precision = precision_name(backend.precision());
    d.device = backend.device_name();
    d.version = BRDFTAB_VERSION;
    // The spec's name without the machine's directories, and its text.
    d.spec_file = std::filesystem::path(spec.file).filename().string();
    d.spec_text = spec.text;
    d.stored_type = spec.output.stored_type;
    d.compression = spec.output.compression;
    d.keep_stderr = spec.output.keep_stderr && !closed_form;
    d.round_accuracy = ts.round_accuracy > 0 ? ts.round_accuracy : spec.output.round_accuracy;
    d.round_absolute = spec.output.round_absolute;
    return d;
}

}  // namespace generate_detail

std::vector<GeneratedTable> generate_tables(const Spec& spec, Backend& backend,
                                            const IntegrationSettings& settings,
                                            const GenerateProgressFn& progress,
                                            Checkpoint* checkpoint) {
    const ModelInfo& model = find_model(spec.model);
    std::vector<GeneratedTable> out;
    for (std::size_t t = 0; t < spec.tables.size(); ++t) {
        const TableSpec& ts = spec.tables[t];
        const QuantityInfo& q = model.quantity(ts.quantity);
        const std::vector<int> options =
            resolve_options(model, ts.options, spec.file + ": table '" + ts.name + "'");
        std::optional<CellPoints> built;
        try {
            built.emplace(model, q, ts);
        } catch (const InputError& e) {
            throw InputError(spec.file + ": table '" + ts.name + "': " + e.what());
        }
        const CellPoints& points = *built;
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
        IntegrationSettings table_settings = settings;
        table_settings.method = resolve_table_method(q, settings.method);
        EstimateCheckpoint stored;
        if (checkpoint) stored = checkpoint->table(t, ts.name, points.cell_count());
        EstimateResult r = estimate(
            backend, model, q, options, points.cell_count(),
            [&](std::size_t first, std::size_t count, double* p) { points.points(first, count, p); },
            table_settings, cb,
            checkpoint ? &stored : nullptr);

        GeneratedTable g;
        TableData& d = g.data;
        d = generate_detail::describe_table(spec, backend, settings, t, options, r.method);
        d.value = std::move(r.value);
        d.stderr_ = std::move(r.stderr_);
        if (r.method != Method::ClosedForm) d.samples = std::move(r.samples);
        d.tolerance_achieved = r.tolerance_achieved;
        d.elapsed_seconds = r.elapsed_seconds;
        d.total_samples = r.total_samples;
        g.cells_unconverged = r.cells_unconverged;
        out.push_back(std::move(g));
    }
    for (const RecombinedSpec& rs : spec.recombined)
        out.push_back(generate_detail::recombine(rs, out, spec));
    for (const ErrorTableSpec& es : spec.errors)
        out.push_back(generate_detail::compare(es, out, spec));
    for (const InvertedSpec& is : spec.inverted)
        out.push_back(generate_detail::invert(is, out, spec));
    for (GeneratedTable& g : out) set_value_range(g);
    return out;
}

}  // namespace brdftab
