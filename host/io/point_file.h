// point_file.h — CSV point files: a header row of names, then one point per
// row (`brdftab eval --points`, `brdftab query --points`).  Only names and
// numbers: cells are split on commas and trimmed, no quoting.  Blank lines
// are skipped.  Every problem is an InputError that names the file and line
// ("points.csv:3: column 'alpha': ...").  Not installed.
#pragma once

#include <cstddef>
#include <functional>
#include <map>
#include <string>
#include <vector>

namespace brdftab {

// One CSV line split on commas, cells trimmed of blanks (a trailing comma
// gives a trailing empty cell).
std::vector<std::string> split_csv(const std::string& line);

// strtod over the whole text; InputError "<what>: '<text>' is not a finite
// number" otherwise.
double parse_number(const std::string& text, const std::string& what);

struct PointRow {
    std::size_t line = 0;            // 1-based line in the file
    std::vector<std::string> cells;  // as written (trimmed), for echoing back
    std::vector<double> values;      // cells as numbers, in header order
};

struct PointFile {
    std::string path;
    std::vector<std::string> header;
    std::vector<PointRow> rows;

    // "path:line" of a row, the prefix of messages about it.
    std::string where(const PointRow& row) const;
    // Header names -> values of one row laid over `defaults` (a name the
    // header repeats takes its last column).
    std::map<std::string, double> named(const PointRow& row,
                                        std::map<std::string, double> defaults = {}) const;
};

// What a reader accepts beyond the CSV shape.  Each check returns an empty
// string when all is well, or the problem, which becomes the tail of the
// InputError ("path:line: column 'name' <problem>", and for values
// "path:line: column 'name': <problem>").
struct PointFileRules {
    std::function<std::string(const std::string& column)> column_problem;
    bool unique_columns = false;  // a repeated column is an error
    std::function<std::string(const std::string& column, double value)> value_problem;
    // Called for each row as soon as it is read and checked, before the next
    // line is read (so a caller's per-row errors and warnings come in file
    // order); may throw.
    std::function<void(const PointFile& file, const PointRow& row)> on_row;
};

// Reads the whole file.  Throws InputError when it cannot be opened, when a
// row's cell count differs from the header's, a cell is not a finite number,
// a rule rejects a column or value, or the file has no rows.
PointFile read_point_file(const std::string& path, const PointFileRules& rules = {});

}  // namespace brdftab
