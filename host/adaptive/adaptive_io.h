// adaptive_io.h — adaptive tables in brdftab HDF5 files (docs/format.md,
// "Adaptive tables").  The same file, group and provenance attributes as a
// tensor table; the group's attribute representation = "adaptive" and its
// datasets hold the tree, the leaves and one value per stored node.
#pragma once

#include <string>
#include <vector>

#include "host/adaptive/adaptive_table.h"
#include "host/io/table_io.h"

namespace brdftab {

// Adds adaptive table `t` to a file being written (checked first: its
// layout, value and stderr sizes).  Throws InputError / Error.
void add_adaptive_table(TableFileWriter& out, const AdaptiveTable& t);
// A file of tensor tables and adaptive tables (atomically, as write_tables).
void write_table_file(const std::string& path, const std::vector<TableData>& tensors,
                      const std::vector<AdaptiveTable>& adaptive);

// Whether table `name` of an open file is adaptive (InputError: no such table).
bool is_adaptive_table(const TableReader& reader, const std::string& name);
bool is_adaptive_table(const std::string& path, const std::string& name);
// Reads an adaptive table, every dataset checked (AdaptiveLayout::check);
// InputError naming the file and the table otherwise.
AdaptiveTable read_adaptive_table(const TableReader& reader, const std::string& name);
AdaptiveTable read_adaptive_table(const std::string& path, const std::string& name);

}  // namespace brdftab
