/*
 * staged_samples.cl — staged samples, in the sample-parallel program
 * (sample_parallel.cl; its bt_reduce follows these kernels).
 *
 * A sample function whose sample is a loop-free first stage followed by a
 * loop of data-dependent length (interfaced-lambertian's vcavity: the facet,
 * then the walk in its groove) is still scalar in the sample kernel: the loop
 * wraps nothing, but it is in the work-item loop's body, which is then not
 * innermost.  Split in two, with the hooks
 *     BT_HOOK_STAGE_SIZE  the number of stage values
 *     bt_hook_stage       void (p, o, quantity, s, REAL* stage)
 *     bt_hook_rest        REAL (p, o, quantity, s, const REAL* stage)
 * whose composition is the sample function's value bit for bit, the sample
 * kernel becomes three:
 *   bt_stage       one work item per sample, as the sample kernel: the
 *                  stage's values at stage[gid * BT_HOOK_STAGE_SIZE + ...];
 *                  loop-free, so it vectorises (built with BT_MF_SOLVE_STEPS:
 *                  an unfinished search leaves NaN in the stage's first value);
 *   bt_stage_redo  the same, from the usual build, for the samples whose first
 *                  stage value is NaN;
 *   bt_stage_rest  one work item per sample: the rest on its stage, at
 *                  scratch[gid] (scalar, like the sample kernel).
 * Stages are stored exactly (REAL), so every sample is the sample kernel's
 * (tests/test_sample_parallel.cpp).  A template (see estimate.cl).
 */

/* Sample gid's stage, computed and stored. */
BT_INLINE void bt_stage_store(uint gid, const REAL* p, const int* o, int quantity, const bt_sampler* s,
                              __global REAL* stage)
{
    REAL st[BT_HOOK_STAGE_SIZE];
    bt_hook_stage(p, o, quantity, s, st);
#pragma unroll
    for (uint i = 0; i < (uint)(BT_HOOK_STAGE_SIZE); ++i)
        stage[(size_t)gid * (BT_HOOK_STAGE_SIZE) + i] = st[i];
}

__kernel void bt_stage(__global const REAL* points, uint stride, __global const int* options,
                       uint n_options, int quantity, uint method, uint key0, uint key1,
                       __global const uint* work_cell, __global const uint* work_batch,
                       uint first_work, uint n_samples, uint batch_size, __global REAL* stage)
{
    const uint gid = (uint)get_global_id(0);
    if (gid >= n_samples) return;
    REAL p[BT_MAX_POINT];
    bt_sampler s;
    bt_sample_at(gid, first_work, BT_KERNEL_BATCH_SIZE_(batch_size), points, BT_KERNEL_STRIDE_(stride),
                 key0, key1, work_cell, work_batch, BT_KERNEL_METHOD_(method), p, &s);
    BT_KERNEL_LOAD_OPTIONS_(o, options, n_options)
    bt_stage_store(gid, p, o, BT_KERNEL_QUANTITY_(quantity), &s, stage);
}

__kernel void bt_stage_redo(__global const REAL* points, uint stride, __global const int* options,
                            uint n_options, int quantity, uint method, uint key0, uint key1,
                            __global const uint* work_cell, __global const uint* work_batch,
                            uint first_work, uint n_samples, uint batch_size, __global REAL* stage)
{
    const uint gid = (uint)get_global_id(0);
    if (gid >= n_samples) return;
    const REAL first = stage[(size_t)gid * (BT_HOOK_STAGE_SIZE)];
    if (first == first) return;  /* not NaN: the search had ended */
    REAL p[BT_MAX_POINT];
    bt_sampler s;
    bt_sample_at(gid, first_work, BT_KERNEL_BATCH_SIZE_(batch_size), points, BT_KERNEL_STRIDE_(stride),
                 key0, key1, work_cell, work_batch, BT_KERNEL_METHOD_(method), p, &s);
    BT_KERNEL_LOAD_OPTIONS_(o, options, n_options)
    bt_stage_store(gid, p, o, BT_KERNEL_QUANTITY_(quantity), &s, stage);
}

__kernel void bt_stage_rest(__global const REAL* points, uint stride, __global const int* options,
                            uint n_options, int quantity, uint method, uint key0, uint key1,
                            __global const uint* work_cell, __global const uint* work_batch,
                            uint first_work, uint n_samples, uint batch_size,
                            __global ACCUM* scratch, __global const REAL* stage)
{
    const uint gid = (uint)get_global_id(0);
    if (gid >= n_samples) return;
    REAL p[BT_MAX_POINT];
    bt_sampler s;
    bt_sample_at(gid, first_work, BT_KERNEL_BATCH_SIZE_(batch_size), points, BT_KERNEL_STRIDE_(stride),
                 key0, key1, work_cell, work_batch, BT_KERNEL_METHOD_(method), p, &s);
    BT_KERNEL_LOAD_OPTIONS_(o, options, n_options)
    REAL st[BT_HOOK_STAGE_SIZE];
#pragma unroll
    for (uint i = 0; i < (uint)(BT_HOOK_STAGE_SIZE); ++i)
        st[i] = stage[(size_t)gid * (BT_HOOK_STAGE_SIZE) + i];
    scratch[gid] = (ACCUM)bt_hook_rest(p, o, BT_KERNEL_QUANTITY_(quantity), &s, st);
}
