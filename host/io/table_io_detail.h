// table_io_detail.h — the pieces of the table file schema (table_io.cpp)
// that a writer and reader of another table representation shares with the
// tensor tables: the description (provenance attributes, axes, rounding),
// real-valued datasets in the stored type with the same filters, and plain
// datasets.  For host/adaptive/adaptive_io.cpp; not installed.  HDF5
// handles are passed as hid_t values (std::int64_t).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "host/core/table.h"

namespace brdftab::table_io_detail {

// Creates group t.name (InputError when the name is taken) with t's axis
// datasets (as a tensor table's, dimension scales included).
void create_table_group(std::int64_t file, const TableData& t);
// Provenance and rounding attributes of t on `group` (as a tensor table's);
// max_abs: the largest finite |value| (the absolute rounding's bits).
void write_description(std::int64_t group, const TableData& t, double max_abs, bool with_stderr);
// A 1-D dataset of reals in t's stored type, compression and rounding
// (stderr: the stderr rounding), as a tensor table's value/stderr.
void write_real_dataset(std::int64_t group, const char* name, const std::vector<double>& v,
                        const TableData& t, bool is_stderr);
// A dataset of `dims` from native memory (H5T_NATIVE_* `mem_type`) stored as
// `file_type`, chunked, shuffled and deflated at `compression`, checksummed.
void write_plain_dataset(std::int64_t group, const char* name, std::int64_t file_type,
                         std::int64_t mem_type, const std::vector<std::uint64_t>& dims,
                         const void* data, int compression);

// The description of table `name` (attributes, axes, rounding; no data),
// whatever its representation.  InputError as read_table.
TableData read_description(std::int64_t file, const std::string& path, const std::string& name);
// The table group's `representation` attribute ("tensor" when absent).
std::string representation(std::int64_t file, const std::string& name);
bool has_dataset(std::int64_t group, const std::string& name);
// Dims of dataset `name` of `group`.
std::vector<std::uint64_t> dataset_shape(std::int64_t group, const std::string& name);
// Whole datasets into native memory, checked for `count` elements.
std::vector<double> read_reals(std::int64_t group, const std::string& name, std::size_t count,
                               StoredType* stored = nullptr, int* compression = nullptr);
void read_native(std::int64_t group, const std::string& name, std::int64_t mem_type, void* out);

}  // namespace brdftab::table_io_detail
