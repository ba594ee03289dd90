// table_io.h — brdftab HDF5 table files (format: docs/format.md).
//
// One HDF5 group per table, datasets `value` and optional `stderr` (and
// `samples`), each axis a 1-D dataset attached as a dimension scale, and
// provenance as attributes.  Files are readable by h5py without our code.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "../core/table.h"

namespace brdftab {

// Write all tables into one file.  The file is written to a temporary path
// beside `path` and renamed over it only when complete, so a failure never
// leaves a partial file nor damages an existing one.  Throws Error.
void write_tables(const std::string& path, const std::vector<TableData>& tables);

// The same file written piece by piece (issue #15: a table need not be held
// whole in memory).  Tables are begun with their description (every field of
// TableData but value, stderr_ and samples, which may be empty), filled with
// ranges of cells in any order, and finished with their provenance; whole
// tables can be added too.  The file is a temporary one beside `path` until
// commit(), which renames it over `path`; destroyed uncommitted, it is
// removed.  The committed file holds exactly what write_tables() would write
// for the same tables (every dataset and attribute, bit for bit).
class TableFileWriter {
public:
    explicit TableFileWriter(const std::string& path);
    ~TableFileWriter();
    TableFileWriter(const TableFileWriter&) = delete;
    TableFileWriter& operator=(const TableFileWriter&) = delete;

    // Creates table `t` (checked as write_tables checks it): its group, its
    // axes and empty datasets: value, stderr when `with_stderr` (write_tables
    // writes it when t.keep_stderr and stderr_ is filled) and samples when
    // `with_samples`.  Returns the table's handle for the calls below.
    std::size_t begin_table(const TableData& t, bool with_stderr, bool with_samples);
    // Cells [first, first + count) in row-major order; stderr_/samples are
    // ignored when the table has no such dataset.
    void write_cells(std::size_t table, std::size_t first, std::size_t count, const double* value,
                     const double* stderr_, const std::uint32_t* samples);
    // Attaches the axes as dimension scales and writes the table's attributes
    // (from `t`, whose data may be empty); closes the table.
    void finish_table(std::size_t table, const TableData& t);
    // A whole table at once, as write_tables writes it.
    void add_table(const TableData& t);
    // Closes the file and renames it over `path`.  Throws Error.
    void commit();
    const std::string& temporary_path() const;
    // The open HDF5 file (an hid_t) until commit(), for writers of other
    // table representations (host/adaptive/adaptive_io.h).
    std::int64_t hdf5_file() const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

// A table file opened once for reading: the listing, the file attributes and
// any number of tables come from the same open file, so a file replaced
// meanwhile (atomically, by another `generate`) is never read half old, half
// new.  Every check of read_table applies.  A malformed or damaged file is an
// InputError naming the file and the object, never a crash in our code; but
// libhdf5 itself may loop or crash on damaged metadata (docs/format.md,
// "Reading untrusted files").
class TableReader {
public:
    // Opens the file and checks that it is a brdftab file of a format this
    // build reads.  Throws InputError.
    explicit TableReader(const std::string& path);
    ~TableReader();
    TableReader(TableReader&&) noexcept;
    TableReader& operator=(TableReader&&) noexcept;

    const std::string& path() const;
    // Names of the tables (groups), in name order.
    std::vector<std::string> table_names() const;
    // One table, as read_table.
    TableData read(const std::string& name) const;
    // File-level attributes, as read_file_attributes.
    nlohmann::json file_attributes() const;
    // The open HDF5 file (an hid_t), valid while the reader lives: for
    // readers of further attributes of this same file (read_certificate).
    std::int64_t hdf5_file() const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

// For a program's main(), before its first use of HDF5: switches off
// libhdf5's clean-up at exit.  After an H5Fclose that failed (a full disk
// during the close's last flush, a file size limit) libhdf5 1.10 keeps the id
// of a file it has freed, and that clean-up crashes on it (host/io/
// hdf5_handles.h).  The writers here close every file before they return or
// throw, so the clean-up would only free the library's memory.  A program
// that also writes HDF5 files through other code (h5py) and relies on that
// clean-up to flush them must not call it.  No effect once HDF5 has started.
void disable_hdf5_exit_cleanup();

// Names of the tables (groups) in a file.  Throws InputError if the file is
// missing or not a brdftab file.
std::vector<std::string> list_tables(const std::string& path);

// Read one table back (values converted to double whatever the stored type).
// Throws InputError naming the file and the table if absent, and for a
// malformed file: attributes of the wrong type or size, axes with fewer than
// 2 nodes, not strictly increasing, or whose min/max attributes disagree with
// their node list (the node list is used), a cell count that overflows or
// does not fit in memory, data whose shape differs from the axes' lengths,
// and data whose Fletcher-32 checksum does not match.
TableData read_table(const std::string& path, const std::string& name);

// File-level attributes (brdftab version, spec text, creation time) as JSON.
nlohmann::json read_file_attributes(const std::string& path);

// The certificate stored with a table (attributes certificate_*, written by
// `generate --accuracy`, `certify --store` and `scene`; docs/format.md): its
// measured max and RMS total error between nodes, in its measure (absolute,
// or relative to max(|value|, abs_floor)), for its interpolation.  nullopt:
// the table has none.  Throws InputError as read_table.
struct StoredCertificate {
    double max_error = 0, rms_error = 0, target = 0, abs_floor = 0;
    bool absolute = false, passed = false;
    std::string interpolation;  // "linear" | "cubic"
};
std::optional<StoredCertificate> read_stored_certificate(const std::string& path, const std::string& table);

}  // namespace brdftab
