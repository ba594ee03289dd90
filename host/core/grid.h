// grid.h — table axes: node placement ("spacing" / warps) and its inverse.
//
// An axis maps a normalised coordinate t in [0, 1] to a value x in user units
// (degrees for angles).  Nodes sit at t_k = k / (count - 1).  The inverse map
// x -> t is what an interpolating reader needs to find the cell of an off-grid
// point, so every spacing here has an exact closed-form inverse.
//
// Spacings (the enum and its names are in vocabulary.h):
//   linear     x = min + t (max - min)
//   cos        uniform in cos(x), x in degrees within [0, 180]:
//              x = acos(cos(min) + t (cos(max) - cos(min)))
//   log        geometric, needs 0 < min < max: x = min (max/min)^t
//   quadratic  dense near min: x = min + t^2 (max - min)
//   explicit   user-given strictly increasing node list; the inverse is
//              piecewise linear between nodes.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "vocabulary.h"

namespace brdftab {

struct Axis {
    std::string name;        // "theta_i", "phi_d", "mu_i", "alpha", ...
    std::string unit;        // "deg", "1", ...
    double min = 0, max = 0;
    std::size_t count = 0;
    Spacing spacing = Spacing::Linear;
    std::vector<double> values;  // node positions, filled by make_axis()

    // x(t) and t(x); t(x) is clamped to [0, 1] only by the caller.
    double warp(double t) const;
    double unwarp(double x) const;
};

// Build an axis and fill its nodes.  For Spacing::Explicit pass the nodes in
// `explicit_values` (min/max/count are then taken from them).  Throws
// InputError for count < 2, min >= max, log with min <= 0, cos outside
// [0, 180] degrees, or non-increasing explicit nodes.
Axis make_axis(const std::string& name, const std::string& unit, double min,
               double max, std::size_t count, Spacing spacing,
               const std::vector<double>& explicit_values = {});

// Number of cells of a table with these axes (the product of their node
// counts), or InputError, prefixed by `where`, when the product overflows
// (4 axes of 65 536 nodes wrap to 0 in 64 bits).  Every cell count of the
// library goes through it: Grid, TableData, the HDF5 reader and writer, the
// lookup table and the EXR export.
std::size_t checked_cell_count(const std::vector<Axis>& axes, const std::string& where = {});

// A Cartesian product of axes, row-major with the last axis fastest.
class Grid {
public:
    explicit Grid(std::vector<Axis> axes);
    const std::vector<Axis>& axes() const { return axes_; }
    std::size_t cell_count() const { return cell_count_; }
    // Multi-index of a flat cell index.
    std::vector<std::size_t> index_of(std::size_t flat) const;
    // Axis values (user units) of a flat cell index, one per axis.
    std::vector<double> coordinates(std::size_t flat) const;

private:
    std::vector<Axis> axes_;
    std::size_t cell_count_ = 1;
};

}  // namespace brdftab
