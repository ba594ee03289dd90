// lookup.cpp — building a LookupTable: reading the head table and the tables
// its recombination names, checking axes and sizes, the angular layout used
// by direction-level lookup, and the completion of reciprocal half tables.
// Interpolation is in interpolate.cpp, recombination in recombine.cpp,
// direction-level evaluation in directions.cpp, sampling in sample.cpp.
#include "host/lookup/lookup.h"

#include <algorithm>
#include <cmath>

#include "host/core/error.h"
#include "host/adaptive/adaptive_io.h"
#include "host/io/table_io.h"
#include "host/lookup/lookup_internal.h"

namespace brdftab {

using namespace lookup_internal;

namespace {

void check_table(TableData& t) {
    const std::string where = "table '" + t.name + "'";
    if (t.axes.empty()) throw InputError(where + ": has no axes");
    for (auto& a : t.axes) {
        if (a.count < 2)
            throw InputError(where + ": axis '" + a.name + "' needs at least 2 nodes");
        if (a.values.empty()) {
            for (std::size_t k = 0; k < a.count; ++k)
                a.values.push_back(a.dependent() ? double(k) / double(a.count - 1)
                                                 : a.warp(double(k) / double(a.count - 1)));
        }
        if (a.values.size() != a.count)
            throw InputError(where + ": axis '" + a.name + "' has " +
                             std::to_string(a.values.size()) + " values for count " +
                             std::to_string(a.count));
        for (std::size_t k = 1; k < a.count; ++k)
            if (!(a.values[k] > a.values[k - 1]))
                throw InputError(where + ": axis '" + a.name + "' nodes must increase");
        // A dependent axis (critical, eta from another axis) holds its nodes'
        // t_k, which must be k/(count-1): its positions come from the warp.
        if (a.dependent()) {
            for (std::size_t k = 0; k < a.count; ++k)
                if (!(std::fabs(a.values[k] - double(k) / double(a.count - 1)) <= 1e-12))
                    throw InputError(where + ": axis '" + a.name + "' depends on '" +
                                     a.depends_on + "' and must hold t_k = k/(count-1)");
            continue;
        }
        // Interpolation warps between min and max; they must be the end nodes.
        const double tol = 1e-9 * (a.values.back() - a.values.front());
        if (!(std::fabs(a.min - a.values.front()) <= tol) ||
            !(std::fabs(a.max - a.values.back()) <= tol))
            throw InputError(where + ": axis '" + a.name + "' has min/max [" + fmt_num(a.min) +
                             ", " + fmt_num(a.max) + "] but nodes from " +
                             fmt_num(a.values.front()) + " to " + fmt_num(a.values.back()));
    }
    const std::size_t cells = checked_cell_count(t.axes, where + ": ");
    if (t.value.size() != cells)
        throw InputError(where + ": value has " + std::to_string(t.value.size()) +
                         " entries, axes need " + std::to_string(cells));
}

bool same_axes(const std::vector<Axis>& a, const std::vector<Axis>& b) {
    if (a.size() != b.size()) return false;
    for (std::size_t d = 0; d < a.size(); ++d) {
        if (a[d].name != b[d].name || a[d].count != b[d].count) return false;
        // Dependent axes: the same t_k place nodes alike only with the same warp.
        if (a[d].dependent() != b[d].dependent()) return false;
        if (a[d].dependent() &&
            (a[d].depends_on != b[d].depends_on || a[d].critical_node != b[d].critical_node ||
             a[d].grading != b[d].grading || a[d].min != b[d].min || a[d].max != b[d].max))
            return false;
        for (std::size_t k = 0; k < a[d].count; ++k) {
            const double scale = std::max(1.0, std::fabs(a[d].values[k]));
            if (std::fabs(a[d].values[k] - b[d].values[k]) > 1e-12 * scale) return false;
        }
    }
    return true;
}

// Radians per axis unit for angular axes.
double angle_scale(const Axis& a, const std::string& table) {
    if (a.unit == "deg" || a.unit == "degree" || a.unit == "degrees") return kDeg;
    if (a.unit == "rad") return 1.0;
    throw InputError("table '" + table + "': angular axis '" + a.name + "' has unit '" +
                     a.unit + "' (expected 'deg' or 'rad')");
}

}  // namespace

// ---------------------------------------------------------------------------
// LookupTable

LookupTable::LookupTable(TableData table) {
    pieces_.push_back(std::move(table));
    init();
}

LookupTable LookupTable::from_tables(const std::vector<TableData>& tables,
                                     const std::string& name) {
    auto find = [&](const std::string& n) -> const TableData* {
        for (const auto& t : tables)
            if (t.name == n) return &t;
        return nullptr;
    };
    const TableData* head = find(name);
    if (!head) throw InputError("table '" + name + "' is not among the given tables");
    LookupTable lt;
    lt.pieces_.push_back(*head);
    for (const auto& n : recombine_tables(*head)) {
        if (n == name) continue;
        bool have = false;
        for (const auto& p : lt.pieces_) have = have || p.name == n;
        if (have) continue;
        const TableData* t = find(n);
        if (!t)
            throw InputError("table '" + name + "': parameters.recombine names table '" + n +
                             "', which is missing");
        lt.pieces_.push_back(*t);
    }
    lt.init();
    return lt;
}

LookupTable LookupTable::open(const std::string& path, const std::string& table) {
    // One open file for the head table and the tables its recipe names.
    const TableReader reader(path);
    if (is_adaptive_table(reader, table)) {
        AdaptiveTable at = read_adaptive_table(reader, table);
        try {
            return LookupTable(std::move(at));
        } catch (const InputError& e) {
            throw InputError(path + ": " + e.what());
        }
    }
    std::vector<TableData> tables;
    tables.push_back(reader.read(table));
    for (const auto& n : recombine_tables(tables.front())) {
        bool have = false;
        for (const auto& t : tables) have = have || t.name == n;
        if (!have) tables.push_back(reader.read(n));
    }
    try {
        return from_tables(tables, table);
    } catch (const InputError& e) {
        throw InputError(path + ": " + e.what());
    }
}

void LookupTable::init() {
    TableData& head = pieces_.front();
    for (auto& p : pieces_) check_table(p);
    for (std::size_t k = 1; k < pieces_.size(); ++k)
        if (!same_axes(head.axes, pieces_[k].axes))
            throw InputError("table '" + head.name + "': recombine term table '" +
                             pieces_[k].name + "' has different axes");
    init_axes();
    const std::size_t dims = head.axes.size();
    strides_.assign(dims, 1);
    for (std::size_t d = dims - 1; d-- > 0;) strides_[d] = strides_[d + 1] * head.axes[d + 1].count;

    // Recombination.
    init_recombination();

    init_angles();
    const AngleLayout& L = layout_;

    // Reciprocal half tables: complete the unstored half from f(i,o) = f(o,i).
    if (head.parameters.is_object() && head.parameters.contains("reciprocal_half")) {
        const auto& rh = head.parameters["reciprocal_half"];
        if (!rh.is_boolean())
            throw InputError("table '" + head.name + "': parameters.reciprocal_half must be a boolean");
        if (rh.get<bool>()) {
            if (!directional_) throw InputError(directional_error_ + " (reciprocal_half)");
            const Axis& ai = head.axes[L.axis_i];
            const Axis& ao = head.axes[L.axis_o];
            bool same = L.mu_i == L.mu_o && ai.count == ao.count && L.scale_i == L.scale_o;
            for (std::size_t k = 0; same && k < ai.count; ++k)
                same = std::fabs(ai.values[k] - ao.values[k]) <=
                       1e-12 * std::max(1.0, std::fabs(ai.values[k]));
            if (!same)
                throw InputError("table '" + head.name +
                                 "': reciprocal_half needs identical incident and "
                                 "outgoing axes");
            const std::size_t si = strides_[L.axis_i], so = strides_[L.axis_o];
            const std::size_t n = ai.count;
            for (auto& p : pieces_) {
                for (std::size_t flat = 0; flat < p.value.size(); ++flat) {
                    const std::size_t ii = (flat / si) % n, io = (flat / so) % n;
                    // Stored half: theta_i <= theta_o, i.e. index_i <= index_o on
                    // theta axes and index_i >= index_o on mu axes.
                    const bool stored = L.mu_i ? ii >= io : ii <= io;
                    if (stored) continue;
                    const std::size_t mirror = flat - ii * si - io * so + io * si + ii * so;
                    p.value[flat] = p.value[mirror];
                    if (p.stderr_.size() == p.value.size()) p.stderr_[flat] = p.stderr_[mirror];
                }
            }
        }
    }
    choose_linear_kernel();
}

// Per axis: the axis its nodes depend on, the prepared FastAxis.
void LookupTable::init_axes() {
    const TableData& head = pieces_.front();
    const std::size_t dims = head.axes.size();
    dependency_.assign(dims, -1);
    for (std::size_t d = 0; d < dims; ++d) {
        if (!head.axes[d].dependent()) continue;
        for (std::size_t e = 0; e < dims; ++e)
            if (head.axes[e].name == head.axes[d].depends_on && !head.axes[e].dependent())
                dependency_[d] = int(e);
        if (dependency_[d] < 0)
            throw InputError("table '" + head.name + "': axis '" + head.axes[d].name +
                             "' depends on '" + head.axes[d].depends_on +
                             "', which is not an axis of the table");
    }
    fast_.resize(dims);
    has_dependent_ = false;
    for (std::size_t d = 0; d < dims; ++d) {
        fast_[d].build(head.axes[d]);
        has_dependent_ = has_dependent_ || head.axes[d].dependent();
    }
}

// The angular layout of direction-level lookups (the head table's axes).
void LookupTable::init_angles() {
    const TableData& head = pieces_.front();
    const std::size_t dims = head.axes.size();
    AngleLayout L;
    for (std::size_t d = 0; d < dims; ++d) {
        const std::string& n = head.axes[d].name;
        if (n == "theta_i" || n == "mu_i") {
            L.axis_i = int(d);
            L.mu_i = n == "mu_i";
        } else if (n == "theta_o" || n == "mu_o") {
            L.axis_o = int(d);
            L.mu_o = n == "mu_o";
        } else if (n == "phi_d") {
            L.axis_phi = int(d);
        }
    }
    directional_ = L.axis_i >= 0 && L.axis_o >= 0;
    for (const auto& a : head.axes)
        if (a.name == "phi_i" || a.name == "phi_o") directional_ = false;
    bool has_dependent = false;
    for (const auto& a : head.axes) has_dependent = has_dependent || a.dependent();
    if (directional_ && has_dependent) {
        directional_ = false;
        directional_error_ = "table '" + head.name +
                             "': direction-level lookup does not support axes whose nodes "
                             "depend on another axis (critical spacing); use eval";
    } else if (!directional_) {
        directional_error_ = "table '" + head.name +
                             "': direction-level lookup needs axes theta_i|mu_i, "
                             "theta_o|mu_o and optionally phi_d (isotropic tables only)";
    } else {
        const Axis& ai = head.axes[L.axis_i];
        const Axis& ao = head.axes[L.axis_o];
        if (!L.mu_i) L.scale_i = angle_scale(ai, head.name);
        if (!L.mu_o) L.scale_o = angle_scale(ao, head.name);
        if (L.axis_phi >= 0) {
            const Axis& ap = head.axes[L.axis_phi];
            L.scale_phi = angle_scale(ap, head.name);
            L.fold_phi = ap.min * L.scale_phi >= -1e-12 && ap.max * L.scale_phi <= kPi + 1e-12;
        } else {
            L.scale_phi = kDeg;
        }
    }
    L.per_rad_i = 1 / L.scale_i;
    L.per_rad_o = 1 / L.scale_o;
    L.per_rad_phi = 1 / L.scale_phi;
    layout_ = L;
}

TableData without_recombination(const TableData& table) {
    TableData d = table;
    if (d.parameters.is_object()) d.parameters.erase("recombine");
    return d;
}

std::unique_ptr<LookupTable> stderr_lookup(const LookupTable& lt) {
    const TableData& t = lt.table();
    if (const AdaptiveTable* at = lt.adaptive()) {
        if (at->data.stderr_.size() != at->data.value.size()) return nullptr;
        AdaptiveTable e = *at;
        e.data.value = at->data.stderr_;
        e.data.stderr_.clear();
        return std::make_unique<LookupTable>(std::move(e));
    }
    if (lt.has_recombination() || t.stderr_.size() != t.value.size()) return nullptr;
    TableData d = without_recombination(t);
    d.value = t.stderr_;
    d.stderr_.clear();
    return std::make_unique<LookupTable>(std::move(d));
}

std::vector<std::string> LookupTable::coordinate_names() const {
    std::vector<std::string> names;
    for (const auto& a : axes()) names.push_back(a.name);
    if (!terms_.empty()) names.push_back(rparam_);
    return names;
}

}  // namespace brdftab
