/*
 * sample_parallel.cl — the sample-parallel launch of a Monte Carlo / RQMC
 * batch (the engine's default for the cases measured faster that way).
 *
 * The usual kernel (estimate.cl) runs a batch's samples as a loop inside one
 * work item, so PoCL's loop over the work items of a group wraps the sample
 * loop and stays scalar.  Here the same work is two kernels with no barrier:
 *   bt_sample   one work item per (work item w, sample k) of a sub-launch,
 *               global id g = (w - first_work) * batch_size + k: draws sample
 *               k of w's batch with the same sampler state {key, cell, batch,
 *               sample = k} and stores it in scratch[g];
 *   bt_reduce   one work item per w of the sub-launch: the Welford loop over
 *               scratch[...k], k = 0..batch_size-1, in order.
 * Every sample is the same function of the same inputs, stored exactly, and
 * the Welford updates run in the same order on the same values, so mean and
 * M2 are bit for bit those of the usual kernel (tests/test_sample_parallel.cpp
 * checks it on every Monte Carlo quantity).  The sample kernel's body has no
 * loop around the sample function, so the work-item loop is innermost.
 *   bt_sample_redo  the sample kernel again, for the slots that hold NaN only.
 * The engine runs it, from the usual build, after the sample kernel of a
 * build whose searches take a fixed number of steps (BT_MF_SOLVE_STEPS,
 * microfacet.h: a search that has not ended then makes its sample NaN), so
 * that every slot ends up with the usual build's value.
 *
 * A template (see estimate.cl): the prelude binds bt_hook_sample.
 */

/* Sample gid of a sub-launch: its work item's point, options and sampler. */
BT_INLINE void bt_sample_at(uint gid, uint first_work, uint batch_size, __global const REAL* points,
                            uint stride, uint key0, uint key1, __global const uint* work_cell,
                            __global const uint* work_batch, uint method, REAL* p, bt_sampler* s)
{
    const uint item = gid / batch_size;
    const uint w = first_work + item;
    bt_load_point(points, w, stride, p);
    *s = bt_work_sampler(key0, key1, work_cell[w], work_batch[w], method);
    s->sample = gid - item * batch_size;
}

__kernel void bt_sample(__global const REAL* points, uint stride, __global const int* options,
                        uint n_options, int quantity, uint method, uint key0, uint key1,
                        __global const uint* work_cell, __global const uint* work_batch,
                        uint first_work, uint n_samples, uint batch_size, __global ACCUM* scratch)
{
    const uint item = (uint)get_global_id(0);
    const uint gid = bt_padding_item(item, n_samples);
    REAL p[BT_MAX_POINT];
    bt_sampler s;
    bt_sample_at(gid, first_work, BT_KERNEL_BATCH_SIZE_(batch_size), points, BT_KERNEL_STRIDE_(stride),
                 key0, key1, work_cell, work_batch, BT_KERNEL_METHOD_(method), p, &s);
    BT_KERNEL_LOAD_OPTIONS_(o, options, n_options)
    const ACCUM x = (ACCUM)bt_hook_sample(p, o, BT_KERNEL_QUANTITY_(quantity), &s);
    if (item < n_samples) scratch[gid] = x;
}

__kernel void bt_sample_redo(__global const REAL* points, uint stride, __global const int* options,
                             uint n_options, int quantity, uint method, uint key0, uint key1,
                             __global const uint* work_cell, __global const uint* work_batch,
                             uint first_work, uint n_samples, uint batch_size,
                             __global ACCUM* scratch)
{
    const uint gid = (uint)get_global_id(0);
    if (gid >= n_samples) return;
    if (scratch[gid] == scratch[gid]) return;  /* not NaN: the search had ended */
    REAL p[BT_MAX_POINT];
    bt_sampler s;
    bt_sample_at(gid, first_work, BT_KERNEL_BATCH_SIZE_(batch_size), points, BT_KERNEL_STRIDE_(stride),
                 key0, key1, work_cell, work_batch, BT_KERNEL_METHOD_(method), p, &s);
    BT_KERNEL_LOAD_OPTIONS_(o, options, n_options)
    scratch[gid] = (ACCUM)bt_hook_sample(p, o, BT_KERNEL_QUANTITY_(quantity), &s);
}

__kernel void bt_reduce(__global const ACCUM* scratch, uint first_work, uint n_work, uint batch_size,
                        __global ACCUM* out_mean, __global ACCUM* out_m2)
{
    const uint item = (uint)get_global_id(0);
    if (item >= n_work) return;
    __global const ACCUM* x = scratch + (size_t)item * batch_size;
    ACCUM mean = 0, m2 = 0;
    for (uint k = 0; k < batch_size; ++k)
        BT_WELFORD_ADD(mean, m2, x[k], k + 1);
    out_mean[first_work + item] = mean;
    out_m2[first_work + item] = m2;
}
