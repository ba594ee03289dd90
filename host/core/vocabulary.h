// vocabulary.h — the closed sets of names brdftab speaks in, as enums.
//
// Inside the library an integration method, a table kind or a direction
// coordinate is an enum value; the spelled-out names appear only at the
// boundaries (spec files, command-line arguments, HDF5 attributes, JSON,
// messages), and each set has exactly one name <-> value table below, so a
// spelling lives in one place.  The names are part of the file format and the
// CLI: changing one changes what old files and scripts mean.
//
// This header includes only the standard library, so it can be installed
// next to grid.h and table.h.
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace brdftab {

// One entry of a name <-> value table.
template <class Enum>
struct NamedValue {
    Enum value;
    const char* name;
};

// ------------------------------------------------------ integration method

// How a quantity's cells are estimated (engine.h describes each estimator).
// Auto stands for "the quantity's default" and is resolved before any work
// (resolve_method in host/models/registry.h).
enum class Method { Auto, ClosedForm, Quadrature, MonteCarlo, Rqmc };

// In this order, the list of allowed names in messages.
inline constexpr NamedValue<Method> kMethodNames[] = {
    {Method::Auto, "auto"},
    {Method::ClosedForm, "closed-form"},
    {Method::Quadrature, "quadrature"},
    {Method::MonteCarlo, "mc"},
    {Method::Rqmc, "rqmc"},
};

std::string to_string(Method method);
// Throws InputError: "integration method 'NAME' is not valid; allowed: auto,
// closed-form, quadrature, mc, rqmc".
Method parse_method(const std::string& name);
std::optional<Method> find_method(std::string_view name);  // nullopt when unknown
std::vector<std::string> method_names();                   // table order

// ------------------------------------------------------------ axis spacing

// Node placement along a table axis; grid.h defines each warp and its inverse.
// The name is stored in the file as the axis' `spacing` attribute.
enum class Spacing { Linear, Cos, Log, Quadratic, Explicit, LogComplement, Critical };

inline constexpr NamedValue<Spacing> kSpacingNames[] = {
    {Spacing::Linear, "linear"},
    {Spacing::Cos, "cos"},
    {Spacing::Log, "log"},
    {Spacing::Quadratic, "quadratic"},
    {Spacing::Explicit, "explicit"},
    {Spacing::LogComplement, "log-complement"},
    {Spacing::Critical, "critical"},
};

const char* spacing_name(Spacing s);
// Throws InputError: "unknown spacing 'NAME'; allowed: linear, cos, log,
// quadratic, explicit, log-complement, critical".
Spacing parse_spacing(const std::string& name);

// ------------------------------------------------------------ table kind

// How a stored table came to be: computed by the engine from a model
// quantity, or formed from other tables of the same spec ([[recombined]],
// [[errors]], [[inverted]], see host/spec/spec.h).
enum class TableKind { Computed, Recombined, Error, Inverted };

inline constexpr NamedValue<TableKind> kTableKindNames[] = {
    {TableKind::Computed, "computed"},
    {TableKind::Recombined, "recombined"},
    {TableKind::Error, "error"},
    {TableKind::Inverted, "inverted"},
};

std::string to_string(TableKind kind);
// Throws InputError: "unknown table kind 'NAME'; allowed: computed, ...".
TableKind parse_table_kind(const std::string& name);
std::optional<TableKind> find_table_kind(std::string_view name);

// ----------------------------------------------------- direction coordinates

// The user-facing names of the four kernel direction slots and their
// alternatives (host/models/registry.h describes the point layout):
//   theta_i, phi_i, theta_o, phi_o   polar angle in [0, 180] deg from the macro
//                                    normal (> 90 = below the surface), azimuth
//   phi_d                            phi_o - phi_i (replaces phi_o)
//   mu_i, mu_o                       cos(theta) (replaces theta)
enum class Coordinate { ThetaI, PhiI, ThetaO, PhiO, PhiD, MuI, MuO };

// How a coordinate's user value becomes its kernel slot's value (radians).
enum class CoordinateEncoding {
    Degrees,        // slot = value * pi / 180
    Cosine,         // slot = acos(value)
    AzimuthOffset,  // phi_d: slot phi_o = phi_i + value * pi / 180
};

struct CoordinateInfo {
    Coordinate id;
    const char* name;
    const char* unit;  // "deg" or "1"
    double min, max;   // allowed user values, both inclusive
    // The direction it describes: the kernel slot's own coordinate.  Two
    // coordinates of the same direction (theta_i and mu_i, phi_o and phi_d)
    // cannot both be given.
    Coordinate direction;
    int slot;  // kernel point slot 0..3 (theta_i, phi_i, theta_o, phi_o)
    CoordinateEncoding encoding;
};

// In this order, the list of direction names in messages.
inline constexpr CoordinateInfo kCoordinates[] = {
    {Coordinate::ThetaI, "theta_i", "deg", 0, 180, Coordinate::ThetaI, 0,
     CoordinateEncoding::Degrees},
    {Coordinate::PhiI, "phi_i", "deg", -360, 360, Coordinate::PhiI, 1,
     CoordinateEncoding::Degrees},
    {Coordinate::ThetaO, "theta_o", "deg", 0, 180, Coordinate::ThetaO, 2,
     CoordinateEncoding::Degrees},
    {Coordinate::PhiO, "phi_o", "deg", -360, 360, Coordinate::PhiO, 3,
     CoordinateEncoding::Degrees},
    {Coordinate::PhiD, "phi_d", "deg", -360, 360, Coordinate::PhiO, 3,
     CoordinateEncoding::AzimuthOffset},
    {Coordinate::MuI, "mu_i", "1", -1, 1, Coordinate::ThetaI, 0,
     CoordinateEncoding::Cosine},
    {Coordinate::MuO, "mu_o", "1", -1, 1, Coordinate::ThetaO, 2,
     CoordinateEncoding::Cosine},
};

const CoordinateInfo& coordinate_info(Coordinate c);
// nullptr when `name` is not a direction coordinate.
const CoordinateInfo* find_coordinate(std::string_view name);
std::string to_string(Coordinate c);
std::vector<std::string> coordinate_names();  // table order

}  // namespace brdftab
