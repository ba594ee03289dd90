// header_export.h — a table as a self-contained C99 header: the values as a
// `static const` array, the axes (node lists, warps, ranges) as constants and
// a multilinear lookup function that reproduces the library's linear
// interpolation (host/lookup/interpolate.cpp) in each axis' warped
// coordinate.  The way engines ship precomputed LUTs: no file reading, no
// library, only <math.h> (and <stdint.h> for 16-bit types).
#pragma once

#include <optional>
#include <string>

#include "host/core/table.h"
#include "host/io/table_io.h"

namespace brdftab {

// How the values are stored in the header.
//   Float   `float`; the lookup differs from the library's by float rounding
//           of the node values (relative 2^-24 of the largest corner).
//   Half    IEEE binary16 bits (`uint16_t`), decoded by a function in the
//           header; relative rounding error <= 2^-11 per node value (normal
//           range), absolute <= 2^-25 below 2^-14.  Values beyond the half
//           range (|v| > 65504) are refused.
//   Uint16  v = offset + scale * q with q in [0, 65535], offset = min value,
//           scale = (max - min) / 65535; absolute error <= scale / 2.
enum class HeaderValueType { Float, Half, Uint16 };

HeaderValueType parse_header_value_type(const std::string& name);  // InputError
// Whether s is a C identifier (letters, digits and '_', not starting with a
// digit).
bool is_c_identifier(const std::string& s);
// v as a C float literal that reads back to the same float ("%.9g", with a
// '.0' where it would otherwise read as an int, and the 'f' suffix).
std::string c_float_literal(float v);

struct HeaderExportOptions {
    // Prefix of every identifier in the header (a C identifier); empty: the
    // table name with every character outside [A-Za-z0-9_] replaced by '_'.
    std::string name;
    HeaderValueType type = HeaderValueType::Float;
    std::string source;  // e.g. the input file name, written in the comment
    // The table's stored certificate (read_stored_certificate), stated in
    // the comment with the stored stderr; nullopt: the comment says the
    // error between nodes was not measured.
    std::optional<StoredCertificate> certificate;
};

// The identifier prefix the header will use for `table` under `options`
// (validated: InputError if it is not a C identifier).
std::string header_identifier(const TableData& table, const HeaderExportOptions& options);

// Writes the header (atomically).  Throws InputError for a table the format
// cannot hold (recombined tables: export their term tables; NaN values;
// values outside the half range with Half).
void export_c_header(const TableData& table, const std::string& out_path,
                     const HeaderExportOptions& options);

struct AdaptiveTable;  // host/adaptive/adaptive_table.h
// An adaptive table (docs/adaptive.md) as a header: the axes as above, the
// tree (split axis, cut, children), the leaves' boxes and node lists, the
// node values and an eval that descends the tree and interpolates the leaf
// as AdaptiveLayout::eval does.  The same storage types and refusals.
void export_c_header(const AdaptiveTable& table, const std::string& out_path,
                     const HeaderExportOptions& options);

}  // namespace brdftab
