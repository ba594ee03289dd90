// point_file.cpp — CSV point files (point_file.h).
#include "host/io/point_file.h"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <set>
#include <sstream>

#include "host/core/error.h"

namespace brdftab {

std::vector<std::string> split_csv(const std::string& line) {
    std::vector<std::string> out;
    std::string cell;
    std::istringstream s(line);
    while (std::getline(s, cell, ',')) {
        const auto b = cell.find_first_not_of(" \t\r");
        const auto e = cell.find_last_not_of(" \t\r");
        out.push_back(b == std::string::npos ? "" : cell.substr(b, e - b + 1));
    }
    if (!line.empty() && line.back() == ',') out.push_back("");
    return out;
}

double parse_number(const std::string& text, const std::string& what) {
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    if (end == text.c_str() || *end != '\0' || !std::isfinite(v))
        throw InputError(what + ": '" + text + "' is not a finite number");
    return v;
}

std::string PointFile::where(const PointRow& row) const {
    return path + ":" + std::to_string(row.line);
}

std::map<std::string, double> PointFile::named(const PointRow& row,
                                               std::map<std::string, double> defaults) const {
    for (std::size_t c = 0; c < header.size() && c < row.values.size(); ++c)
        defaults[header[c]] = row.values[c];
    return defaults;
}

PointFile read_point_file(const std::string& path, const PointFileRules& rules) {
    std::ifstream in(path);
    if (!in) throw InputError("cannot open points file '" + path + "'");
    PointFile file;
    file.path = path;
    std::string line;
    std::size_t line_no = 0;
    while (std::getline(in, line)) {
        ++line_no;
        if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
        const std::string at = path + ":" + std::to_string(line_no);
        if (file.header.empty()) {
            file.header = split_csv(line);
            std::set<std::string> seen;
            for (const auto& h : file.header) {
                if (rules.column_problem) {
                    const std::string problem = rules.column_problem(h);
                    if (!problem.empty())
                        throw InputError(at + ": column '" + h + "' " + problem);
                }
                if (rules.unique_columns && !seen.insert(h).second)
                    throw InputError(at + ": column '" + h + "' twice");
            }
            continue;
        }
        PointRow row;
        row.line = line_no;
        row.cells = split_csv(line);
        if (row.cells.size() != file.header.size())
            throw InputError(at + ": " + std::to_string(row.cells.size()) +
                             " columns, header has " + std::to_string(file.header.size()));
        for (std::size_t c = 0; c < row.cells.size(); ++c) {
            const std::string where = at + ": column '" + file.header[c] + "'";
            const double v = parse_number(row.cells[c], where);
            if (rules.value_problem) {
                const std::string problem = rules.value_problem(file.header[c], v);
                if (!problem.empty()) throw InputError(where + ": " + problem);
            }
            row.values.push_back(v);
        }
        file.rows.push_back(std::move(row));
        if (rules.on_row) rules.on_row(file, file.rows.back());
    }
    if (file.rows.empty()) throw InputError("points file '" + path + "' has no rows");
    return file;
}

}  // namespace brdftab
