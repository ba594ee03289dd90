/*
 * node_parallel.cl — the flat node-parallel launch of a quadrature sum
 * (node_parallel.h describes the launch and the model's contract).
 *
 * A template: the program's generated prelude binds the hooks
 *     BT_HOOK_STATE_SIZE  values of a work item's state
 *     bt_hook_count, bt_hook_prepare, bt_hook_term, bt_hook_finish
 *                         the model's count, prepare, term and finish functions
 */

/* prepare: one work item per work item w of a sub-launch, its state at
 * state[(w - first_work) * BT_HOOK_STATE_SIZE + ...] (the copy unrolled, as
 * measured) */
__kernel void bt_node_prepare(__global const REAL* points, uint stride, __global const int* options,
                              uint n_options, int quantity, uint method, uint key0, uint key1,
                              __global const uint* work_cell, __global const uint* work_batch,
                              uint first_work, uint n_work, __global REAL* state)
{
    const uint gid = (uint)get_global_id(0);
    if (gid >= n_work) return;
    const uint w = first_work + gid;
    REAL p[BT_MAX_POINT];
    bt_load_point(points, w, BT_KERNEL_STRIDE_(stride), p);
    BT_KERNEL_LOAD_OPTIONS_(o, options, n_options)
    bt_sampler s = bt_work_sampler(key0, key1, work_cell[w], work_batch[w], BT_KERNEL_METHOD_(method));
    REAL st[BT_HOOK_STATE_SIZE];
    bt_hook_prepare(p, o, BT_KERNEL_QUANTITY_(quantity), &s, st);
#pragma unroll
    for (uint i = 0; i < (uint)(BT_HOOK_STATE_SIZE); ++i)
        state[(size_t)gid * (BT_HOOK_STATE_SIZE) + i] = st[i];
}

/* Global node `node` belongs to work item w = node_item[node], where it is
 * term number node - node_offset[w]: copies w's state into `st` (whole,
 * unrolled) and returns that term number.  Shared with node_split.cl. */
BT_INLINE int bt_node_state(uint node, __global const uint* node_item, __global const uint* node_offset,
                            uint first_work, __global const REAL* state, REAL* st)
{
    const uint w = node_item[node];
    __global const REAL* my_state = state + (size_t)(w - first_work) * (BT_HOOK_STATE_SIZE);
#pragma unroll
    for (uint i = 0; i < (uint)(BT_HOOK_STATE_SIZE); ++i) st[i] = my_state[i];
    return (int)(node - node_offset[w]);
}

/* The term of global node `node` from its work item's state. */
BT_INLINE REAL bt_node_term(uint node, const int* o, int quantity, __global const uint* node_item,
                            __global const uint* node_offset, uint first_work,
                            __global const REAL* state)
{
    REAL st[BT_HOOK_STATE_SIZE];
    const int k = bt_node_state(node, node_item, node_offset, first_work, state, st);
    return bt_hook_term(st, o, quantity, k);
}

__kernel void bt_node(__global const int* options, uint n_options, int quantity,
                      __global const uint* node_item, __global const uint* node_offset, uint first_work,
                      uint first_node, uint n_nodes, __global const REAL* state, __global REAL* scratch)
{
    const uint item = (uint)get_global_id(0);
    const uint gid = bt_padding_item(item, n_nodes);
    const uint node = first_node + gid;
    BT_KERNEL_LOAD_OPTIONS_(o, options, n_options)
    const REAL term = bt_node_term(node, o, BT_KERNEL_QUANTITY_(quantity), node_item, node_offset,
                                   first_work, state);
    if (item < n_nodes) scratch[gid] = term;
}

__kernel void bt_node_sum(__global const REAL* points, uint stride, __global const int* options,
                          uint n_options, int quantity, uint method, uint key0, uint key1,
                          __global const uint* work_cell, __global const uint* work_batch,
                          __global const uint* node_offset, uint first_node, uint first_work, uint n_work,
                          __global const REAL* scratch, __global ACCUM* out_mean, __global ACCUM* out_m2)
{
    const uint gid = (uint)get_global_id(0);
    if (gid >= n_work) return;
    const uint w = first_work + gid;
    REAL p[BT_MAX_POINT];
    bt_load_point(points, w, BT_KERNEL_STRIDE_(stride), p);
    BT_KERNEL_LOAD_OPTIONS_(o, options, n_options)
    bt_sampler s = bt_work_sampler(key0, key1, work_cell[w], work_batch[w], BT_KERNEL_METHOD_(method));
    const int q_ = BT_KERNEL_QUANTITY_(quantity);
    const int n = bt_hook_count(p, o, q_, &s);
    const uint stored = node_offset[w + 1u] - node_offset[w];
    __global const REAL* x = scratch + (node_offset[w] - first_node);
    REAL sum = R(0.0);
    for (int k = 0; k < n; ++k) {
        const int have = (uint)k < stored;
        REAL v = have ? x[k] : R(0.0);
        /* not laid out by the host, or NaN (a split kernel's node of the
         * other form, or a NaN term): computed here */
        if (!have || !(v == v)) {
            REAL st[BT_HOOK_STATE_SIZE];
            bt_hook_prepare(p, o, q_, &s, st);
            v = bt_hook_term(st, o, q_, k);
        }
        sum += v;
    }
    ACCUM value = (ACCUM)bt_hook_finish(p, o, q_, &s, sum);
    ACCUM mean = 0, m2 = 0;
    BT_WELFORD_ADD(mean, m2, value, 1u);
    out_mean[w] = mean;
    out_m2[w] = m2;
}
