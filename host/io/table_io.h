// table_io.h — brdftab HDF5 table files (format: docs/format.md).
//
// One HDF5 group per table, datasets `value` and optional `stderr` (and
// `samples`), each axis a 1-D dataset attached as a dimension scale, and
// provenance as attributes.  Files are readable by h5py without our code.
#pragma once

#include <string>
#include <vector>

#include "../core/table.h"

namespace brdftab {

// Write all tables into one file.  The file is written to a temporary path
// beside `path` and renamed over it only when complete, so a failure never
// leaves a partial file nor damages an existing one.  Throws Error.
void write_tables(const std::string& path, const std::vector<TableData>& tables);

// Names of the tables (groups) in a file.  Throws InputError if the file is
// missing or not a brdftab file.
std::vector<std::string> list_tables(const std::string& path);

// Read one table back (values converted to double whatever the stored type).
// Throws InputError naming the file and the table if absent.
TableData read_table(const std::string& path, const std::string& name);

// File-level attributes (brdftab version, spec text, creation time) as JSON.
nlohmann::json read_file_attributes(const std::string& path);

}  // namespace brdftab
