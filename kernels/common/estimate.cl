/*
 * estimate.cl — the usual kernel: one work item per (cell, batch), a loop over
 * the batch's samples and the Welford sums of their values (estimator.h).
 *
 * A template: the program's generated prelude (host/engine/kernel_sources.cpp)
 * includes estimator.h and the model's kernel header, and binds the hook
 *     bt_hook_sample   REAL (const REAL* p, const int* o, int quantity,
 *                             const bt_sampler* s): the model's sample function
 */
__kernel void bt_estimate(__global const REAL* points, uint stride, __global const int* options,
                          uint n_options, int quantity, uint method, uint key0, uint key1,
                          __global const uint* work_cell, __global const uint* work_batch,
                          uint n_work, uint batch_size, __global ACCUM* out_mean,
                          __global ACCUM* out_m2)
{
    const uint gid = (uint)get_global_id(0);
#if !BT_SAMPLE_BARRIER && !defined(BT_KERNEL_ONE_SAMPLE_)
    if (gid >= n_work) return;
#endif
    /* With the sample-loop barrier every work item of a group must reach the
     * same barriers: items past n_work (the launch is padded to whole work
     * groups) run the loop too, on a copy of item 0's inputs, and store
     * nothing. */
    const uint w = gid < n_work ? gid : 0u;
    REAL p[BT_MAX_POINT];
    bt_load_point(points, w, BT_KERNEL_STRIDE_(stride), p);
    BT_KERNEL_LOAD_OPTIONS_(o, options, n_options)
    bt_sampler s = bt_work_sampler(key0, key1, work_cell[w], work_batch[w], BT_KERNEL_METHOD_(method));
    const uint batch_size_ = BT_KERNEL_BATCH_SIZE_(batch_size);
    ACCUM mean = 0, m2 = 0;
    for (uint k = 0; k < batch_size_; ++k) {
        s.sample = k;
        ACCUM x = (ACCUM)bt_hook_sample(p, o, BT_KERNEL_QUANTITY_(quantity), &s);
        BT_WELFORD_ADD(mean, m2, x, k + 1);
#if BT_SAMPLE_BARRIER
        barrier(CLK_LOCAL_MEM_FENCE);
#endif
    }
    if (gid < n_work) {
        out_mean[gid] = mean;
        out_m2[gid] = m2;
    }
}
