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
// another leaf without being one of its nodes (a hanging node) is not
// stored: its value is that leaf's interpolant at it, computed when the
// table is read, in an order where every value it needs is known
// (AdaptiveLayout::resolve_hanging).  The refinement keeps the tree
// balanced: two leaves whose boxes meet in a set of two or more dimensions
// are nested there (one is at least as fine as the other along every axis
// of that set).  Then every leaf that holds a hanging node gives it the same
// value, and the table is continuous across every face that is not a
// declared jump, for both patch orders and whatever rounding the stored
// values had (docs/adaptive.md, "Continuity").
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
    // Hanging nodes: with H = hanging_leaf.size() and N values in all, values
    // N - H .. N - 1 are not stored; value N - H + j is leaf hanging_leaf[j]'s
    // interpolant at that node, computed for j = 0, 1, ... (resolve_hanging).
    std::vector<std::uint32_t> hanging_leaf;

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
    // Values N - H .. N - 1 of `values` (N = value_count) from the others,
    // in order (docs/format.md "Adaptive tables"): the node's position from
    // the first leaf_nodes entry that holds it, its coordinate u in the
    // constraining leaf rounded to a multiple of 2^-32 (exact: the position
    // is dyadic in that leaf), then that leaf's interpolant with every
    // nonzero weight on a value already known.  InputError (prefixed by
    // `where`) when a hanging node is listed by no leaf, lies outside its
    // constraining leaf, or needs a value not yet computed.
    void resolve_hanging(double* values, std::size_t value_count, const std::string& where) const;
    std::size_t stored_count(std::size_t value_count) const { return value_count - hanging_leaf.size(); }
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
    std::size_t value_count() const { return data.value.size(); }  // every node's, hanging ones included
    std::size_t stored_count() const { return layout.stored_count(data.value.size()); }
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
    std::size_t max_values = 65536;  // stop refining before more nodes (stored and hanging)
    int max_level = 24;              // dyadic halvings per axis, at most
    std::vector<int> initial_level;  // per axis (empty: 0): uniform start
    std::vector<std::vector<AdaptiveBreakpoint>> breakpoints;  // per axis (may be empty)
    // Continuity across faces that are not declared jumps: the balance rule
    // and hanging nodes (false: every node stored with its own value).
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
    std::size_t rounds = 0, evaluations = 0, leaves = 0;
    std::size_t values = 0;  // every node's value (stored ones and hanging ones)
    // Nodes whose values are interpolated from a neighbouring leaf (not
    // stored), and the leaf halvings the balance rule added.
    std::size_t hanging_nodes = 0, balance_splits = 0;
    // Largest |value - leaf interpolant| over every hanging node and every
    // leaf whose closed box holds it (rounding only: the balance makes them
    // agree).
    double continuity_residual = 0;
    double estimated_max = 0;        // largest leaf probe error, in the measure
    std::size_t leaves_over_target = 0;
    bool budget_hit = false;
    std::size_t stored() const { return values - hanging_nodes; }
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
