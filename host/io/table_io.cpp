// table_io.cpp — the brdftab HDF5 table file schema (layout: docs/format.md):
// one group per table with `value`, optional `stderr` and `samples` datasets,
// axis datasets attached as dimension scales, provenance as attributes, and
// the file-level format version.  Writing goes through a temporary file that
// replaces the target only when complete.  The HDF5 plumbing (handles, error
// stack, attributes) is in hdf5_handles.h and hdf5_attributes.h, the
// binary16 rounding in half_float.h.
#include "host/io/table_io.h"
#include "host/io/table_io_detail.h"

#include "host/core/atomic_file.h"

#include <hdf5.h>
#include <hdf5_hl.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <type_traits>
#include <ctime>
#include <fcntl.h>
#include <filesystem>
#include <memory>
#include <new>
#include <set>
#include <stdexcept>
#include <unistd.h>

#include "host/core/error.h"
#include "host/io/bit_rounding.h"
#include "host/io/half_float.h"
#include "host/io/hdf5_attributes.h"
#include "host/io/hdf5_handles.h"

#ifndef BRDFTAB_VERSION
#define BRDFTAB_VERSION "unknown"
#endif

namespace brdftab {
namespace {

using namespace hdf5;

constexpr int kFormatVersion = 1;
// Upper bound of one chunk.  HDF5's default chunk cache is 1 MiB per dataset,
// so a chunk of at most that size is cached whole when a reader revisits it.
constexpr std::size_t kMaxChunkBytes = 1u << 20;

// ---------------------------------------------------------------- writing ---

std::string utc_now_iso8601() {
    std::time_t t = std::time(nullptr);
    std::tm tm{};
    gmtime_r(&t, &tm);
    char buf[32];
    std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
    return buf;
}

// The name becomes an HDF5 link name: no '/', not empty, not "." .
void check_link_name(const std::string& name, const std::string& what) {
    if (name.empty() || name == "." || name.find('/') != std::string::npos ||
        name.find('\0') != std::string::npos)
        throw InputError(what + " name '" + name +
                         "' cannot be an HDF5 name (must be non-empty, without '/')");
}

// `with_data`: also check the sizes of value, stderr and samples (the
// streaming writer checks each range of cells as it comes instead).
void validate_table(const TableData& t, bool with_data = true) {
    check_link_name(t.name, "table");
    const std::string where = "table '" + t.name + "': ";
    std::set<std::string> seen;
    for (const Axis& a : t.axes) {
        check_link_name(a.name, where + "axis");
        if (a.name == "value" || a.name == "stderr" || a.name == "samples")
            throw InputError(where + "axis name '" + a.name +
                             "' is reserved (value, stderr, samples are dataset names)");
        if (!seen.insert(a.name).second)
            throw InputError(where + "axis '" + a.name + "' appears twice");
        // The reader refuses axes of fewer than 2 nodes (make_axis never
        // makes them); refuse to write what could not be read back.
        if (a.count < 2)
            throw Error(where + "axis '" + a.name + "' has " + std::to_string(a.count) +
                        " node(s); an axis needs at least 2");
        if (a.values.size() != a.count)
            throw Error(where + "axis '" + a.name + "' has count " + std::to_string(a.count) +
                        " but " + std::to_string(a.values.size()) + " node values");
    }
    const std::size_t n = checked_cell_count(t.axes, where);
    if (with_data && t.value.size() != n)
        throw Error(where + "value has " + std::to_string(t.value.size()) +
                    " entries, the axes need " + std::to_string(n));
    if (with_data && !t.stderr_.empty() && t.stderr_.size() != n)
        throw Error(where + "stderr has " + std::to_string(t.stderr_.size()) +
                    " entries, the axes need " + std::to_string(n));
    if (with_data && !t.samples.empty() && t.samples.size() != n)
        throw Error(where + "samples has " + std::to_string(t.samples.size()) +
                    " entries, the axes need " + std::to_string(n));
    if (t.compression < 0 || t.compression > 9)
        throw InputError(where + "compression level " + std::to_string(t.compression) +
                         " outside 0..9");
}

// Largest row-major block of at most kMaxChunkBytes: trailing axes are kept
// whole as long as they fit (a 2-D slice over the last two axes is then one
// chunk), leading axes are grouped so small tables do not end up in many
// tiny chunks.
std::vector<hsize_t> chunk_shape(const std::vector<hsize_t>& dims, std::size_t elem) {
    std::vector<hsize_t> chunk = dims;
    const std::size_t limit = std::max<std::size_t>(1, kMaxChunkBytes / elem);
    for (std::size_t i = 0; i < chunk.size(); ++i) {
        std::size_t inner = 1;
        for (std::size_t j = i + 1; j < chunk.size(); ++j) inner *= chunk[j];
        if (chunk[i] * inner <= limit) break;
        chunk[i] = std::max<std::size_t>(1, limit / inner);
        if (chunk[i] * inner <= limit) break;
    }
    return chunk;
}

Handle create_dataset(hid_t group, const char* name, hid_t file_type,
                      const std::vector<hsize_t>& dims, int compression) {
    Handle space = dims.empty()
                       ? scalar_space()
                       : Handle(H5Screate_simple(static_cast<int>(dims.size()), dims.data(),
                                                 nullptr),
                                H5Sclose, "H5Screate_simple", name);
    Handle dcpl = make_plist(H5P_DATASET_CREATE, name);
    if (!dims.empty()) {  // a scalar dataspace cannot be chunked
        std::vector<hsize_t> chunk = chunk_shape(dims, H5Tget_size(file_type));
        check(H5Pset_chunk(dcpl, static_cast<int>(chunk.size()), chunk.data()),
              "H5Pset_chunk", name);
        if (compression > 0) {
            // Shuffle groups the bytes of equal significance, which is what
            // makes smooth floating-point tables compress at all.
            check(H5Pset_shuffle(dcpl), "H5Pset_shuffle", name);
            check(H5Pset_deflate(dcpl, static_cast<unsigned>(compression)), "H5Pset_deflate",
                  name);
        }
        // Last in the pipeline, so the checksum covers the bytes as stored:
        // HDF5 verifies it on every read of a chunk and fails the read on a
        // mismatch, so a flipped bit is an error, not a wrong value.
        check(H5Pset_fletcher32(dcpl), "H5Pset_fletcher32", name);
    }
    return Handle(H5Dcreate2(group, name, file_type, space, H5P_DEFAULT, dcpl, H5P_DEFAULT),
                  H5Dclose, "H5Dcreate2", name);
}

// The parameters of the spacings that need more than min/max/count
// (docs/format.md, "Axis datasets"): log-complement's pivot; critical's
// node, grading and eta (a fixed value, or the name of the axis it runs on).
void write_spacing_parameters(hid_t ds, const Axis& a) {
    if (a.spacing == Spacing::LogComplement) write_double_attr(ds, "pivot", a.pivot);
    if (a.spacing != Spacing::Critical) return;
    write_u64_attr(ds, "critical_node", a.critical_node);
    write_double_attr(ds, "grading", a.grading);
    if (a.dependent())
        write_string_attr(ds, "depends_on", a.depends_on);
    else
        write_double_attr(ds, "critical_eta", a.critical_eta);
}

// Axis a's node list as a dataset of `group`, with its attributes, marked as
// a dimension scale.
Handle write_axis_dataset(hid_t group, const Axis& a) {
    const hsize_t n = a.count;
    // Chunked (one chunk up to 1 MiB) so that the node list carries a
    // checksum too; not compressed, as before.
    Handle ds = create_dataset(group, a.name.c_str(), H5T_IEEE_F64LE, {n}, 0);
    check(H5Dwrite(ds, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, a.values.data()),
          "H5Dwrite", a.name);
    write_string_attr(ds, "unit", a.unit);
    write_string_attr(ds, "spacing", spacing_name(a.spacing));
    write_double_attr(ds, "min", a.min);
    write_double_attr(ds, "max", a.max);
    write_spacing_parameters(ds, a);
    check(H5DSset_scale(ds, a.name.c_str()), "H5DSset_scale", a.name);
    return ds;
}

// The HDF5 objects of one table being written: its group, the axis datasets
// (dimension scales) and the data datasets (value, then stderr and samples
// when present).  Shared by the whole-table writer (write_table) and the
// streaming one (TableFileWriter), so both lay out a table the same way.
struct TableObjects {
    Handle group;
    std::vector<Handle> axis_ds;
    std::vector<hsize_t> dims;
    Handle value, stderr_, samples;  // stderr_, samples: invalid when absent
};

// The group, the axis datasets (written) and empty data datasets of `t`.
TableObjects create_table_objects(hid_t file, const TableData& t, bool with_stderr,
                                  bool with_samples) {
    htri_t exists = H5Lexists(file, t.name.c_str(), H5P_DEFAULT);
    check(exists, "H5Lexists", t.name);
    if (exists > 0) throw InputError("table name '" + t.name + "' used twice in one file");

    TableObjects o;
    o.group = Handle(H5Gcreate2(file, t.name.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
                     H5Gclose, "H5Gcreate2", t.name);
    hid_t group = o.group;

    // Axis datasets first: they become the dimension scales.
    for (const Axis& a : t.axes) {
        o.axis_ds.push_back(write_axis_dataset(group, a));
        o.dims.push_back(a.count);
    }
    Handle half;
    auto real_type = [&]() -> hid_t {
        switch (t.stored_type) {
        case StoredType::Float64: return H5T_IEEE_F64LE;
        case StoredType::Float32: return H5T_IEEE_F32LE;
        case StoredType::Float16: if (half.get() < 0) half = half_type(); return half;
        }
        throw Error("unknown stored type");
    };
    o.value = create_dataset(group, "value", real_type(), o.dims, t.compression);
    if (with_stderr)
        o.stderr_ = create_dataset(group, "stderr", real_type(), o.dims, t.compression);
    if (with_samples)
        o.samples = create_dataset(group, "samples", H5T_STD_U32LE, o.dims, t.compression);
    return o;
}

// Row-major cells [first, first + count) of an array of shape `dims` as
// boxes (offset, extent) in increasing cell order: a partial row, whole rows
// of the leading axis, a partial row, each split further along the next axis
// (at most 2 x rank - 1 boxes).
void cell_range_boxes(const std::vector<hsize_t>& dims, std::size_t axis,
                      std::vector<hsize_t>& prefix, hsize_t first, hsize_t count,
                      std::vector<std::pair<std::vector<hsize_t>, std::vector<hsize_t>>>& out) {
    if (count == 0) return;
    hsize_t inner = 1;
    for (std::size_t j = axis + 1; j < dims.size(); ++j) inner *= dims[j];
    auto whole = [&](hsize_t row, hsize_t rows) {
        std::vector<hsize_t> offset = prefix, extent(prefix.size(), 1);
        offset.push_back(row);
        extent.push_back(rows);
        for (std::size_t j = axis + 1; j < dims.size(); ++j) {
            offset.push_back(0);
            extent.push_back(dims[j]);
        }
        out.emplace_back(std::move(offset), std::move(extent));
    };
    auto partial = [&](hsize_t row, hsize_t from, hsize_t n) {
        prefix.push_back(row);
        cell_range_boxes(dims, axis + 1, prefix, from, n, out);
        prefix.pop_back();
    };
    hsize_t row = first / inner, offset = first % inner;
    if (offset != 0) {  // the end of a first, partial row
        const hsize_t n = std::min(count, inner - offset);
        partial(row, offset, n);
        first += n;
        count -= n;
        ++row;
    }
    if (count >= inner) {
        whole(row, count / inner);
        row += count / inner;
        first += (count / inner) * inner;
        count %= inner;
    }
    if (count > 0) partial(row, 0, count);  // the start of a last, partial row
}

// Writes `count` elements of `data` (memory type `mem_type`) to cells
// [first, first + count) of dataset `ds`.
void write_cell_range(hid_t ds, const char* name, hid_t mem_type, const void* data,
                      std::size_t elem_size, const std::vector<hsize_t>& dims, hsize_t first,
                      hsize_t count) {
    if (dims.empty()) {  // a scalar (a table without axes): its one cell
        if (first != 0 || count != 1) throw Error(std::string(name) + ": a scalar has one cell");
        check(H5Dwrite(ds, mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data), "H5Dwrite", name);
        return;
    }
    std::vector<std::pair<std::vector<hsize_t>, std::vector<hsize_t>>> boxes;
    std::vector<hsize_t> prefix;
    cell_range_boxes(dims, 0, prefix, first, count, boxes);
    Handle file_space(H5Dget_space(ds), H5Sclose, "H5Dget_space", name);
    const char* bytes = static_cast<const char*>(data);
    for (const auto& [offset, extent] : boxes) {
        hsize_t n = 1;
        for (hsize_t e : extent) n *= e;
        check(H5Sselect_hyperslab(file_space, H5S_SELECT_SET, offset.data(), nullptr,
                                  extent.data(), nullptr),
              "H5Sselect_hyperslab", name);
        Handle mem_space(H5Screate_simple(1, &n, nullptr), H5Sclose, "H5Screate_simple", name);
        check(H5Dwrite(ds, mem_type, mem_space, file_space, H5P_DEFAULT, bytes), "H5Dwrite",
              name);
        bytes += n * elem_size;
    }
}

// Real values of cells [first, first + count) in the table's stored type,
// rounded by our own casts (round to nearest) rather than HDF5's conversion
// path, so a stored float is exactly (float)x and a stored half half_bits(x);
// for binary16 the memory type is the file type: HDF5 copies the bits.  An
// active `rule` (bit_rounding.h) rounds to fewer mantissa bits first.
void write_real_cells(hid_t ds, const char* name, const double* data, StoredType type,
                      const std::vector<hsize_t>& dims, hsize_t first, hsize_t count,
                      const RoundingRule& rule = {}) {
    if (rule.active()) {
        // Every rounded value is exactly representable in `type`, so the
        // plain conversion below does not round it again.
        std::vector<double> r(count);
        std::transform(data, data + count, r.begin(), [&](double v) { return round_value(v, rule); });
        write_real_cells(ds, name, r.data(), type, dims, first, count);
        return;
    }
    switch (type) {
    case StoredType::Float64:
        write_cell_range(ds, name, H5T_NATIVE_DOUBLE, data, 8, dims, first, count);
        return;
    case StoredType::Float32: {
        std::vector<float> f(data, data + count);
        write_cell_range(ds, name, H5T_NATIVE_FLOAT, f.data(), 4, dims, first, count);
        return;
    }
    case StoredType::Float16: {
        std::vector<std::uint16_t> h(count);
        std::transform(data, data + count, h.begin(), half_bits);
        Handle ht = half_type();
        write_cell_range(ds, name, ht, h.data(), 2, dims, first, count);
        return;
    }
    }
    throw Error("unknown stored type");
}

void attach_scales(const TableObjects& o, const TableData& t) {
    for (const Handle* ds : {&o.value, &o.stderr_, &o.samples}) {
        if (ds->get() < 0) continue;
        for (std::size_t i = 0; i < t.axes.size(); ++i) {
            check(H5DSattach_scale(*ds, o.axis_ds[i], static_cast<unsigned>(i)),
                  "H5DSattach_scale", t.axes[i].name);
            check(H5DSset_label(*ds, static_cast<unsigned>(i), t.axes[i].name.c_str()),
                  "H5DSset_label", t.axes[i].name);
        }
    }
}

void write_table_attributes(hid_t group, const TableData& t) {
    nlohmann::json axis_names = nlohmann::json::array();
    for (const Axis& a : t.axes) axis_names.push_back(a.name);
    write_string_attr(group, "model", t.model);
    write_string_attr(group, "quantity", t.quantity);
    write_string_attr(group, "description", t.description);
    write_string_attr(group, "units", t.units);
    write_string_attr(group, "parameters", t.parameters.dump());
    write_string_attr(group, "axes", axis_names.dump());
    write_string_attr(group, "method", method_attribute(t));
    write_u64_attr(group, "samples_requested", t.samples_requested);
    write_double_attr(group, "tolerance_requested", t.tolerance_requested);
    write_double_attr(group, "abs_floor", t.abs_floor);
    write_double_attr(group, "tolerance_achieved", t.tolerance_achieved);
    write_u64_attr(group, "seed", t.seed);
    write_string_attr(group, "precision", t.precision);
    write_string_attr(group, "device", t.device);
    write_string_attr(group, "brdftab_version", t.version.empty() ? BRDFTAB_VERSION : t.version);
    write_string_attr(group, "spec_file", t.spec_file);
    if (!t.spec_text.empty()) write_string_attr(group, "spec", t.spec_text);
    write_double_attr(group, "elapsed_seconds", t.elapsed_seconds);
    write_u64_attr(group, "total_samples", t.total_samples);
    write_string_attr(group, "stored_type", stored_type_name(t.stored_type));
}

// Rounded storage (bit_rounding.h; docs/format.md "Rounded storage"): the
// measure and accuracy the values were rounded for, the mantissa bits kept
// (absolute: by the largest |value|, `max_abs`), the per-value bound, and the
// bits kept in stderr.  Nothing for a table stored with its type's rounding.
void write_rounding_attributes(hid_t group, const TableData& t, double max_abs, bool with_stderr) {
    if (!(t.round_accuracy > 0)) return;
    const RoundingRule rule = value_rounding(t);
    const int p = mantissa_bits(t.stored_type);
    write_string_attr(group, "rounding", t.round_absolute ? "absolute" : "relative");
    write_double_attr(group, "rounding_accuracy", t.round_accuracy);
    write_i32_attr(group, "keep_bits", rule.active() ? absolute_keep_bits(max_abs, rule) : p);
    write_double_attr(group, "rounding_bound",
                      rule.active() ? rule.bound : t.round_absolute ? 0.0 : std::ldexp(1.0, -(p + 1)));
    if (with_stderr) {
        const RoundingRule s = stderr_rounding(t);
        write_i32_attr(group, "stderr_keep_bits", s.active() ? s.keep_bits : p);
    }
}

// Largest finite |v| of n values (0 when none).
double max_finite_abs(const double* v, std::size_t n) {
    double m = 0;
    for (std::size_t i = 0; i < n; ++i)
        if (std::isfinite(v[i])) m = std::max(m, std::fabs(v[i]));
    return m;
}


void write_table(hid_t file, const TableData& t) {
    const bool with_stderr = t.keep_stderr && !t.stderr_.empty();
    TableObjects o = create_table_objects(file, t, with_stderr, !t.samples.empty());
    const hsize_t n = t.value.size();
    write_real_cells(o.value, "value", t.value.data(), t.stored_type, o.dims, 0, n,
                     value_rounding(t));
    if (with_stderr)
        write_real_cells(o.stderr_, "stderr", t.stderr_.data(), t.stored_type, o.dims, 0, n,
                         stderr_rounding(t));
    if (!t.samples.empty())
        write_cell_range(o.samples, "samples", H5T_NATIVE_UINT32, t.samples.data(), 4, o.dims,
                         0, n);
    attach_scales(o, t);
    write_table_attributes(o.group, t);
    write_rounding_attributes(o.group, t, max_finite_abs(t.value.data(), t.value.size()), with_stderr);
}

// ---------------------------------------------------------------- reading ---
//
// Every file read here may come from elsewhere and may be damaged or hostile:
// each attribute is checked for type and size (hdf5_attributes.cpp), each
// dataset's shape against the axes before anything is allocated, the cell
// count for overflow, and every failure becomes an InputError naming the file
// and the object.  What this cannot catch is libhdf5 itself looping or
// crashing on damaged metadata (docs/format.md, "Reading untrusted files").

Handle open_brdftab_file(const std::string& path) {
    silence_hdf5();
    std::error_code ec;
    if (!std::filesystem::exists(path, ec))
        throw InputError("table file '" + path + "' does not exist");
    if (std::filesystem::is_directory(path, ec))
        throw InputError("table file '" + path + "' is a directory");
    // A FIFO or a device would block or stream forever inside HDF5's probe.
    if (!std::filesystem::is_regular_file(path, ec))
        throw InputError("table file '" + path + "' is not a regular file");
    htri_t is_h5 = H5Fis_hdf5(path.c_str());
    H5Eclear2(H5E_DEFAULT);
    if (is_h5 <= 0)
        throw InputError("'" + path + "' is not an HDF5 file (or cannot be read)");
    hid_t id = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    if (id < 0) {
        H5Eclear2(H5E_DEFAULT);
        throw InputError("cannot open HDF5 file '" + path + "'");
    }
    Handle file(id, H5Fclose, "H5Fopen", path);
    if (!has_attr(file, "brdftab_format"))
        throw InputError("'" + path +
                         "' is an HDF5 file but not a brdftab table file (no brdftab_format "
                         "attribute)");
    std::uint64_t fmt = read_u64_attr(file, "brdftab_format");
    if (fmt != static_cast<std::uint64_t>(kFormatVersion))
        throw InputError("'" + path + "' has brdftab_format " + std::to_string(fmt) +
                         "; this build reads format " + std::to_string(kFormatVersion));
    return file;
}

// Run `body`; an HDF5 failure (Error) or an allocation failure while reading
// file `path` is bad input (exit code 2), reported with `where` (the file and
// the object) in front of HDF5's own message.  An InputError that does not
// name the file yet (e.g. an unknown stored_type spelling) gets `where` too.
template <class F>
auto as_input_error(const std::string& path, const std::string& where, F&& body)
    -> decltype(body()) {
    try {
        return body();
    } catch (const InputError& e) {
        if (std::string(e.what()).find("'" + path + "'") != std::string::npos) throw;
        throw InputError(where + e.what());
    } catch (const Error& e) {
        throw InputError(where + "damaged file or not written by brdftab (" + e.what() + ")");
    } catch (const std::bad_alloc&) {
        throw InputError(where + "too large to read into memory");
    } catch (const std::length_error&) {
        throw InputError(where + "too large to read into memory");
    }
}

// Refuse to read `count` elements of `bytes` each when they cannot fit in
// this machine's physical memory: a few bytes of header can declare an
// enormous (sparse) dataset, and filling the buffer would exhaust memory.
void check_fits_in_memory(std::size_t count, std::size_t bytes, const std::string& where) {
    const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGE_SIZE);
    if (pages <= 0 || page <= 0) return;
    const double have = double(pages) * double(page), need = double(count) * double(bytes);
    if (need > have) {
        char buf[160];
        std::snprintf(buf, sizeof buf,
                      "%zu cells need %.3g GiB to read, more than this machine's %.3g GiB of "
                      "memory",
                      count, need / double(1u << 30), have / double(1u << 30));
        throw InputError(where + buf);
    }
}

// Axis checks on read, the rules make_axis applies when a table is made: at
// least 2 nodes, finite and strictly increasing.  Lookups interpolate over
// the node list (and warp between its end nodes), so the `min`/`max`
// attributes must agree with the end nodes; a mismatch means the file was
// edited and is refused rather than silently shifting every lookup.
void check_read_axis(Axis& a, const std::string& where) {
    const std::string what = where + "axis '" + a.name + "': ";
    if (a.count < 2)
        throw InputError(what + "has " + std::to_string(a.count) +
                         " node(s); an axis needs at least 2");
    for (std::size_t k = 0; k < a.count; ++k) {
        if (!std::isfinite(a.values[k]))
            throw InputError(what + "node #" + std::to_string(k) + " is not finite");
        if (k > 0 && !(a.values[k] > a.values[k - 1]))
            throw InputError(what + "nodes must be strictly increasing (node #" +
                             std::to_string(k) + " is not above node #" +
                             std::to_string(k - 1) + ")");
    }
    const double first = a.values.front(), last = a.values.back();
    const double tol = 1e-9 * (last - first);
    if (!(std::fabs(a.min - first) <= tol) || !(std::fabs(a.max - last) <= tol)) {
        char buf[200];
        std::snprintf(buf, sizeof buf,
                      "attributes min/max = [%.17g, %.17g] disagree with the node list, which "
                      "runs from %.17g to %.17g",
                      a.min, a.max, first, last);
        throw InputError(what + buf);
    }
    a.min = first;
    a.max = last;
}

// log-complement and critical axes: the attributes their warp needs are
// required, the axis is rebuilt from them, and the stored node list must be
// the rebuilt one (positions, or t_k for an axis whose nodes depend on
// another), so an edited file is refused rather than looked up wrongly.
void read_spacing_parameters(hid_t ds, Axis& a, const std::string& where) {
    const std::string what = where + "axis '" + a.name + "': ";
    auto need = [&](const char* key) {
        if (!has_attr(ds, key))
            throw InputError(what + "spacing '" + spacing_name(a.spacing) +
                             "' needs the attribute '" + key + "', which is missing");
    };
    need("min");
    need("max");
    Axis built;
    try {
        const double lo = read_double_attr(ds, "min"), hi = read_double_attr(ds, "max");
        if (a.spacing == Spacing::LogComplement) {
            need("pivot");
            built = make_log_complement_axis(a.name, a.unit, lo, hi, a.count,
                                             read_double_attr(ds, "pivot"));
        } else {
            need("critical_node");
            need("grading");
            const std::uint64_t node = read_u64_attr(ds, "critical_node");
            const double grading = read_double_attr(ds, "grading");
            if (has_attr(ds, "depends_on")) {
                built = make_critical_axis(a.name, lo, hi, a.count, std::size_t(node), grading,
                                           0.0, read_string_attr(ds, "depends_on"));
                if (built.depends_on.empty() || built.depends_on == a.name)
                    throw InputError("attribute 'depends_on' must name another axis");
            } else {
                need("critical_eta");
                built = make_critical_axis(a.name, lo, hi, a.count, std::size_t(node), grading,
                                           read_double_attr(ds, "critical_eta"));
            }
        }
    } catch (const InputError& e) {
        throw InputError(what + e.what());
    }
    for (std::size_t k = 0; k < a.count; ++k) {
        const double tol = 1e-9 * std::max(1.0, std::fabs(built.values[k]));
        if (!(std::fabs(a.values[k] - built.values[k]) <= tol))
            throw InputError(what + "node #" + std::to_string(k) + " (" +
                             std::to_string(a.values[k]) + ") disagrees with its spacing '" +
                             spacing_name(a.spacing) + "' (" + std::to_string(built.values[k]) +
                             ")");
    }
    built.unit = a.unit;
    built.values = a.values;
    a = std::move(built);
}

// An axis whose nodes depend on another must find it among the table's axes,
// and its nodes must increase at each of that axis' nodes.
void check_dependent_axes(const std::vector<Axis>& axes, const std::string& where) {
    for (const Axis& a : axes) {
        if (!a.dependent()) continue;
        const Axis* dep = nullptr;
        for (const Axis& b : axes)
            if (b.name == a.depends_on && !b.dependent()) dep = &b;
        if (!dep)
            throw InputError(where + "axis '" + a.name + "' depends on '" + a.depends_on +
                             "', which is not an axis of the table");
        try {
            check_dependent_nodes(a, dep->values);
        } catch (const InputError& e) {
            throw InputError(where + e.what());
        }
    }
}

herr_t collect_link(hid_t, const char* name, const H5L_info_t*, void* data) noexcept {
    try {
        static_cast<std::vector<std::string>*>(data)->emplace_back(name);
        return 0;
    } catch (...) {
        return -1;
    }
}

std::vector<std::string> group_names(hid_t file) {
    std::vector<std::string> links, groups;
    hsize_t idx = 0;
    check(H5Literate(file, H5_INDEX_NAME, H5_ITER_INC, &idx, collect_link, &links),
          "H5Literate");
    for (const std::string& l : links) {
        Handle obj(H5Oopen(file, l.c_str(), H5P_DEFAULT), H5Oclose, "H5Oopen", l);
        if (H5Iget_type(obj) == H5I_GROUP) groups.push_back(l);
    }
    return groups;
}

std::vector<hsize_t> dataset_dims(hid_t ds, const std::string& name) {
    Handle space(H5Dget_space(ds), H5Sclose, "H5Dget_space", name);
    int rank = H5Sget_simple_extent_ndims(space);
    if (rank < 0) fail("H5Sget_simple_extent_ndims", name);
    std::vector<hsize_t> dims(static_cast<std::size_t>(rank));
    if (rank > 0) check(H5Sget_simple_extent_dims(space, dims.data(), nullptr),
                        "H5Sget_simple_extent_dims", name);
    return dims;
}

// Any real dataset into doubles.  Widening float64/float32 is exact through
// HDF5; 2-byte floats are read as raw bits and widened by Imath.
std::vector<double> read_real(hid_t ds, const std::string& name, std::size_t n) {
    Handle ftype(H5Dget_type(ds), H5Tclose, "H5Dget_type", name);
    std::vector<double> out(n);
    if (H5Tget_class(ftype) == H5T_FLOAT && H5Tget_size(ftype) == 2) {
        std::vector<std::uint16_t> bits(n);
        Handle ht = half_type();
        check(H5Dread(ds, ht, H5S_ALL, H5S_ALL, H5P_DEFAULT, bits.data()), "H5Dread", name);
        std::transform(bits.begin(), bits.end(), out.begin(), half_to_double);
    } else {
        check(H5Dread(ds, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()),
              "H5Dread", name);
    }
    return out;
}

StoredType stored_type_of(hid_t ds, const std::string& name) {
    Handle ftype(H5Dget_type(ds), H5Tclose, "H5Dget_type", name);
    switch (H5Tget_size(ftype)) {
    case 2: return StoredType::Float16;
    case 4: return StoredType::Float32;
    default: return StoredType::Float64;
    }
}

int deflate_level(hid_t ds, const std::string& name) {
    Handle dcpl(H5Dget_create_plist(ds), H5Pclose, "H5Dget_create_plist", name);
    int n = H5Pget_nfilters(dcpl);
    for (int i = 0; i < n; ++i) {
        unsigned flags = 0, cd[4] = {0, 0, 0, 0};
        std::size_t ncd = 4;
        char fname[64];
        H5Z_filter_t f = H5Pget_filter2(dcpl, static_cast<unsigned>(i), &flags, &ncd, cd,
                                        sizeof fname, fname, nullptr);
        if (f == H5Z_FILTER_DEFLATE) return ncd > 0 ? static_cast<int>(cd[0]) : 6;
    }
    return 0;
}

bool has_link(hid_t loc, const std::string& name) {
    htri_t r = H5Lexists(loc, name.c_str(), H5P_DEFAULT);
    check(r, "H5Lexists", name);
    return r > 0;
}

}  // namespace

// ------------------------------------------------------------------ public --

void write_tables(const std::string& path, const std::vector<TableData>& tables) {
    // The streaming writer writes the same objects in the same order, and
    // discards its temporary file without a write to the disk on failure.
    TableFileWriter out(path);
    // Checked table by table; an error on a later table still only ever
    // touches the temporary file.
    for (const TableData& t : tables) out.add_table(t);
    out.commit();
}

namespace {

// The description of one table of an open file (its attributes and axes,
// no data); throws InputError (callers wrap HDF5 failures).
TableData read_description(hid_t file, const std::string& path, const std::string& name) {
    if (name.empty() || name.find('/') != std::string::npos || !has_link(file, name) ||
        [&] {
            Handle o(H5Oopen(file, name.c_str(), H5P_DEFAULT), H5Oclose, "H5Oopen", name);
            return H5Iget_type(o) != H5I_GROUP;
        }()) {
        std::string avail;
        for (const std::string& g : group_names(file)) avail += (avail.empty() ? "" : ", ") + g;
        throw InputError("'" + path + "' has no table '" + name + "' (available: " +
                         (avail.empty() ? "none" : avail) + ")");
    }
    Handle group(H5Gopen2(file, name.c_str(), H5P_DEFAULT), H5Gclose, "H5Gopen2", name);
    const std::string where = "'" + path + "', table '" + name + "': ";

    TableData t;
    t.name = name;
    auto str = [&](const char* key) {
        return has_attr(group, key) ? read_string_attr(group, key) : std::string();
    };
    auto dbl = [&](const char* key) { return has_attr(group, key) ? read_double_attr(group, key) : 0.0; };
    auto u64 = [&](const char* key) {
        return has_attr(group, key) ? read_u64_attr(group, key) : std::uint64_t{0};
    };
    t.model = str("model");
    t.quantity = str("quantity");
    t.description = str("description");
    t.units = str("units");
    try {
        set_method_attribute(t, str("method"));
    } catch (const InputError& e) {
        throw InputError(where + e.what());
    }
    t.precision = str("precision");
    t.device = str("device");
    t.version = str("brdftab_version");
    t.spec_file = str("spec_file");
    t.spec_text = str("spec");  // absent in files before it was stored
    t.samples_requested = u64("samples_requested");
    t.tolerance_requested = dbl("tolerance_requested");
    t.abs_floor = dbl("abs_floor");
    t.tolerance_achieved = dbl("tolerance_achieved");
    t.seed = u64("seed");
    t.elapsed_seconds = dbl("elapsed_seconds");
    t.total_samples = u64("total_samples");
    try {
        std::string p = str("parameters");
        t.parameters = p.empty() ? nlohmann::json::object() : nlohmann::json::parse(p);
    } catch (const nlohmann::json::exception& e) {
        throw InputError(where + "attribute 'parameters' is not JSON: " + e.what());
    }

    nlohmann::json axes;
    try {
        if (!has_attr(group, "axes")) throw InputError(where + "missing attribute 'axes'");
        axes = nlohmann::json::parse(read_string_attr(group, "axes"));
    } catch (const nlohmann::json::exception& e) {
        throw InputError(where + "attribute 'axes' is not JSON: " + e.what());
    }
    if (!axes.is_array()) throw InputError(where + "attribute 'axes' is not a JSON array");
    for (const auto& an : axes) {
        if (!an.is_string()) throw InputError(where + "attribute 'axes' holds a non-string");
        const std::string aname = an.get<std::string>();
        if (!has_link(group, aname))
            throw InputError(where + "axis dataset '" + aname + "' is missing");
        Handle ds(H5Dopen2(group, aname.c_str(), H5P_DEFAULT), H5Dclose, "H5Dopen2", aname);
        std::vector<hsize_t> d = dataset_dims(ds, aname);
        if (d.size() != 1) throw InputError(where + "axis dataset '" + aname + "' is not 1-D");
        Axis a;
        a.name = aname;
        a.count = d[0];
        if (a.count < 2)  // before reading: a 0-node axis has no end nodes
            throw InputError(where + "axis '" + aname + "' has " + std::to_string(a.count) +
                             " node(s); an axis needs at least 2");
        check_fits_in_memory(a.count, sizeof(double), where + "axis '" + aname + "': ");
        a.values = read_real(ds, aname, a.count);
        a.unit = has_attr(ds, "unit") ? read_string_attr(ds, "unit") : std::string();
        a.spacing = Spacing::Explicit;  // the node list alone still defines the axis
        if (has_attr(ds, "spacing")) {
            try {
                a.spacing = parse_spacing(read_string_attr(ds, "spacing"));
            } catch (const InputError& e) {
                throw InputError(where + "axis '" + aname + "': " + e.what());
            }
        }
        if (a.spacing == Spacing::LogComplement || a.spacing == Spacing::Critical) {
            read_spacing_parameters(ds, a, where);
        } else {
            a.min = has_attr(ds, "min") ? read_double_attr(ds, "min") : a.values.front();
            a.max = has_attr(ds, "max") ? read_double_attr(ds, "max") : a.values.back();
            check_read_axis(a, where);
        }
        t.axes.push_back(std::move(a));
    }
    check_dependent_axes(t.axes, where);
    if (has_attr(group, "rounding")) {
        const std::string r = str("rounding");
        if (r != "relative" && r != "absolute")
            throw InputError(where + "attribute 'rounding' is '" + r + "'; allowed: relative, absolute");
        t.round_absolute = r == "absolute";
        t.round_accuracy = dbl("rounding_accuracy");
        if (!(t.round_accuracy > 0) || !std::isfinite(t.round_accuracy))
            throw InputError(where + "attribute 'rounding_accuracy' must be a positive number");
    }
    return t;
}

// The representation attribute of table group `name` ("tensor" when absent).
std::string representation_of(hid_t file, const std::string& name) {
    Handle group(H5Gopen2(file, name.c_str(), H5P_DEFAULT), H5Gclose, "H5Gopen2", name);
    return has_attr(group, "representation") ? read_string_attr(group, "representation") : "tensor";
}

// One tensor table of an open file; throws InputError (callers wrap HDF5
// failures).  An adaptive table (docs/format.md "Adaptive tables") is
// refused here: every reader of tensor tables goes through this function,
// so one that does not know the other representation never misreads it.
TableData read_group(hid_t file, const std::string& path, const std::string& name) {
    TableData t = read_description(file, path, name);
    const std::string where = "'" + path + "', table '" + name + "': ";
    if (const std::string r = representation_of(file, name); r != "tensor")
        throw InputError(where + "is an " + r + " table (docs/adaptive.md): this command reads tensor "
                         "tables only (docs/adaptive.md lists the commands that read " + r + " tables)");
    Handle group(H5Gopen2(file, name.c_str(), H5P_DEFAULT), H5Gclose, "H5Gopen2", name);
    auto str = [&](const char* key) {
        return has_attr(group, key) ? read_string_attr(group, key) : std::string();
    };
    const std::vector<std::size_t> shape = t.shape();
    const std::size_t n = checked_cell_count(t.axes, where);
    check_fits_in_memory(n, sizeof(double), where);

    auto read_cells = [&](const char* dname, auto&& reader) {
        Handle ds(H5Dopen2(group, dname, H5P_DEFAULT), H5Dclose, "H5Dopen2", dname);
        std::vector<hsize_t> d = dataset_dims(ds, dname);
        if (!std::equal(d.begin(), d.end(), shape.begin(), shape.end()))
            throw InputError(where + "dataset '" + dname + "' shape does not match the axes");
        reader(ds);
    };
    if (!has_link(group, "value")) throw InputError(where + "dataset 'value' is missing");
    read_cells("value", [&](hid_t ds) {
        t.value = read_real(ds, "value", n);
        t.stored_type = stored_type_of(ds, "value");
        t.compression = deflate_level(ds, "value");
    });
    if (has_attr(group, "stored_type")) t.stored_type = parse_stored_type(str("stored_type"));
    t.keep_stderr = has_link(group, "stderr");
    if (t.keep_stderr)
        read_cells("stderr", [&](hid_t ds) { t.stderr_ = read_real(ds, "stderr", n); });
    if (has_link(group, "samples"))
        read_cells("samples", [&](hid_t ds) {
            t.samples.resize(n);
            check(H5Dread(ds, H5T_NATIVE_UINT32, H5S_ALL, H5S_ALL, H5P_DEFAULT,
                          t.samples.data()),
                  "H5Dread", "samples");
        });
    return t;
}

}  // namespace

// ------------------------------------------------------------ TableReader --

struct TableReader::Impl {
    std::string path;
    Handle file;
};

TableReader::TableReader(const std::string& path) : impl_(std::make_unique<Impl>()) {
    impl_->path = path;
    impl_->file = as_input_error(path, "'" + path + "': ",
                                   [&] { return open_brdftab_file(path); });
}
TableReader::~TableReader() = default;
TableReader::TableReader(TableReader&&) noexcept = default;
TableReader& TableReader::operator=(TableReader&&) noexcept = default;

const std::string& TableReader::path() const { return impl_->path; }

static_assert(std::is_same_v<hid_t, std::int64_t>, "TableReader::hdf5_file returns an hid_t");
std::int64_t TableReader::hdf5_file() const { return impl_->file.get(); }

std::vector<std::string> TableReader::table_names() const {
    return as_input_error(impl_->path, "'" + impl_->path + "': ",
                          [&] { return group_names(impl_->file); });
}

TableData TableReader::read(const std::string& name) const {
    return as_input_error(impl_->path, "'" + impl_->path + "', table '" + name + "': ",
                          [&] { return read_group(impl_->file, impl_->path, name); });
}

nlohmann::json TableReader::file_attributes() const {
    return as_input_error(impl_->path, "'" + impl_->path + "': ", [&] {
        nlohmann::json out = nlohmann::json::object();
        for (const std::string& a : attr_names(impl_->file)) out[a] = attr_to_json(impl_->file, a);
        return out;
    });
}

std::vector<std::string> list_tables(const std::string& path) {
    return TableReader(path).table_names();
}

TableData read_table(const std::string& path, const std::string& name) {
    return TableReader(path).read(name);
}

nlohmann::json read_file_attributes(const std::string& path) {
    return TableReader(path).file_attributes();
}

std::optional<StoredCertificate> read_stored_certificate(const std::string& path, const std::string& table) {
    const TableReader reader(path);
    const std::vector<std::string> names = reader.table_names();
    if (std::find(names.begin(), names.end(), table) == names.end())
        throw InputError(path + ": no table '" + table + "'");
    Handle group(H5Gopen2(static_cast<hid_t>(reader.hdf5_file()), table.c_str(), H5P_DEFAULT), H5Gclose,
                 "H5Gopen2", path + ": " + table);
    if (!has_attr(group, "certificate_max_error")) return std::nullopt;
    StoredCertificate c;
    c.max_error = read_double_attr(group, "certificate_max_error");
    c.rms_error = read_double_attr(group, "certificate_rms_error");
    c.target = read_double_attr(group, "certificate_target");
    c.absolute = read_string_attr(group, "certificate_measure") == "absolute";
    c.abs_floor = read_double_attr(group, "certificate_abs_floor");
    c.interpolation = read_string_attr(group, "certificate_interpolation");
    c.passed = read_u64_attr(group, "certificate_passed") != 0;
    return c;
}

// ------------------------------------------------------- streaming writer --

struct TableFileWriter::Impl {
    std::unique_ptr<AtomicOutput> tmp;
    Handle file;
    struct Open {
        TableObjects objects;
        StoredType type = StoredType::Float64;
        RoundingRule value_rule, stderr_rule;
        double max_abs = 0;  // largest finite |value| written (rounding attributes)
        std::size_t cells = 0;
        std::string name;
    };
    std::vector<std::unique_ptr<Open>> tables;  // null once finished

    Open& open_table(std::size_t k) {
        if (k >= tables.size() || !tables[k]) throw Error("table file writer: no such open table");
        return *tables[k];
    }
};

TableFileWriter::TableFileWriter(const std::string& path) : impl_(std::make_unique<Impl>()) {
    silence_hdf5();
    if (H5Zfilter_avail(H5Z_FILTER_DEFLATE) <= 0 || H5Zfilter_avail(H5Z_FILTER_SHUFFLE) <= 0 ||
        H5Zfilter_avail(H5Z_FILTER_FLETCHER32) <= 0)
        throw Error("this HDF5 library lacks the deflate, shuffle or fletcher32 filter");
    impl_->tmp = std::make_unique<AtomicOutput>(path);
    Handle fapl = make_plist(H5P_FILE_ACCESS, "file access");
    // Oldest object formats that still hold everything we write, so readers
    // linked against older HDF5 releases can open the file.
    check(H5Pset_libver_bounds(fapl, H5F_LIBVER_EARLIEST, H5F_LIBVER_V18),
          "H5Pset_libver_bounds");
    impl_->file = Handle(H5Fcreate(impl_->tmp->path().c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, fapl),
                         H5Fclose, "H5Fcreate", impl_->tmp->path());
    write_i32_attr(impl_->file, "brdftab_format", kFormatVersion);
    write_string_attr(impl_->file, "brdftab_version", BRDFTAB_VERSION);
    write_string_attr(impl_->file, "created", utc_now_iso8601());
}

TableFileWriter::~TableFileWriter() {
    // Uncommitted: the temporary file is thrown away, so nothing more of it
    // goes to the disk, whose being full may be why we are here (closing a
    // table flushes its chunk cache; see hdf5_handles.h).  Handles close
    // before the temporary file is removed.
    if (impl_->file.get() >= 0) detach_from_disk(impl_->file);
    impl_->tables.clear();
    impl_->file = Handle();
    impl_->tmp.reset();
}

const std::string& TableFileWriter::temporary_path() const { return impl_->tmp->path(); }

std::size_t TableFileWriter::begin_table(const TableData& t, bool with_stderr, bool with_samples) {
    validate_table(t, false);
    auto open = std::make_unique<Impl::Open>();
    open->objects = create_table_objects(impl_->file, t, with_stderr, with_samples);
    open->type = t.stored_type;
    open->value_rule = value_rounding(t);
    open->stderr_rule = stderr_rounding(t);
    open->cells = checked_cell_count(t.axes, "table '" + t.name + "': ");
    open->name = t.name;
    impl_->tables.push_back(std::move(open));
    return impl_->tables.size() - 1;
}

void TableFileWriter::write_cells(std::size_t table, std::size_t first, std::size_t count,
                                  const double* value, const double* stderr_,
                                  const std::uint32_t* samples) {
    Impl::Open& t = impl_->open_table(table);
    if (first > t.cells || count > t.cells - first)
        throw Error("table '" + t.name + "': cells " + std::to_string(first) + " + " +
                    std::to_string(count) + " beyond its " + std::to_string(t.cells));
    const TableObjects& o = t.objects;
    write_real_cells(o.value, "value", value, t.type, o.dims, first, count, t.value_rule);
    t.max_abs = std::max(t.max_abs, max_finite_abs(value, count));
    if (o.stderr_.get() >= 0)
        write_real_cells(o.stderr_, "stderr", stderr_, t.type, o.dims, first, count, t.stderr_rule);
    if (o.samples.get() >= 0)
        write_cell_range(o.samples, "samples", H5T_NATIVE_UINT32, samples, 4, o.dims, first,
                         count);
}

void TableFileWriter::finish_table(std::size_t table, const TableData& t) {
    Impl::Open& open = impl_->open_table(table);
    attach_scales(open.objects, t);
    write_table_attributes(open.objects.group, t);
    write_rounding_attributes(open.objects.group, t, open.max_abs, open.objects.stderr_.get() >= 0);
    impl_->tables[table].reset();
}

void TableFileWriter::add_table(const TableData& t) {
    validate_table(t);
    write_table(impl_->file, t);
}

void TableFileWriter::commit() {
    for (const auto& t : impl_->tables)
        if (t) throw Error("table file writer: table '" + t->name + "' was not finished");
    impl_->tables.clear();
    close_written_file(impl_->file, impl_->tmp->path());
    impl_->tmp->commit();
}

std::int64_t TableFileWriter::hdf5_file() const { return impl_->file.get(); }

// ------------------------------------------- shared with other representations --

namespace table_io_detail {

void create_table_group(std::int64_t file, const TableData& t) {
    validate_table(t, false);
    htri_t exists = H5Lexists(file, t.name.c_str(), H5P_DEFAULT);
    check(exists, "H5Lexists", t.name);
    if (exists > 0) throw InputError("table name '" + t.name + "' used twice in one file");
    Handle group(H5Gcreate2(file, t.name.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose,
                 "H5Gcreate2", t.name);
    for (const Axis& a : t.axes) write_axis_dataset(group, a);
}

void write_description(std::int64_t group, const TableData& t, double max_abs, bool with_stderr) {
    write_table_attributes(group, t);
    write_rounding_attributes(group, t, max_abs, with_stderr);
}

void write_real_dataset(std::int64_t group, const char* name, const std::vector<double>& v,
                        const TableData& t, bool is_stderr) {
    Handle half;
    hid_t type = t.stored_type == StoredType::Float64   ? H5T_IEEE_F64LE
                 : t.stored_type == StoredType::Float32 ? H5T_IEEE_F32LE
                                                        : (half = half_type()).get();
    const std::vector<hsize_t> dims{v.size()};
    Handle ds = create_dataset(group, name, type, dims, t.compression);
    write_real_cells(ds, name, v.data(), t.stored_type, dims, 0, v.size(),
                     is_stderr ? stderr_rounding(t) : value_rounding(t));
}

void write_plain_dataset(std::int64_t group, const char* name, std::int64_t file_type,
                         std::int64_t mem_type, const std::vector<std::uint64_t>& dims,
                         const void* data, int compression) {
    const std::vector<hsize_t> d(dims.begin(), dims.end());
    Handle ds = create_dataset(group, name, file_type, d, compression);
    check(H5Dwrite(ds, mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data), "H5Dwrite", name);
}

TableData read_description(std::int64_t file, const std::string& path, const std::string& name) {
    return brdftab::read_description(file, path, name);
}

std::string representation(std::int64_t file, const std::string& name) {
    return representation_of(file, name);
}

bool has_dataset(std::int64_t group, const std::string& name) { return has_link(group, name); }

std::vector<std::uint64_t> dataset_shape(std::int64_t group, const std::string& name) {
    Handle ds(H5Dopen2(group, name.c_str(), H5P_DEFAULT), H5Dclose, "H5Dopen2", name);
    const std::vector<hsize_t> d = dataset_dims(ds, name);
    return std::vector<std::uint64_t>(d.begin(), d.end());
}

std::vector<double> read_reals(std::int64_t group, const std::string& name, std::size_t count,
                               StoredType* stored, int* compression) {
    Handle ds(H5Dopen2(group, name.c_str(), H5P_DEFAULT), H5Dclose, "H5Dopen2", name);
    check_fits_in_memory(count, sizeof(double), name + ": ");
    if (stored) *stored = stored_type_of(ds, name);
    if (compression) *compression = deflate_level(ds, name);
    return read_real(ds, name, count);
}

void read_native(std::int64_t group, const std::string& name, std::int64_t mem_type, void* out) {
    Handle ds(H5Dopen2(group, name.c_str(), H5P_DEFAULT), H5Dclose, "H5Dopen2", name);
    check(H5Dread(ds, mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, out), "H5Dread", name);
}

}  // namespace table_io_detail

}  // namespace brdftab
