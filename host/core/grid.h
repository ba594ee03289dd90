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
//   log-complement
//              geometric in the distance to a pivot P outside [min, max]:
//              x = P - (P - min) ((P - max)/(P - min))^t.  With P above max the
//              nodes crowd towards max (e.g. 1 - c for a scattering albedo c
//              near 1), with P below min towards min.
//   critical   a cosine axis (mu_i) whose node `critical_node` sits exactly on
//              the cosine of the critical angle of total internal reflection,
//              mu_c(eta) = sqrt(1 - r^2) with r = 1/eta for light from inside
//              (range <= 0) and r = eta from outside (range >= 0), r the ratio
//              of the far side's index to the near side's.  Each side of it is
//              spaced on its own, node distances from the kink growing as
//              s^grading (Fresnel's reflectance rises like sqrt(|mu| - mu_c)
//              on the transmitting side; roughness rounds the kink on both).  The kink position is clamped so that each
//              side keeps at least kCriticalMinSide of its share of the range
//              (eta -> 1 moves mu_c to 0, out of a range that stops short of
//              grazing): continuous in eta, never a zero-width cell.  eta is a
//              fixed number (critical_eta; the node list is then an ordinary
//              one) or another axis of the table (depends_on = "eta"): the
//              grid is then not a tensor product in x, only in t, and
//              `values` holds the nodes' t_k = k/(count-1), not positions;
//              use warp_at / unwarp_at / Grid::coordinates.
#pragma once

#include <cstddef>
#include <limits>
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
                                 // (t_k for an axis with depends_on, see above)

    // log-complement: the pivot P (outside [min, max]).
    double pivot = std::numeric_limits<double>::quiet_NaN();
    // critical: the node on mu_c, the grading power of the transmitting side,
    // and where eta comes from (a fixed value, or the axis named depends_on).
    std::size_t critical_node = 0;
    double grading = 1;
    double critical_eta = std::numeric_limits<double>::quiet_NaN();
    std::string depends_on;

    // x(t) and t(x); t(x) is clamped to [0, 1] only by the caller.  On an
    // axis with depends_on they throw Error (the map needs eta: use the _at
    // forms).
    double warp(double t) const;
    double unwarp(double x) const;
    // The same at a given value of the coordinate the axis depends on (eta);
    // `dep` is ignored by axes without depends_on.
    double warp_at(double t, double dep) const;
    double unwarp_at(double x, double dep) const;
    bool dependent() const { return !depends_on.empty(); }
    // critical: the kink's position for this eta (after the clamp above).
    double critical_position(double eta) const;
};

// Where a coordinate falls on an axis, for a slice fixed at it (`export
// --slice`, `plot --slice`, docs/cli-table-commands.md "Slices"): at a node
// (within 1e-9 of the larger of the node's magnitude and the axis span), or
// between nodes `node` and `node + 1` at fraction `s` of the warped
// coordinate t, the weights of the library's linear interpolation.  `dep`:
// the value of the coordinate a dependent axis depends on (ignored
// otherwise).  Throws InputError outside [min, max].
struct AxisPosition {
    std::size_t node = 0;
    double s = 0;
    bool at_node = true;
};
AxisPosition axis_position(const Axis& a, double x, double dep = 0);
// "eta = 1.5 lies between the nodes 1.47 and 1.58: interpolated linearly
// (weights 0.61, 0.39)"; empty at a node.  Node values with 6 digits.
std::string slice_note(const Axis& a, double x, const AxisPosition& p);

// Each side of a critical axis keeps at least this fraction of the width it
// would have with the kink at its uniform place.  Small, so that the kink
// stays on its node over a wide range of eta (with the kink node in the
// middle of [-1, -0.02]: 1.0013 <= eta <= 4.1), while a side never shrinks
// to zero width (its cells stay apart and the inverse exact).
extern const double kCriticalMinSide;  // 1/16, grid.cpp

// Critical spacing: the node index of the kink for `count` nodes and a
// fraction in (0, 1), within [1, count - 2].
std::size_t critical_node_for(std::size_t count, double fraction);

// Build a critical axis (spacing "critical").  `eta_axis` non-empty: eta
// comes from that axis (values = t_k); else from `eta`, and the nodes are
// positions.  Throws InputError for count < 3, a range not within [-1, 0] or
// [0, 1], grading outside [1, 4], or nodes that coincide.
Axis make_critical_axis(const std::string& name, double min, double max, std::size_t count,
                        std::size_t critical_node, double grading, double eta,
                        const std::string& eta_axis = {});
// Check that a dependent axis' nodes strictly increase at each of these
// values of the coordinate it depends on (InputError otherwise).
void check_dependent_nodes(const Axis& a, const std::vector<double>& dep_values);

// Build an axis and fill its nodes.  For Spacing::Explicit pass the nodes in
// `explicit_values` (min/max/count are then taken from them).  Throws
// InputError for count < 2, min >= max, log with min <= 0, cos outside
// [0, 180] degrees, or non-increasing explicit nodes.
Axis make_axis(const std::string& name, const std::string& unit, double min,
               double max, std::size_t count, Spacing spacing,
               const std::vector<double>& explicit_values = {});
// log-complement with its pivot (InputError when it lies within [min, max]).
Axis make_log_complement_axis(const std::string& name, const std::string& unit, double min,
                              double max, std::size_t count, double pivot);

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
    // Axis values (user units) of a flat cell index, one per axis; an axis
    // with depends_on is placed at its cell's value of that axis.
    std::vector<double> coordinates(std::size_t flat) const;
    std::vector<double> coordinates(const std::vector<std::size_t>& index) const;
    // A point from normalised coordinates t (one per axis), each x clamped to
    // its axis' [min, max]: uniform in t means uniform over the grid's cells.
    std::vector<double> point_at(const std::vector<double>& t) const;
    // Index of the axis that axis d depends on, or -1.
    int dependency(std::size_t d) const { return dependency_[d]; }

private:
    std::vector<Axis> axes_;
    std::vector<int> dependency_;
    std::size_t cell_count_ = 1;
};

}  // namespace brdftab
