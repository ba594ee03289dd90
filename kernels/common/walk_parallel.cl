/*
 * walk_parallel.cl — the walk-parallel launch of a random-walk quantity
 * (walk_parallel.h describes the launch and the model's contract).
 *
 * A template: the program's generated prelude binds the hooks
 *     bt_hook_walk_state  the walk's state type
 *     bt_hook_walk_setup, bt_hook_walk_begin, bt_hook_walk_step,
 *     bt_hook_walk_value  the model's walk functions
 * The entry point takes the usual kernel's arguments (estimate.cl), so the
 * engine launches both alike.
 */
__kernel void bt_estimate_walk(__global const REAL* points, uint stride, __global const int* options,
                               uint n_options, int quantity, uint method, uint key0, uint key1,
                               __global const uint* work_cell, __global const uint* work_batch,
                               uint n_work, uint batch_size, __global ACCUM* out_mean,
                               __global ACCUM* out_m2)
{
    __local int busy_[3];
    const uint gid = (uint)get_global_id(0);
    const uint w = gid < n_work ? gid : 0u;
    REAL p[BT_MAX_POINT];
    bt_load_point(points, w, BT_KERNEL_STRIDE_(stride), p);
    BT_KERNEL_LOAD_OPTIONS_(o, options, n_options)
    bt_sampler s = bt_work_sampler(key0, key1, work_cell[w], work_batch[w], BT_KERNEL_METHOD_(method));
    const int quantity_ = BT_KERNEL_QUANTITY_(quantity);
    const uint batch_size_ = BT_KERNEL_BATCH_SIZE_(batch_size);
    if (get_local_id(0) == 0) {
        busy_[0] = 0;
        busy_[1] = 0;
        busy_[2] = 0;
    }
    /* k: samples done; padding items have none to do */
    uint k = gid < n_work ? 0u : batch_size_;
    ACCUM mean = 0, m2 = 0;
    bt_hook_walk_state st;
    bt_hook_walk_setup(p, o, quantity_, &st);
    s.sample = 0u;
    int ended = k < batch_size_ ? bt_hook_walk_begin(p, o, quantity_, &s, &st) : 1;
    barrier(CLK_LOCAL_MEM_FENCE);
    for (uint slot = 0;; slot = slot == 2u ? 0u : slot + 1u) {
        if (k < batch_size_) {
            if (ended) {
                ACCUM x = (ACCUM)bt_hook_walk_value(&st);
                BT_WELFORD_ADD(mean, m2, x, k + 1);
                ++k;
                if (k < batch_size_) {
                    s.sample = k;
                    ended = bt_hook_walk_begin(p, o, quantity_, &s, &st);
                }
            } else {
                ended = bt_hook_walk_step(p, o, quantity_, &s, &st);
            }
        }
        barrier(CLK_LOCAL_MEM_FENCE);
        if (get_local_id(0) == 0) busy_[slot == 2u ? 0u : slot + 1u] = 0;
        if (k < batch_size_) busy_[slot] = 1;
        barrier(CLK_LOCAL_MEM_FENCE);
        if (!busy_[slot]) break;
    }
    if (gid < n_work) {
        out_mean[gid] = mean;
        out_m2[gid] = m2;
    }
}
