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

/* The sample-loop barrier (see "The sample loop's synchronisation point"
 * below) is only for loops of several samples: a one-sample loop (closed
 * forms: BT_METHOD_CLOSED = 2, quadrature: BT_METHOD_QUADRATURE = 3, see
 * sampler.h) has nothing to vectorise inside it, and PoCL crashed on one such
 * kernel with the barrier and forced inlining. */
#if defined(BT_SPEC_METHOD) && defined(BT_SAMPLE_BARRIER)
#if BT_SAMPLE_BARRIER && (BT_SPEC_METHOD == 2 || BT_SPEC_METHOD == 3)
#undef BT_SAMPLE_BARRIER
#define BT_SAMPLE_BARRIER 0
#endif
#endif

#if !defined(BT_SAMPLE_BARRIER)
#define BT_SAMPLE_BARRIER 0
#endif
#if !defined(BT_FORCE_INLINE)
#define BT_FORCE_INLINE BT_SAMPLE_BARRIER
#endif
/* The engine passes -D BT_FORCE_INLINE=1 for rough-dielectric, micrograin and
 * interfaced-lambertian (host/engine/engine.cpp): measured faster there, and their preset tables
 * bit-identical.  Not for lambert-sphere: PoCL crashes (SIGSEGV) with it in
 * the in-kernel Horak-Chandrasekhar solve of lambert-sphere-constants
 * (docs/contributing.md). */
#if BT_DEVICE && BT_FORCE_INLINE && !defined(BT_NO_FORCE_INLINE)
/* With the sample-loop barrier (below), or with -D BT_FORCE_INLINE=1, force
 * inlining of every shared function into the kernel.  PoCL's inliner otherwise keeps larger helpers
 * (bt_uniform, the microfacet G1, ...) as calls, and a call in the sample
 * loop stops the vectoriser from running the work items of a group as SIMD
 * lanes.  Measured with bench/bench_estimator_loop on a trigonometry-free
 * sample function: Philox sampling 7.5 M -> 43 M samples per CPU-second, and
 * only with both the barrier and the inlining (docs/benchmarks.md).
 * Inlining changes no arithmetic (-D BT_NO_FORCE_INLINE: not forced, for
 * that comparison).  Redefined here, before sampler.h and the
 * model header define their functions, because the estimator is the first
 * file of every device program; it belongs in compat.h. */
#undef BT_INLINE
#define BT_INLINE static inline __attribute__((always_inline))
#endif

#include "sampler.h"

/* Slots of a kernel point: 4 directions, the model's parameters and its
 * derived per-cell invariants (host/models/registry.h; lambert-sphere uses
 * 4 + 5 + 20). */
#define BT_MAX_POINT 32
#define BT_MAX_OPTIONS 12

/* One Welford update; `n` is the 1-based count after adding x. */
#define BT_WELFORD_ADD(mean, m2, x, n)                                         \
    do {                                                                       \
        ACCUM bt_delta_ = (x) - (mean);                                        \
        (mean) += bt_delta_ / (ACCUM)(n);                                      \
        (m2) += bt_delta_ * ((x) - (mean));                                    \
    } while (0)

#if BT_DEVICE
/* Specialisation.  The engine builds one program per (model, quantity,
 * options, method) it runs, passing them as compile-time constants:
 *     -D BT_SPEC_QUANTITY=<id> -D BT_SPEC_METHOD=<BT_METHOD_*>
 *     -D BT_SPEC_OPTIONS=<o0>,<o1>,...  -D BT_SPEC_STRIDE=<point stride>
 * so every branch of the model on them folds away at compile time and PoCL
 * sees one straight path for all work items.  The runtime arguments stay in
 * the signature (ignored then), so generic and specialised programs are
 * launched alike.  The arithmetic of a work item is the same either way:
 * constants replace loads, nothing is reordered, so results are bit-identical. */
#if defined(BT_SPEC_QUANTITY)
#define BT_KERNEL_QUANTITY_(runtime) (BT_SPEC_QUANTITY)
#else
#define BT_KERNEL_QUANTITY_(runtime) (runtime)
#endif
#if defined(BT_SPEC_METHOD)
#define BT_KERNEL_METHOD_(runtime) (BT_SPEC_METHOD)
/* Closed forms and quadrature always run one-sample batches (engine.cpp):
 * a constant trip count removes the loop. */
#if BT_SPEC_METHOD == BT_METHOD_CLOSED || BT_SPEC_METHOD == BT_METHOD_QUADRATURE
#define BT_KERNEL_BATCH_SIZE_(runtime) (1u)
#endif
#else
#define BT_KERNEL_METHOD_(runtime) (runtime)
#endif
#if !defined(BT_KERNEL_BATCH_SIZE_)
#define BT_KERNEL_BATCH_SIZE_(runtime) (runtime)
#endif
#if defined(BT_SPEC_STRIDE)
#define BT_KERNEL_STRIDE_(runtime) ((uint)(BT_SPEC_STRIDE))
#else
#define BT_KERNEL_STRIDE_(runtime) (runtime)
#endif
#if defined(BT_SPEC_OPTIONS)
#define BT_KERNEL_LOAD_OPTIONS_(o, options, n_options)                         \
    const int o[BT_MAX_OPTIONS] = {BT_SPEC_OPTIONS};
#else
#define BT_KERNEL_LOAD_OPTIONS_(o, options, n_options)                         \
    int o[BT_MAX_OPTIONS];                                                     \
    for (uint k = 0; k < BT_MAX_OPTIONS; ++k)                                  \
        o[k] = k < n_options ? options[k] : 0;
#endif
/* The sample loop's synchronisation point (off by default; the engine
 * passes -D BT_SAMPLE_BARRIER=1 only where asked to, see docs/devices.md).
 * PoCL runs the work items of a work group as a loop around the kernel body;
 * a barrier inside the sample loop (whose trip count is the same for every
 * work item) makes PoCL put that work-item loop *inside* the sample loop,
 * where its loop vectoriser can turn it into SIMD lanes — provided the loop
 * body has no calls left (hence the forced inlining above).  It never changes
 * a work item's arithmetic.  Measured (docs/benchmarks.md, "What vectorises,
 * and why"): a large gain on a call-free body, but on large model bodies
 * PoCL's compile time blows up (every value live across the barrier becomes
 * a per-work-item array), so it is not the default: the sample-, node- and
 * walk-parallel launches remove the sample loop instead. */
#if !defined(BT_SAMPLE_BARRIER)
#define BT_SAMPLE_BARRIER 0
#endif
#if BT_SAMPLE_BARRIER
#define BT_KERNEL_SAMPLE_SYNC_() barrier(CLK_LOCAL_MEM_FENCE)
/* Every work item of a group must reach the same barriers: items past
 * n_work (the launch is padded to whole work groups) run the loop too, on a
 * copy of item 0's inputs, and store nothing. */
#define BT_KERNEL_PADDING_EXIT_(gid, n_work) ((void)0)
#else
#define BT_KERNEL_SAMPLE_SYNC_() ((void)0)
#define BT_KERNEL_PADDING_EXIT_(gid, n_work)                                   \
    if ((gid) >= (n_work)) return
#endif

/* Work item w's inputs, shared by the kernels below (same names in their
 * signatures): the point p (its load unrolled, see below), the options o and the sampler
 * state s of its (cell, batch). */
#define BT_KERNEL_LOAD_WORK_(w)                                                \
        const uint stride_ = BT_KERNEL_STRIDE_(stride);                        \
        REAL p[BT_MAX_POINT];                                                  \
        _Pragma("unroll")                                                      \
        for (uint k = 0; k < BT_MAX_POINT; ++k)                                \
            p[k] = k < stride_ ? points[(size_t)w * stride_ + k] : R(0.0);     \
        BT_KERNEL_LOAD_OPTIONS_(o, options, n_options)                         \
        bt_sampler s;                                                          \
        s.key0 = key0;                                                         \
        s.key1 = key1;                                                         \
        s.cell = work_cell[w];                                                 \
        s.batch = work_batch[w];                                               \
        s.method = BT_KERNEL_METHOD_(method);

/* The first arguments of every kernel that loads work items (what
 * BT_KERNEL_LOAD_WORK_ reads; the engine's set_work_args sets them): the
 * usual, walk-parallel, sample-parallel and node-parallel kernels. */
#define BT_WORK_KERNEL_PARAMS                                                  \
        __global const REAL* points, uint stride, __global const int* options, \
        uint n_options, int quantity, uint method, uint key0, uint key1,       \
        __global const uint* work_cell, __global const uint* work_batch
/* The arguments of the usual kernel, which every kernel launched alike takes
 * (the walk-parallel kernel of walk_parallel.h too). */
#define BT_ESTIMATE_KERNEL_PARAMS                                              \
        BT_WORK_KERNEL_PARAMS, uint n_work, uint batch_size,                   \
        __global ACCUM* out_mean, __global ACCUM* out_m2

/* The point load is unrolled: left as a loop, clang vectorises it as a 4-wide
 * inner loop before PoCL wraps the body in its work-item loop, which then is
 * not innermost and stays scalar (measured on the rough-dielectric bsdf
 * kernel, docs/contributing.md "What keeps PoCL's work-item loop scalar"). */
#define BT_DEFINE_ESTIMATE_KERNEL(kernel_name, sample_fn)                      \
    __kernel void kernel_name(BT_ESTIMATE_KERNEL_PARAMS)                       \
    {                                                                          \
        const uint gid = (uint)get_global_id(0);                               \
        BT_KERNEL_PADDING_EXIT_(gid, n_work);                                  \
        const uint w = gid < n_work ? gid : 0u;                                \
        BT_KERNEL_LOAD_WORK_(w)                                                \
        const uint batch_size_ = BT_KERNEL_BATCH_SIZE_(batch_size);            \
        ACCUM mean = 0, m2 = 0;                                                \
        for (uint k = 0; k < batch_size_; ++k) {                               \
            s.sample = k;                                                      \
            ACCUM x = (ACCUM)sample_fn(p, o, BT_KERNEL_QUANTITY_(quantity), &s); \
            BT_WELFORD_ADD(mean, m2, x, k + 1);                                \
            BT_KERNEL_SAMPLE_SYNC_();                                          \
        }                                                                      \
        if (gid < n_work) {                                                    \
            out_mean[gid] = mean;                                              \
            out_m2[gid] = m2;                                                  \
        }                                                                      \
    }

/* Sample-parallel launch (the engine's default for the Monte Carlo cases
 * measured faster that way, host/engine/engine.cpp; BRDFTAB_SAMPLE_PARALLEL
 * forces it on or off).  The kernel above runs a batch's samples as a loop
 * inside one work item, so PoCL's loop over the work items of a group wraps
 * the sample loop and stays scalar.  Here the same work is two kernels with
 * no barrier:
 *   sample_kernel  one work item per (work item w, sample k) of a sub-launch,
 *                  global id g = (w - first_work) * batch_size + k: draws
 *                  sample k of w's batch with the same sampler state
 *                  {key, cell, batch, sample = k} and stores it in scratch[g];
 *   reduce_kernel  one work item per w of the sub-launch: the Welford loop
 *                  above over scratch[...k], k = 0..batch_size-1, in order.
 * Every sample is the same function of the same inputs, stored exactly, and
 * the Welford updates run in the same order on the same values, so mean and
 * M2 are bit for bit those of bt_estimate (tests/test_sample_parallel.cpp
 * checks it on every Monte Carlo quantity).  The sample kernel's body has no
 * loop around the sample function, so the work-item loop is innermost.
 *   redo_kernel    the sample kernel again, for the slots that hold NaN only.
 * The engine runs it, from the usual build, after the sample kernel of a
 * build whose searches take a fixed number of steps (BT_MF_SOLVE_STEPS,
 * microfacet.h: a search that has not ended then makes its sample NaN), so
 * that every slot ends up with the usual build's value. */
#define BT_DEFINE_SAMPLE_PARALLEL_KERNELS(sample_kernel, reduce_kernel,        \
                                          redo_kernel, sample_fn)              \
    __kernel void sample_kernel(                                               \
        BT_WORK_KERNEL_PARAMS, uint first_work, uint n_samples, uint batch_size, \
        __global ACCUM* scratch)                                               \
    {                                                                          \
        BT_SAMPLE_PARALLEL_BODY_(sample_fn, 0)                                 \
    }                                                                          \
    __kernel void redo_kernel(                                                 \
        BT_WORK_KERNEL_PARAMS, uint first_work, uint n_samples, uint batch_size, \
        __global ACCUM* scratch)                                               \
    {                                                                          \
        BT_SAMPLE_PARALLEL_BODY_(sample_fn, 1)                                 \
    }                                                                          \
    __kernel void reduce_kernel(__global const ACCUM* scratch,                 \
                                uint first_work, uint n_work,                  \
                                uint batch_size, __global ACCUM* out_mean,     \
                                __global ACCUM* out_m2)                        \
    {                                                                          \
        const uint item = (uint)get_global_id(0);                              \
        if (item >= n_work) return;                                            \
        __global const ACCUM* x = scratch + (size_t)item * batch_size;         \
        ACCUM mean = 0, m2 = 0;                                                \
        for (uint k = 0; k < batch_size; ++k)                                  \
            BT_WELFORD_ADD(mean, m2, x[k], k + 1);                             \
        out_mean[first_work + item] = mean;                                    \
        out_m2[first_work + item] = m2;                                        \
    }
/* Sample gid of a sub-launch, as every per-sample kernel starts: unless it
 * is padding or `skip` (an expression of gid) holds, its work item, point
 * and sampler state. */
#define BT_SAMPLE_LOAD_(skip)                                                  \
        const uint gid = (uint)get_global_id(0);                               \
        if (gid >= n_samples) return;                                          \
        if (skip) return;                                                      \
        const uint batch_size_ = BT_KERNEL_BATCH_SIZE_(batch_size);            \
        const uint item = gid / batch_size_;                                   \
        const uint w = first_work + item;                                      \
        BT_KERNEL_LOAD_WORK_(w)                                                \
        s.sample = gid - item * batch_size_;
/* The sample kernel's body; with redo = 1 only the slots that hold NaN are
 * computed again (the redo kernel: see BT_MF_SOLVE_STEPS in microfacet.h). */
#define BT_SAMPLE_PARALLEL_BODY_(sample_fn, redo)                              \
        BT_SAMPLE_LOAD_((redo) && scratch[gid] == scratch[gid])                \
        scratch[gid] =                                                         \
            (ACCUM)sample_fn(p, o, BT_KERNEL_QUANTITY_(quantity), &s);

/* Staged samples.  A sample function whose sample is a loop-free first stage
 * followed by a loop of data-dependent length (interfaced-lambertian's
 * vcavity: the facet, then the walk in its groove) is still scalar in the
 * sample kernel above: the loop wraps nothing, but it is in the work-item
 * loop's body, which is then not innermost.  Split in two, with
 *     void stage_fn(p, o, quantity, s, REAL* stage)     stage_size values
 *     REAL rest_fn (p, o, quantity, s, const REAL* stage)
 * whose composition is sample_fn's value bit for bit, the sample kernel
 * becomes three (the reduce kernel above follows them):
 *   stage_kernel       one work item per sample, as the sample kernel:
 *                      stage_fn's values at stage[gid * stage_size + ...];
 *                      loop-free, so it vectorises (built with
 *                      BT_MF_SOLVE_STEPS: an unfinished search leaves NaN in
 *                      the stage's first value);
 *   stage_redo_kernel  the same, from the usual build, for the samples whose
 *                      first stage value is NaN;
 *   rest_kernel        one work item per sample: rest_fn on its stage, at
 *                      scratch[gid] (scalar, like the sample kernel).
 * Stages are stored exactly (REAL), so every sample is the sample kernel's
 * (tests/test_sample_parallel.cpp). */
#define BT_DEFINE_STAGED_SAMPLE_KERNELS(stage_kernel, stage_redo_kernel,       \
                                        rest_kernel, stage_size, stage_fn,     \
                                        rest_fn)                               \
    __kernel void stage_kernel(                                                \
        BT_WORK_KERNEL_PARAMS, uint first_work, uint n_samples, uint batch_size, \
        __global REAL* stage)                                                  \
    {                                                                          \
        BT_STAGE_BODY_(stage_size, stage_fn, 0)                                \
    }                                                                          \
    __kernel void stage_redo_kernel(                                           \
        BT_WORK_KERNEL_PARAMS, uint first_work, uint n_samples, uint batch_size, \
        __global REAL* stage)                                                  \
    {                                                                          \
        BT_STAGE_BODY_(stage_size, stage_fn, 1)                                \
    }                                                                          \
    __kernel void rest_kernel(                                                 \
        BT_WORK_KERNEL_PARAMS, uint first_work, uint n_samples, uint batch_size, \
        __global ACCUM* scratch, __global const REAL* stage)                   \
    {                                                                          \
        BT_SAMPLE_LOAD_(0)                                                     \
        REAL st[stage_size];                                                   \
        _Pragma("unroll")                                                      \
        for (uint i = 0; i < (uint)(stage_size); ++i)                          \
            st[i] = stage[(size_t)gid * (stage_size) + i];                     \
        scratch[gid] =                                                         \
            (ACCUM)rest_fn(p, o, BT_KERNEL_QUANTITY_(quantity), &s, st);       \
    }
/* The stage kernel's body; with redo = 1 only the stages whose first value
 * is NaN are computed again. */
#define BT_STAGE_BODY_(stage_size, stage_fn, redo)                             \
        BT_SAMPLE_LOAD_((redo) && stage[(size_t)gid * (stage_size)] ==         \
                                      stage[(size_t)gid * (stage_size)])       \
        REAL st[stage_size];                                                   \
        stage_fn(p, o, BT_KERNEL_QUANTITY_(quantity), &s, st);                 \
        _Pragma("unroll")                                                      \
        for (uint i = 0; i < (uint)(stage_size); ++i)                          \
            stage[(size_t)gid * (stage_size) + i] = st[i];
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
