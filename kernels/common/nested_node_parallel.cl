/*
 * nested_node_parallel.cl — the nested node-parallel launch of a sum of
 * groups of nodes (node_parallel.h, "Nested sums", describes the launch, its
 * seven kernels and the model's contract).
 *
 * A template: the program's generated prelude binds the hooks
 *     BT_HOOK_TABLE_ENTRIES, BT_HOOK_TABLE_SIZE, BT_HOOK_ITEM_STATE_SIZE,
 *     BT_HOOK_GROUP_STATE_SIZE, BT_HOOK_TERMS, BT_HOOK_PARTIALS, BT_HOOK_ACC_SIZE
 *         the sizes (table entries; values per entry, per work item's and
 *         group's state, per node's terms, per group's partial sums, of acc)
 *     bt_hook_table, bt_hook_count, bt_hook_prepare, bt_hook_group_prepare,
 *     bt_hook_term_setup, bt_hook_term, bt_hook_group_reduce, bt_hook_group_add,
 *     bt_hook_finish, bt_hook_sample
 *         the model's functions
 */
__kernel void bt_node_table(__global REAL* table)
{
    const uint gid = (uint)get_global_id(0);
    if (gid >= (uint)(BT_HOOK_TABLE_ENTRIES)) return;
    REAL t[BT_HOOK_TABLE_SIZE];
    bt_hook_table((int)gid, t);
    for (uint i = 0; i < (uint)(BT_HOOK_TABLE_SIZE); ++i)
        table[(size_t)gid * (BT_HOOK_TABLE_SIZE) + i] = t[i];
}

__kernel void bt_node_prepare(__global const REAL* points, uint stride, __global const int* options,
                              uint n_options, int quantity, uint method, uint key0, uint key1,
                              __global const uint* work_cell, __global const uint* work_batch,
                              uint first_work, uint n_work, __global const REAL* table,
                              __global REAL* state)
{
    const uint gid = (uint)get_global_id(0);
    if (gid >= n_work) return;
    const uint w = first_work + gid;
    REAL p[BT_MAX_POINT];
    bt_load_point(points, w, BT_KERNEL_STRIDE_(stride), p);
    BT_KERNEL_LOAD_OPTIONS_(o, options, n_options)
    bt_sampler s = bt_work_sampler(key0, key1, work_cell[w], work_batch[w], BT_KERNEL_METHOD_(method));
    REAL st[BT_HOOK_ITEM_STATE_SIZE];
    bt_hook_prepare(p, o, BT_KERNEL_QUANTITY_(quantity), &s, table, st);
    for (uint i = 0; i < (uint)(BT_HOOK_ITEM_STATE_SIZE); ++i)
        state[(size_t)gid * (BT_HOOK_ITEM_STATE_SIZE) + i] = st[i];
}

__kernel void bt_node_chunk(__global const uint* group_node, uint first_group, uint n_groups,
                            __global uint* node_group, __global const uint* group_item,
                            __global const REAL* item_state, __global const REAL* group_state,
                            __global REAL* node_x)
{
    const uint gid = (uint)get_global_id(0);
    if (gid >= n_groups) return;
    const uint g = first_group + gid;
    const uint base = group_node[first_group];
    for (uint k = group_node[g]; k < group_node[g + 1u]; ++k)
        node_group[k - base] = g;
    bt_hook_term_setup(item_state + (size_t)group_item[g] * (BT_HOOK_ITEM_STATE_SIZE),
                       group_state + (size_t)g * (BT_HOOK_GROUP_STATE_SIZE),
                       node_x + (group_node[g] - base));
}

__kernel void bt_node_group(__global const int* options, uint n_options, int quantity,
                            __global const uint* group_item, __global const uint* item_group,
                            uint n_groups, __global const REAL* item_state, __global REAL* group_state,
                            __global int* group_nodes)
{
    const uint gid = (uint)get_global_id(0);
    if (gid >= n_groups) return;
    const uint item = group_item[gid];
    BT_KERNEL_LOAD_OPTIONS_(o, options, n_options)
    group_nodes[gid] = bt_hook_group_prepare(item_state + (size_t)item * (BT_HOOK_ITEM_STATE_SIZE), o,
                                             BT_KERNEL_QUANTITY_(quantity), (int)(gid - item_group[item]),
                                             group_state + (size_t)gid * (BT_HOOK_GROUP_STATE_SIZE));
}

__kernel void bt_node(__global const int* options, uint n_options, int quantity,
                      __global const uint* node_group, __global const uint* group_item, uint n_nodes,
                      __global const REAL* item_state, __global const REAL* group_state,
                      __global REAL* scratch, __global const REAL* node_x)
{
    const uint gid = (uint)get_global_id(0);
    if (gid >= n_nodes) return;
    const uint g = node_group[gid];
    BT_KERNEL_LOAD_OPTIONS_(o, options, n_options)
    REAL t[BT_HOOK_TERMS];
    bt_hook_term(item_state + (size_t)group_item[g] * (BT_HOOK_ITEM_STATE_SIZE),
                 group_state + (size_t)g * (BT_HOOK_GROUP_STATE_SIZE), o, BT_KERNEL_QUANTITY_(quantity),
                 node_x[gid], t);
#pragma unroll
    for (uint i = 0; i < (uint)(BT_HOOK_TERMS); ++i)
        scratch[(size_t)gid * (BT_HOOK_TERMS) + i] = t[i];
}

__kernel void bt_node_reduce(__global const int* options, uint n_options, int quantity,
                             __global const uint* group_node, uint first_group, uint n_groups,
                             __global const uint* group_item, __global const REAL* item_state,
                             __global const REAL* group_state, __global const REAL* scratch,
                             __global REAL* group_partial)
{
    const uint gid = (uint)get_global_id(0);
    if (gid >= n_groups) return;
    const uint g = first_group + gid;
    BT_KERNEL_LOAD_OPTIONS_(o, options, n_options)
    REAL partial[BT_HOOK_PARTIALS];
    bt_hook_group_reduce(item_state + (size_t)group_item[g] * (BT_HOOK_ITEM_STATE_SIZE),
                         group_state + (size_t)g * (BT_HOOK_GROUP_STATE_SIZE), o,
                         BT_KERNEL_QUANTITY_(quantity),
                         scratch + (size_t)(group_node[g] - group_node[first_group]) * (BT_HOOK_TERMS),
                         partial);
#pragma unroll
    for (uint i = 0; i < (uint)(BT_HOOK_PARTIALS); ++i)
        group_partial[(size_t)g * (BT_HOOK_PARTIALS) + i] = partial[i];
}

__kernel void bt_node_sum(__global const REAL* points, uint stride, __global const int* options,
                          uint n_options, int quantity, uint method, uint key0, uint key1,
                          __global const uint* work_cell, __global const uint* work_batch,
                          uint first_work, uint n_work, __global const uint* item_group,
                          __global const REAL* item_state, __global const REAL* group_state,
                          __global const REAL* group_partial, __global ACCUM* out_mean,
                          __global ACCUM* out_m2)
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
    const uint first = item_group[gid];
    REAL value;
    if (n == 0 || (uint)n != item_group[gid + 1u] - first) {
        value = bt_hook_sample(p, o, q_, &s);
    } else {
        REAL acc[BT_HOOK_ACC_SIZE];
        for (uint i = 0; i < (uint)(BT_HOOK_ACC_SIZE); ++i) acc[i] = R(0.0);
        for (uint g = first; g < first + (uint)n; ++g)
            bt_hook_group_add(item_state + (size_t)gid * (BT_HOOK_ITEM_STATE_SIZE),
                              group_state + (size_t)g * (BT_HOOK_GROUP_STATE_SIZE), o, q_,
                              group_partial + (size_t)g * (BT_HOOK_PARTIALS), acc);
        value = bt_hook_finish(p, o, q_, &s, acc);
    }
    ACCUM x = (ACCUM)value;
    ACCUM mean = 0, m2 = 0;
    BT_WELFORD_ADD(mean, m2, x, 1u);
    out_mean[w] = mean;
    out_m2[w] = m2;
}
