/*
 * node_parallel.h — node-parallel launch of a quadrature sum (the engine's
 * "node-parallel" path, host/engine/launch/node_parallel_*.cpp).
 *
 * The usual kernel (estimate.cl) runs a
 * quadrature rule as a loop inside one work item.  When that loop's trip
 * count depends on the point (hfunction's H: ~60-200 trapezoid nodes), PoCL's
 * loop over the work items of a group wraps it, is not innermost, and stays
 * scalar.  A model whose value is a plain in-order sum
 *     value = finish(sum_{k = 0}^{count - 1} term(k))
 * can opt in per quantity (QuantityInfo::node_parallel,
 * host/models/registry.h) with four functions of its kernel header and the
 * size of a per-work-item state:
 *     int  count_fn  (const REAL* p, const int* o, int quantity, const bt_sampler* s);
 *     void prepare_fn(const REAL* p, const int* o, int quantity, const bt_sampler* s,
 *                     REAL* state);                  (state_size values)
 *     REAL term_fn   (const REAL* state, const int* o, int quantity, int k);
 *     REAL finish_fn (const REAL* p, const int* o, int quantity, const bt_sampler* s,
 *                     REAL sum);
 * whose composition, with `sum` a REAL that starts at 0 and adds term(k) for
 * k = 0, 1, ..., count - 1, is the sample function's value bit for bit
 * (the model's serial loop must compute that very composition: see hf_h in
 * kernels/models/hfunction.h).  The state holds what every term of a work
 * item shares (hfunction: Psi's coefficients and moments, the grid), so
 * that the per-node kernel neither recomputes it nor holds the loops and
 * divisions that compute it.  The work is three kernels, no barrier (plain
 * OpenCL C in node_parallel.cl; the names below are its hooks' roles):
 *
 *   prepare_kernel  one work item per work item w of a sub-launch: its state,
 *                   stored in state[(w - first_work) * state_size + ...].
 *   node_kernel     one work item per node of a sub-launch: global node number
 *                   first_node + gid, which belongs to work item
 *                   w = node_item[first_node + gid] and is its node
 *                   k = first_node + gid - node_offset[w]; stores term(k) in
 *                   scratch[gid].  No loop around the term, so the work-item
 *                   loop is innermost and can be vectorised.
 *   sum_kernel      one work item per work item w of the sub-launch: adds its
 *                   count(w) terms in order k = 0, 1, ... from scratch,
 *                   applies finish, and stores mean and M2 with the same
 *                   one-sample Welford update as the usual kernel (M2 = 0 for
 *                   a finite value).
 *
 * The host lays the nodes out (node_offset: the exclusive prefix sum of the
 * counts, node_item: the work item of every node) from the count function
 * compiled for the host.  The device recomputes the count in the sum kernel
 * and trusts only its own: a node the host did not lay out (a float build
 * that rounds the count up) is computed there, in its place in the order; a
 * laid-out node beyond the device's count is never read.  Every term is the
 * same function of the same inputs as in the serial loop, stored exactly
 * (scratch and state are REAL, the type of the loop's values), and added in
 * the same order, so the result has the usual kernel's bits
 * (tests/test_node_parallel.cpp).
 */
#ifndef BRDFTAB_NODE_PARALLEL_H
#define BRDFTAB_NODE_PARALLEL_H

#include "estimator.h"


/* Split terms (node_split.cl, with the flat launch above).
 * A term with two forms on either side of a branch (hfunction: the series
 * of K below t = 1/2, K itself above) costs both forms in a vectorised node
 * kernel, which runs both sides of a branch for every lane.  A model may
 * name the forms apart,
 *     REAL term_first_fn (state, o, quantity, k)   term(k) where k is of the
 *     REAL term_second_fn(state, o, quantity, k)   form, else NaN
 * and a host function that says how many leading nodes of a work item are
 * of the first form (NodeParallelFunctions::host_split).  The engine then
 * runs, instead of node_kernel, first_kernel over the list of first-form
 * nodes and second_kernel over the others (node_list[list_first + gid]:
 * global node numbers; same other arguments as node_kernel), each storing
 * at the node's own scratch slot.  A node the host put on the wrong side
 * comes back NaN, and the sum kernel computes it with term_fn: the host's
 * split is a guess that changes no value. */

/*
 * Nested sums (nested_node_parallel.cl).  A tensor rule with
 * data-dependent breakpoints on both levels (oren-nayar's theta_a nodes, each
 * with its own phi_a sub-intervals) is a sum of *groups* (outer nodes) of
 * nodes: value = finish(acc), where acc (acc_size values, from 0) takes
 * group g's contribution for g = 0, 1, ..., count - 1 in order.  A group's
 * contribution is in two steps: group_reduce adds its nodes' terms (n_terms
 * values each) in its own order into n_partial values, and group_add adds
 * those to acc.  The model names:
 *     int  count_fn        (p, o, quantity, s)  groups; 0: no nested sum
 *                          (the sum kernel then returns sample_fn's value)
 *     void table_fn        (int entry, REAL* values)  entry 0..table_entries-1
 *                          of a table the device computes once per program
 *                          (table_size values per entry; oren-nayar: the
 *                          Gauss-Legendre rule of n = entry nodes)
 *     void prepare_fn      (p, o, quantity, s, BT_GLOBAL const REAL* table,
 *                           REAL* item_state)
 *     int  group_prepare_fn(BT_GLOBAL const REAL* item_state, o, quantity, g,
 *                           BT_GLOBAL REAL* group_state)   returns the group's
 *                           nodes; writes what its nodes read (in place)
 *     void term_fn_setup   (BT_GLOBAL const REAL* item_state,
 *                           BT_GLOBAL const REAL* group_state,
 *                           BT_GLOBAL REAL* node_x)   each of the group's
 *                           nodes' own value x (oren-nayar: its phi_a), in
 *                           the group's node order (the name is term_fn's
 *                           with "_setup" appended)
 *     void term_fn         (BT_GLOBAL const REAL* item_state,
 *                           BT_GLOBAL const REAL* group_state, o, quantity,
 *                           REAL x, REAL* terms)
 *     void group_reduce_fn (item_state, group_state, o, quantity,
 *                           BT_GLOBAL const REAL* terms, REAL* partial)
 *     void group_add_fn    (item_state, group_state, o, quantity,
 *                           BT_GLOBAL const REAL* partial, REAL* acc)
 *     REAL finish_fn       (p, o, quantity, s, const REAL* acc)
 *     REAL sample_fn       (p, o, quantity, s)  the model's sample function
 * The host lays out every work item's groups from the count function
 * compiled for the host (QuantityInfo::node_parallel.host_count); the
 * device counts each group's nodes (the group kernel), the host reads the
 * counts back and lays the nodes out (prefix sums; the chunk kernel writes
 * every node's group).  A work item whose device group count
 * differs from the host's (rounding, in float) runs sample_fn instead.
 * The host splits a launch into *blocks* of whole work items (their item
 * and group states), and a block's nodes into *sub-launches* of whole
 * groups (the node scratch).  Indices of work items and groups are local to
 * a block, indices of nodes to a sub-launch:
 *   table_kernel    one work item per table entry, once per program (the
 *                   engine keeps the table with the program's kernels).
 *                   Oren-nayar's Gauss-Legendre rules come from it: computed
 *                   in every work item's prepare (Newton on P_n, PoCL's
 *                   scalar cos) they took 14 % of the device time at 12
 *                   nodes (docs/benchmarks.md, "Node-parallel quadrature").
 *                   The same function in the same program gives the same
 *                   bits (test_node_parallel compares with the usual
 *                   kernel, which computes the rule inline).
 *   prepare_kernel  one work item per work item of the block: item state.
 *   group_kernel    one work item per group G of the block, of work item
 *                   i = group_item[G], its number G - item_group[i]: group
 *                   state and node count group_nodes[G].
 *   chunk_kernel    one work item per group G of a sub-launch (G from
 *                   first_group), after the host has laid out the nodes
 *                   (group_node: the exclusive prefix sum of the block's
 *                   device counts): node_group[k] = G for its nodes k,
 *                   and node_x[k] (term_fn_setup), k counted from the
 *                   sub-launch's first node group_node[first_group].
 *   node_kernel     one work item per node of a sub-launch: group
 *                   G = node_group[gid] and x = node_x[gid] (plain loads,
 *                   consecutive in gid); terms at scratch[n_terms * gid].
 *                   Loop-free: vectorises.  (x, not the node's number
 *                   k - group_node[G], which would take more gathers per node.)
 *   reduce_kernel   one work item per group of a sub-launch: its partial
 *                   sums from its nodes' terms, at group_partial[n_partial * G].
 *   sum_kernel      one work item per work item of the block: acc from its
 *                   groups' partial sums in order, then finish; mean and M2
 *                   as in the usual kernel.
 * Only the group kernel's counts come back to the host (one read per block);
 * a block's sub-launches and its sum are queued without waiting.  The
 * per-group reduction is a kernel over groups, not part of the sum kernel's
 * loop, so that it runs on every core even when a sub-launch holds few work
 * items (docs/benchmarks.md, "Node-parallel quadrature").
 * Every term and every addition is the serial loop's (the model's serial
 * code must call the same functions), and partial sums are stored exactly
 * (REAL), so the bits are the usual kernel's.
 */
/* The table of a nested sum whose prepare reads none (one zero). */
BT_INLINE void bt_node_no_table(int entry, REAL* values)
{
    (void)entry;
    values[0] = R(0.0);
}


#endif /* BRDFTAB_NODE_PARALLEL_H */
