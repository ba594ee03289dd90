/*
 * estimator.h — the generic per-cell estimator loop shared by every model.
 *
 * A *work item* is one (table cell, batch) pair.  It draws `batch_size`
 * samples of the model's integrand, numbered 0..batch_size-1 inside the batch,
 * and returns the batch mean and the Welford sum of squared deviations (M2).
 * Every random number is a pure function of (seed key, cell id, batch id,
 * sample index, dimension) — see sampler.h — so the result for a cell does not
 * depend on how cells are grouped into launches, on work-group size or on the
 * device.  The host merges batches in double (Chan et al.'s parallel variance
 * formula) and decides, per cell, whether more batches are needed.
 *
 * A model provides a sample function with the signature
 *     REAL fn(const REAL* point, const int* options, int quantity,
 *             const bt_sampler* sampler);
 * where `point` holds the cell's continuous inputs (see host/models/registry.h
 * for the layout: theta_i, phi_i, theta_o, phi_o in radians, then the model's
 * continuous parameters) and `options` its categorical options.  Closed-form
 * quantities ignore the sampler and are launched with batch_size = 1.
 *
 * BT_DEFINE_ESTIMATE_KERNEL(name, fn) emits the OpenCL entry point; on the host
 * the same loop is `bt_estimate_batch` below, called by the serial backend.
 */
#ifndef BRDFTAB_ESTIMATOR_H
#define BRDFTAB_ESTIMATOR_H

#include "compat.h"
#include "sampler.h"

#define BT_MAX_POINT 16
#define BT_MAX_OPTIONS 8

/* One Welford update; `n` is the 1-based count after adding x. */
#define BT_WELFORD_ADD(mean, m2, x, n)                                         \
    do {                                                                       \
        ACCUM bt_delta_ = (x) - (mean);                                        \
        (mean) += bt_delta_ / (ACCUM)(n);                                      \
        (m2) += bt_delta_ * ((x) - (mean));                                    \
    } while (0)

#if BT_DEVICE
#define BT_DEFINE_ESTIMATE_KERNEL(kernel_name, sample_fn)                      \
    __kernel void kernel_name(                                                 \
        __global const REAL* points, uint stride, __global const int* options, \
        uint n_options, int quantity, uint method, uint key0, uint key1,       \
        __global const uint* work_cell, __global const uint* work_batch,       \
        uint n_work, uint batch_size, __global ACCUM* out_mean,                \
        __global ACCUM* out_m2)                                                \
    {                                                                          \
        uint w = (uint)get_global_id(0);                                       \
        if (w >= n_work) return;                                               \
        REAL p[BT_MAX_POINT];                                                  \
        int o[BT_MAX_OPTIONS];                                                 \
        for (uint k = 0; k < BT_MAX_POINT; ++k)                                \
            p[k] = k < stride ? points[(size_t)w * stride + k] : R(0.0);       \
        for (uint k = 0; k < BT_MAX_OPTIONS; ++k)                              \
            o[k] = k < n_options ? options[k] : 0;                             \
        bt_sampler s;                                                          \
        s.key0 = key0;                                                         \
        s.key1 = key1;                                                         \
        s.cell = work_cell[w];                                                 \
        s.batch = work_batch[w];                                               \
        s.method = method;                                                     \
        ACCUM mean = 0, m2 = 0;                                                \
        for (uint k = 0; k < batch_size; ++k) {                                \
            s.sample = k;                                                      \
            ACCUM x = (ACCUM)sample_fn(p, o, quantity, &s);                    \
            BT_WELFORD_ADD(mean, m2, x, k + 1);                                \
        }                                                                      \
        out_mean[w] = mean;                                                    \
        out_m2[w] = m2;                                                        \
    }
#else
typedef REAL (*bt_sample_fn)(const REAL* point, const int* options,
                             int quantity, const bt_sampler* sampler);

/* Host twin of the kernel body above: one work item. */
BT_INLINE void bt_estimate_batch(bt_sample_fn fn, const REAL* point,
                                 const int* options, int quantity, uint method,
                                 uint key0, uint key1, uint cell, uint batch,
                                 uint batch_size, ACCUM* out_mean,
                                 ACCUM* out_m2)
{
    bt_sampler s;
    s.key0 = key0;
    s.key1 = key1;
    s.cell = cell;
    s.batch = batch;
    s.method = method;
    ACCUM mean = 0, m2 = 0;
    for (uint k = 0; k < batch_size; ++k) {
        s.sample = k;
        ACCUM x = (ACCUM)fn(point, options, quantity, &s);
        BT_WELFORD_ADD(mean, m2, x, k + 1);
    }
    *out_mean = mean;
    *out_m2 = m2;
}
#endif

#endif /* BRDFTAB_ESTIMATOR_H */
