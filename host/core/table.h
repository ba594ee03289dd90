// table.h — the in-memory form of one tabulated quantity.
//
// This is what the engine produces, what table_io writes to / reads from HDF5,
// what exr_export slices and what the lookup library interpolates.  Values are
// stored row-major with the LAST axis varying fastest (C order, as h5py and
// numpy see them).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "grid.h"
#include "vocabulary.h"

namespace brdftab {

enum class StoredType { Float64, Float32, Float16 };

const char* stored_type_name(StoredType t);            // "float64" | "float32" | "float16"
StoredType parse_stored_type(const std::string& name);  // throws InputError

struct TableData {
    std::string name;      // HDF5 group name, e.g. "brdf"
    std::string model;     // e.g. "rough-dielectric"
    std::string quantity;  // e.g. "brdf"
    std::string units;     // unit of `value`, e.g. "1/sr" or "1"
    std::string description;
    nlohmann::json parameters = nlohmann::json::object();  // fixed parameters and options
    std::vector<Axis> axes;  // table axes, outermost first

    std::vector<double> value;   // prod(axis counts) entries
    std::vector<double> stderr_; // same size, or empty when not kept / closed form
    std::vector<std::uint32_t> samples;  // samples used per cell (optional, may be empty)

    // Provenance (written as HDF5 attributes).
    // How the table came to be, and for a computed table the integration
    // method (Auto: not recorded).  The file holds both in one `method`
    // attribute, see method_attribute().
    TableKind kind = TableKind::Computed;
    Method method = Method::Auto;
    std::uint64_t samples_requested = 0;  // --samples budget, or max budget under --tolerance
    double tolerance_requested = 0;  // 0 when a fixed budget was used
    double abs_floor = 0;
    double tolerance_achieved = 0;   // see EstimateResult::tolerance_achieved (engine.h)
    std::uint64_t seed = 0;
    std::string precision;  // "double" | "float"
    std::string device;     // device name or "host"
    std::string version;    // brdftab version
    std::string spec_file;  // the spec the table was generated from (may be empty)
    std::string spec_text;  // that spec's full text (empty when none; attribute "spec")
    double elapsed_seconds = 0;
    std::uint64_t total_samples = 0;

    // Storage choices (output section of the spec).
    StoredType stored_type = StoredType::Float32;
    int compression = 6;     // deflate level 0..9 (0 = no compression filter)
    bool keep_stderr = true;
    // Rounded storage (host/io/bit_rounding.h): > 0: the values keep only the
    // mantissa bits this accuracy needs, in the relative measure or, with
    // round_absolute, the absolute one.  0: the stored type's own rounding.
    double round_accuracy = 0;
    bool round_absolute = false;

    std::size_t cell_count() const;
    std::vector<std::size_t> shape() const;
    // Row-major flat index of a multi-index.
    std::size_t flat_index(const std::vector<std::size_t>& index) const;
};

// The `method` attribute of a stored table: the integration method's name for
// a computed table ("closed-form", "mc", ...), the kind's name for a table
// formed from others ("recombined", "error", "inverted").
std::string method_attribute(const TableData& t);
// Sets t.kind and t.method from a `method` attribute; an empty one (a file
// that records none) reads as a computed table with method Auto.  Throws
// InputError naming the allowed values.
void set_method_attribute(TableData& t, const std::string& attribute);

}  // namespace brdftab
