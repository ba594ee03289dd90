// adaptive_table.h — a table whose resolution follows its local error
// (docs/format.md "Adaptive tables", docs/adaptive.md).
//
// Domain: the table's normalised warped coordinates t in [0, 1]^d (each
// axis' unwarp, grid.h).  A k-d tree cuts it into boxes (leaves); each leaf
// is a small tensor patch of n = 2^m + 1 nodes per axis, interpolated
// multilinearly inside.  Inside each interval between declared breakpoints
// the cuts are dyadic (a cut halves a box along one axis), so the node sets
// of neighbouring leaves are nested on their common face.  A breakpoint is a
// cut at a given t that every leaf respects (a known kink: the function
// stays continuous there), or a declared jump: the leaves on its two sides
// then hold their own one-sided node values and no continuity is enforced
// across it.
//
// Continuity elsewhere: a node of one leaf that lies on the closed box of
// another leaf without being one of its nodes (a hanging node) takes that
// leaf's interpolated value; this is iterated to a fixed point (nested
// grids: the common trace of two leaves on a face is then the interpolant
// on the coarser node set in each direction), so the table is continuous
// across every face that is not a declared jump.  Order 2: the same where
// one leaf's face nodes refine the other's along every tangent axis (its
// triples nest in the coarse ones); a 3-D face between leaves finer along
// different tangent axes can keep a gap (docs/adaptive.md, "Continuity").
//
// Evaluation descends the tree (flat arrays), then interpolates in the leaf:
// no allocation.  Library code: no printing.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "host/core/grid.h"
#include "host/core/table.h"

namespace brdftab {

// One axis' interpolation stencil at patch coordinate u in [0, n - 1] (node
// units): returns the first node index i; w[0..order] are the weights of
// nodes i .. i + order.  Order 1: i = min(floor(u), n - 2), s = u - i,
// w = (1 - s, s).  Order 2: i = 2 min(floor(u / 2), (n - 1)/2 - 1),
// s = u - i in [0, 2], w = ((s-1)(s-2)/2, s(2-s), s(s-1)/2).
std::size_t adaptive_stencil(double u, std::size_t n, int order, double* w);

// The tree and the leaves' node lists of an adaptive table (the datasets of
// docs/format.md "Adaptive tables").  Values live in AdaptiveTable::data.
struct AdaptiveLayout {
    std::size_t dims = 0;
    std::size_t patch_nodes = 3;  // n, nodes per axis of every leaf
    int patch_order = 1;          // 1: multilinear, 2: piecewise quadratic per axis
    // Tree node k: split_axis[k] >= 0: an inner node cutting axis
    // split_axis[k] at t = split_t[k], children lower[k] (t < split_t) and
    // upper[k] (t >= split_t); split_axis[k] = -1: a leaf, lower[k] = its
    // leaf index.  Node 0 is the root.
    std::vector<std::int32_t> split_axis;
    std::vector<double> split_t;
    std::vector<std::uint32_t> lower, upper;
    // Leaf l's box: [box[(l*dims + a)*2], box[(l*dims + a)*2 + 1]] on axis a.
    std::vector<double> box;
    // Leaf l's n^dims nodes, row-major (last axis fastest): indices into the
    // values, node (i_0, ..., i_{d-1}) at t_a = lo_a + i_a (hi_a - lo_a)/(n-1).
    std::vector<std::uint32_t> leaf_nodes;

    std::size_t leaf_count() const { return dims ? box.size() / (2 * dims) : 0; }
    std::size_t nodes_per_leaf() const;
    // Leaf containing t (each t_a clamped to [0, 1]).
    std::size_t leaf_of(const double* t) const;
    // The leaf's interpolant (of patch_order) of `values` at t (t clamped
    // to the leaf's box).
    double eval_leaf(std::size_t leaf, const double* t, const double* values) const;
    double eval(const double* t, const double* values) const {
        return eval_leaf(leaf_of(t), t, values);
    }
    // InputError (prefixed by `where`) unless the arrays are consistent:
    // sizes, patch_order 1 or 2 (2 with an odd patch_nodes >= 3), child
    // indices in range and forming a tree over every leaf, boxes
    // inside [0, 1] with lo < hi, node indices below value_count.
    void check(std::size_t value_count, const std::string& where) const;
};

// A table in the adaptive representation: `data` holds the provenance, the
// axes (their warps; counts and node lists as a tensor table's would be, used
// only through warp/unwarp) and one value (and stderr) per stored node.
struct AdaptiveTable {
    TableData data;
    AdaptiveLayout layout;
    // Axis breakpoints in t (each axis' list, increasing, within (0, 1)) and
    // which of them are jumps: provenance (the layout already respects them).
    std::vector<std::vector<double>> breakpoints_t;
    std::vector<std::vector<bool>> breakpoint_jump;
    double target = 0;       // the refinement's target, in its measure
    bool absolute = true;    // measure of `target`
    double estimated_max = 0;  // the refinement's largest probe error at the end

    // t of a point in axis units (dependent axes through the axis they
    // depend on), clamped to [0, 1].
    void to_t(const double* x, double* t) const;
    // Axis values of normalised coordinates t (inverse of to_t).
    void to_x(const double* t, double* x) const;
    // Value at a point in axis units.
    double eval(const double* x) const;
    std::size_t value_count() const { return data.value.size(); }
};

// A declared breakpoint of one axis, in t.
struct AdaptiveBreakpoint {
    double t = 0;
    bool jump = false;  // false: a kink (the function is continuous there)
};

struct AdaptiveBuildOptions {
    std::size_t patch_nodes = 3;  // 2^m + 1, m in 1..3
    int patch_order = 1;          // 1 (multilinear) or 2 (piecewise quadratic per axis)
    double target = 1e-3;         // largest probe error a leaf may keep
    bool absolute = true;         // else relative to max(|f|, floor)
    double floor = 0;             // relative measure: 0 = rel_floor_factor x max |f| seen
    double rel_floor_factor = 1e-3;
    // A leaf passes when its largest probe error is <= safety x target (the
    // midpoint probes see about half the largest error of a kink inside a
    // cell).
    double safety = 0.5;
    std::size_t max_values = 65536;  // stop refining before more stored nodes
    int max_level = 24;              // dyadic halvings per axis, at most
    std::vector<int> initial_level;  // per axis (empty: 0): uniform start
    std::vector<std::vector<AdaptiveBreakpoint>> breakpoints;  // per axis (may be empty)
    // Enforce continuity across faces that are not declared jumps.
    bool continuity = true;
};

// Values of `count` points t (point k at t + k*dims, normalised warped
// coordinates; a point on the lower side of a declared jump is moved inside
// by 1e-9 of its interval), into value[k] and, when it is not null,
// stderr_[k] (sized by the caller).  Called once per refinement round with
// every new point of that round.
using AdaptiveBatchFn = std::function<void(std::size_t count, const double* t, double* value,
                                           double* stderr_)>;

// What the refinement did (for the CLI's summary and the docs' figures).
struct AdaptiveBuildReport {
    std::size_t rounds = 0, evaluations = 0, leaves = 0, values = 0;
    std::size_t hanging_nodes = 0, continuity_sweeps = 0;
    double continuity_residual = 0;  // largest |constraint - value| left (absolute)
    // Nodes that hang in two leaves or more (3-D and up: edges where leaves
    // refined along different axes meet): only the coarsest leaf's
    // constraint is enforced (enforcing all ties the interpolants together
    // far around); tie_crack is the largest gap left at such a node.
    std::size_t tied_nodes = 0;
    double tie_crack = 0;
    double estimated_max = 0;        // largest leaf probe error, in the measure
    std::size_t leaves_over_target = 0;
    bool budget_hit = false;
};
using AdaptiveRoundFn = std::function<void(const AdaptiveBuildReport&)>;

// Refines from the initial tree until every leaf passes or the next round
// would exceed max_values; fills layout and values (stderr_ too when the
// batch function gives them: `with_stderr`).  Deterministic: the same
// options and function give bit-identical results.  Throws InputError for
// bad options.
AdaptiveBuildReport build_adaptive(std::size_t dims, const AdaptiveBuildOptions& options,
                                   const AdaptiveBatchFn& batch, bool with_stderr,
                                   AdaptiveLayout& layout, std::vector<double>& values,
                                   std::vector<double>& stderr_,
                                   const AdaptiveRoundFn& round = nullptr);

}  // namespace brdftab
