/*
 * node_split.cl — split terms, in the flat node-parallel program
 * (node_parallel.cl; node_parallel.h, "Split terms").
 *
 * The engine runs, instead of bt_node, bt_node_first over the list of
 * first-form nodes and bt_node_second over the others (node_list[list_first +
 * gid]: global node numbers; bt_node's other arguments), each storing at the
 * node's own scratch slot.  A template: the prelude binds bt_hook_term_first
 * and bt_hook_term_second (term(k) where node k is of that form, else NaN).
 */
BT_INLINE REAL bt_node_term_first(uint node, const int* o, int quantity, __global const uint* node_item,
                                  __global const uint* node_offset, uint first_work,
                                  __global const REAL* state)
{
    REAL st[BT_HOOK_STATE_SIZE];
    const int k = bt_node_state(node, node_item, node_offset, first_work, state, st);
    return bt_hook_term_first(st, o, quantity, k);
}

BT_INLINE REAL bt_node_term_second(uint node, const int* o, int quantity, __global const uint* node_item,
                                   __global const uint* node_offset, uint first_work,
                                   __global const REAL* state)
{
    REAL st[BT_HOOK_STATE_SIZE];
    const int k = bt_node_state(node, node_item, node_offset, first_work, state, st);
    return bt_hook_term_second(st, o, quantity, k);
}

__kernel void bt_node_first(__global const int* options, uint n_options, int quantity,
                            __global const uint* node_item, __global const uint* node_offset,
                            uint first_work, uint first_node, uint n_nodes, __global const REAL* state,
                            __global REAL* scratch, __global const uint* node_list, uint list_first)
{
    const uint item = (uint)get_global_id(0);
    const uint gid = bt_padding_item(item, n_nodes);
    const uint node = node_list[list_first + gid];
    BT_KERNEL_LOAD_OPTIONS_(o, options, n_options)
    const REAL term = bt_node_term_first(node, o, BT_KERNEL_QUANTITY_(quantity), node_item,
                                         node_offset, first_work, state);
    if (item < n_nodes) scratch[node - first_node] = term;
}

__kernel void bt_node_second(__global const int* options, uint n_options, int quantity,
                             __global const uint* node_item, __global const uint* node_offset,
                             uint first_work, uint first_node, uint n_nodes, __global const REAL* state,
                             __global REAL* scratch, __global const uint* node_list, uint list_first)
{
    const uint item = (uint)get_global_id(0);
    const uint gid = bt_padding_item(item, n_nodes);
    const uint node = node_list[list_first + gid];
    BT_KERNEL_LOAD_OPTIONS_(o, options, n_options)
    const REAL term = bt_node_term_second(node, o, BT_KERNEL_QUANTITY_(quantity), node_item,
                                          node_offset, first_work, state);
    if (item < n_nodes) scratch[node - first_node] = term;
}
