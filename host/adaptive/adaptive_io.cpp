// adaptive_io.cpp — HDF5 layout of adaptive tables (docs/format.md,
// "Adaptive tables"), through the schema pieces tensor tables use
// (host/io/table_io_detail.h).
#include "host/adaptive/adaptive_io.h"

#include <hdf5.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include <nlohmann/json.hpp>

#include "host/core/error.h"
#include "host/io/hdf5_attributes.h"
#include "host/io/hdf5_handles.h"
#include "host/io/table_io_detail.h"

namespace brdftab {

using namespace hdf5;
namespace detail = table_io_detail;

namespace {

void check_adaptive(const AdaptiveTable& t, const std::string& where) {
    if (t.layout.dims != t.data.axes.size())
        throw InputError(where + "the layout has " + std::to_string(t.layout.dims) + " axes, the table " +
                         std::to_string(t.data.axes.size()));
    t.layout.check(t.data.value.size(), where);
    if (!t.data.stderr_.empty() && t.data.stderr_.size() != t.data.value.size())
        throw InputError(where + "stderr and value differ in length");
}

nlohmann::json breakpoints_json(const AdaptiveTable& t) {
    nlohmann::json all = nlohmann::json::array();
    for (std::size_t a = 0; a < t.data.axes.size(); ++a) {
        nlohmann::json list = nlohmann::json::array();
        if (a < t.breakpoints_t.size())
            for (std::size_t k = 0; k < t.breakpoints_t[a].size(); ++k)
                list.push_back({{"t", t.breakpoints_t[a][k]},
                                {"jump", a < t.breakpoint_jump.size() && k < t.breakpoint_jump[a].size() &&
                                             t.breakpoint_jump[a][k]}});
        all.push_back(list);
    }
    return all;
}

}  // namespace

void add_adaptive_table(TableFileWriter& out, const AdaptiveTable& t) {
    const std::string where = "table '" + t.data.name + "': ";
    check_adaptive(t, where);
    const hid_t file = static_cast<hid_t>(out.hdf5_file());
    detail::create_table_group(file, t.data);
    Handle group(H5Gopen2(file, t.data.name.c_str(), H5P_DEFAULT), H5Gclose, "H5Gopen2", t.data.name);
    const AdaptiveLayout& L = t.layout;
    const bool with_stderr = t.data.keep_stderr && !t.data.stderr_.empty();
    // The stored nodes only: a reader computes the hanging ones from them
    // (AdaptiveLayout::resolve_hanging), so they follow the rounded values.
    const std::size_t stored = L.stored_count(t.data.value.size());
    const std::vector<double> value(t.data.value.begin(), t.data.value.begin() + std::ptrdiff_t(stored));
    detail::write_real_dataset(group, "value", value, t.data, false);
    if (with_stderr) {
        const std::vector<double> se(t.data.stderr_.begin(), t.data.stderr_.begin() + std::ptrdiff_t(stored));
        detail::write_real_dataset(group, "stderr", se, t.data, true);
    }
    const std::uint64_t tn = L.split_axis.size(), leaves = L.leaf_count();
    const int c = t.data.compression;
    detail::write_plain_dataset(group, "tree_axis", H5T_STD_I32LE, H5T_NATIVE_INT32, {tn}, L.split_axis.data(), c);
    detail::write_plain_dataset(group, "tree_split", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {tn}, L.split_t.data(), c);
    std::vector<std::uint32_t> child(2 * tn);
    for (std::size_t k = 0; k < tn; ++k) {
        child[2 * k] = L.lower[k];
        child[2 * k + 1] = L.upper[k];
    }
    detail::write_plain_dataset(group, "tree_child", H5T_STD_U32LE, H5T_NATIVE_UINT32, {tn, 2}, child.data(), c);
    detail::write_plain_dataset(group, "leaf_box", H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, {leaves, L.dims, 2},
                                L.box.data(), c);
    detail::write_plain_dataset(group, "leaf_nodes", H5T_STD_U32LE, H5T_NATIVE_UINT32,
                                {leaves, L.nodes_per_leaf()}, L.leaf_nodes.data(), c);
    if (!L.hanging_leaf.empty())
        detail::write_plain_dataset(group, "hanging_leaf", H5T_STD_U32LE, H5T_NATIVE_UINT32,
                                    {L.hanging_leaf.size()}, L.hanging_leaf.data(), c);
    double max_abs = 0;
    for (double v : value)
        if (std::isfinite(v)) max_abs = std::max(max_abs, std::fabs(v));
    detail::write_description(group, t.data, max_abs, with_stderr);
    write_string_attr(group, "representation", "adaptive");
    write_i32_attr(group, "patch_nodes", static_cast<std::int32_t>(L.patch_nodes));
    write_i32_attr(group, "patch_order", static_cast<std::int32_t>(L.patch_order));
    write_string_attr(group, "breakpoints", breakpoints_json(t).dump());
    write_double_attr(group, "adaptive_target", t.target);
    write_string_attr(group, "adaptive_measure", t.absolute ? "absolute" : "relative");
    write_double_attr(group, "adaptive_estimated_max", t.estimated_max);
}

void write_table_file(const std::string& path, const std::vector<TableData>& tensors,
                      const std::vector<AdaptiveTable>& adaptive) {
    TableFileWriter out(path);
    for (const TableData& t : tensors) out.add_table(t);
    for (const AdaptiveTable& t : adaptive) add_adaptive_table(out, t);
    out.commit();
}

bool is_adaptive_table(const TableReader& reader, const std::string& name) {
    const std::vector<std::string> names = reader.table_names();
    if (std::find(names.begin(), names.end(), name) == names.end()) {
        std::string avail;
        for (const std::string& g : names) avail += (avail.empty() ? "" : ", ") + g;
        throw InputError("'" + reader.path() + "' has no table '" + name + "' (available: " +
                         (avail.empty() ? "none" : avail) + ")");
    }
    try {
        return detail::representation(reader.hdf5_file(), name) == "adaptive";
    } catch (const InputError&) {
        throw;
    } catch (const Error& e) {
        throw InputError("'" + reader.path() + "', table '" + name + "': " + e.what());
    }
}

bool is_adaptive_table(const std::string& path, const std::string& name) {
    return is_adaptive_table(TableReader(path), name);
}

AdaptiveTable read_adaptive_table(const TableReader& reader, const std::string& name) {
    const std::string where = "'" + reader.path() + "', table '" + name + "': ";
    if (!is_adaptive_table(reader, name)) throw InputError(where + "is not an adaptive table");
    const hid_t file = static_cast<hid_t>(reader.hdf5_file());
    try {
        AdaptiveTable t;
        t.data = detail::read_description(file, reader.path(), name);
        Handle group(H5Gopen2(file, name.c_str(), H5P_DEFAULT), H5Gclose, "H5Gopen2", name);
        AdaptiveLayout& L = t.layout;
        L.dims = t.data.axes.size();
        const std::uint64_t pn = read_u64_attr(group, "patch_nodes");
        if (pn > 9) throw InputError(where + "patch_nodes " + std::to_string(pn) + "; allowed: 2, 3, 5, 9");
        L.patch_nodes = static_cast<std::size_t>(pn);
        if (has_attr(group, "patch_order")) {
            const std::uint64_t po = read_u64_attr(group, "patch_order");
            if (po != 1 && po != 2) throw InputError(where + "patch_order " + std::to_string(po) + "; allowed: 1, 2");
            L.patch_order = static_cast<int>(po);
        }
        auto shape = [&](const char* ds, std::vector<std::uint64_t> want) {
            if (!detail::has_dataset(group, ds)) throw InputError(where + "dataset '" + ds + "' is missing");
            const std::vector<std::uint64_t> got = detail::dataset_shape(group, ds);
            for (std::size_t i = 0; i < want.size(); ++i)
                if (want[i] == 0 && i < got.size()) want[i] = got[i];  // 0: take the file's
            if (got != want) throw InputError(where + "dataset '" + std::string(ds) + "' has the wrong shape");
            return got;
        };
        const std::uint64_t stored = shape("value", {0})[0];
        t.data.value = detail::read_reals(group, "value", stored, &t.data.stored_type, &t.data.compression);
        if (has_attr(group, "stored_type")) t.data.stored_type = parse_stored_type(read_string_attr(group, "stored_type"));
        t.data.keep_stderr = detail::has_dataset(group, "stderr");
        if (t.data.keep_stderr) {
            shape("stderr", {stored});
            t.data.stderr_ = detail::read_reals(group, "stderr", stored);
        }
        // The hanging nodes: values stored + 0 .. stored + H - 1.
        std::uint64_t hanging = 0;
        if (detail::has_dataset(group, "hanging_leaf")) {
            hanging = shape("hanging_leaf", {0})[0];
            if (hanging > (std::uint64_t{1} << 32) - stored)
                throw InputError(where + "hanging_leaf is too long");
            L.hanging_leaf.resize(hanging);
            if (hanging) detail::read_native(group, "hanging_leaf", H5T_NATIVE_UINT32, L.hanging_leaf.data());
        }
        const std::uint64_t n = stored + hanging;
        t.data.value.resize(n, std::numeric_limits<double>::quiet_NaN());
        if (t.data.keep_stderr) t.data.stderr_.resize(n, std::numeric_limits<double>::quiet_NaN());
        const std::uint64_t tn = shape("tree_axis", {0})[0];
        if (tn == 0 || tn > (std::uint64_t{1} << 32)) throw InputError(where + "tree_axis is empty or too long");
        shape("tree_split", {tn});
        shape("tree_child", {tn, 2});
        const std::uint64_t leaves = shape("leaf_box", {0, L.dims, 2})[0];
        shape("leaf_nodes", {leaves, L.nodes_per_leaf()});
        L.split_axis.resize(tn);
        L.split_t.resize(tn);
        std::vector<std::uint32_t> child(2 * tn);
        detail::read_native(group, "tree_axis", H5T_NATIVE_INT32, L.split_axis.data());
        detail::read_native(group, "tree_split", H5T_NATIVE_DOUBLE, L.split_t.data());
        detail::read_native(group, "tree_child", H5T_NATIVE_UINT32, child.data());
        L.lower.resize(tn);
        L.upper.resize(tn);
        for (std::size_t k = 0; k < tn; ++k) {
            L.lower[k] = child[2 * k];
            L.upper[k] = child[2 * k + 1];
        }
        L.box.resize(leaves * L.dims * 2);
        L.leaf_nodes.resize(leaves * L.nodes_per_leaf());
        detail::read_native(group, "leaf_box", H5T_NATIVE_DOUBLE, L.box.data());
        detail::read_native(group, "leaf_nodes", H5T_NATIVE_UINT32, L.leaf_nodes.data());
        L.check(n, where);
        L.resolve_hanging(t.data.value.data(), n, where);
        if (t.data.keep_stderr) L.resolve_hanging(t.data.stderr_.data(), n, where);
        if (has_attr(group, "adaptive_target")) t.target = read_double_attr(group, "adaptive_target");
        if (has_attr(group, "adaptive_measure")) t.absolute = read_string_attr(group, "adaptive_measure") == "absolute";
        if (has_attr(group, "adaptive_estimated_max"))
            t.estimated_max = read_double_attr(group, "adaptive_estimated_max");
        if (has_attr(group, "breakpoints")) {
            const nlohmann::json b = nlohmann::json::parse(read_string_attr(group, "breakpoints"), nullptr, false);
            if (b.is_array())
                for (const auto& list : b) {
                    t.breakpoints_t.emplace_back();
                    t.breakpoint_jump.emplace_back();
                    if (!list.is_array()) continue;
                    for (const auto& p : list)
                        if (p.is_object() && p.contains("t") && p["t"].is_number()) {
                            t.breakpoints_t.back().push_back(p["t"].get<double>());
                            t.breakpoint_jump.back().push_back(p.value("jump", false));
                        }
                }
        }
        for (const Axis& a : t.data.axes)
            if (a.dependent() && std::none_of(t.data.axes.begin(), t.data.axes.end(),
                                              [&](const Axis& b) { return b.name == a.depends_on; }))
                throw InputError(where + "axis '" + a.name + "' depends on a missing axis");
        return t;
    } catch (const InputError&) {
        throw;
    } catch (const std::bad_alloc&) {
        throw InputError(where + "does not fit in memory");
    } catch (const Error& e) {
        throw InputError(where + e.what());
    }
}

AdaptiveTable read_adaptive_table(const std::string& path, const std::string& name) {
    return read_adaptive_table(TableReader(path), name);
}

}  // namespace brdftab
