// node_placement.h — explicit nodes that equidistribute the measured
// interpolation error along one axis (`brdftab plan --place-nodes`,
// docs/planning.md "Node placement that follows the physics").
//
// Piecewise-linear interpolation of f on an interval of width h errs by
// about C h^p with C = |f''|/8 and p = 2.  Given, for every interval i of a
// fine pilot line, its measured error e_i and width h_i, the local constant
// is C_i = e_i / h_i^p.  The largest error over the axis is smallest when
// every interval has the same error E (equidistribution): h(x) = (E/C(x))^(1/p),
// i.e. a node density proportional to C(x)^(1/p).  With N nodes that gives
//   E = (integral of C^(1/p) dx / (N - 1))^p,
// against max C (span/(N - 1))^p for N nodes uniform in x: the placement wins
// by the factor (max C^(1/p) / mean C^(1/p))^p.
//
// The nodes are written as spacing = "explicit", which the lookup library
// interpolates linearly in x between nodes, so the errors here are those of
// interpolation in x (not in an axis' warped coordinate).  Library code: no
// printing.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace brdftab {

// One pilot line along the axis: node positions and values, and probe
// positions (inside the node intervals) and the directly evaluated values
// there.
struct PlacementLine {
    std::vector<double> node_x, node_f;
    std::vector<double> probe_x, probe_f;
};

// The largest |error| of linear interpolation in x between the line's nodes,
// per node interval, over all lines and probes (relative: divided by
// max(|f|, floor)).  All lines must share node_x.
std::vector<double> local_linear_errors(const std::vector<PlacementLine>& lines, bool relative,
                                        double floor);

struct NodePlacement {
    std::vector<double> values;    // the placed nodes, strictly increasing, exact ends
    double predicted_max = 0;      // predicted max error of interpolation on them
    double uniform_max = 0;        // the same for `count` nodes uniform in x
};

// Places `count` (>= 2) nodes over [node_x.front(), node_x.back()] for the
// per-interval errors `local_error` of the pilot nodes `node_x` (one per
// interval) and the error order p (2 for linear interpolation).  Intervals
// without measurable error get 1/1000 of the largest density, so no cell
// grows without bound.  Throws InputError on inconsistent input.
//
// The prediction takes, per cell, the model's (integral of C^(1/p) dx)^p and,
// for a cell inside one pilot interval, also that interval's error scaled by
// (H/h)^refine_order: with refine_order below p (the axis' measured order,
// e.g. 1 near a square-root edge) it does not promise the h^2 gain of a
// smooth function where the pilot did not resolve one.  0: refine_order = p.
NodePlacement place_nodes(const std::vector<double>& node_x,
                          const std::vector<double>& local_error, double order,
                          std::size_t count, double refine_order = 0);

// ---- applied to a chosen plan (`brdftab plan --place-nodes`)

struct TablePilot;
struct Candidate;
struct PlanTarget;

// What place_plan_nodes did to one axis.
struct PlacedAxis {
    std::string table, axis;
    std::size_t count = 0;
    double predicted_max = 0;  // on the placed nodes
    double uniform_max = 0;    // the same model, count nodes uniform in x
    double spacing_max = 0;    // the planner's fit for the axis' own spacing at count
};

// For every planned axis of every table of `plan` (not explicit in the spec),
// explicit nodes with the plan's count that equidistribute the pilot's
// measured error (the target's measure), kept only where they are predicted
// to beat the axis' own spacing at that count; the plan's
// explicit_values are set accordingly.  Linear interpolation only
// (InputError for a Catmull-Rom target).
std::vector<PlacedAxis> place_plan_nodes(const std::vector<TablePilot>& pilots, Candidate& plan,
                                         const PlanTarget& target);

}  // namespace brdftab
