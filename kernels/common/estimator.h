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
 * The OpenCL entry point is kernels/common/estimate.cl; on the host the same
 * loop is `bt_estimate_batch` below, called by the serial backend.
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
/* The engine passes -D BT_FORCE_INLINE=1 for the models whose registration
 * asks for it (ModelBuilder::force_inline, host/models/registry.h): each such
 * model states the measurement there.  A model may not ask where PoCL fails
 * to compile the inlined program (docs/contributing.md). */
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

/* One Welford update; `n` is the 1-based count after adding x.  A macro
 * shared by the host (C++) and the kernels: it updates the two accumulators
 * in place, where a function would take their addresses, and in the
 * walk-parallel kernel they are live across barriers (PoCL keeps such
 * values in per-work-item arrays). */
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
 * constants replace loads, nothing is reordered, so results are bit-identical.
 * BT_KERNEL_QUANTITY_ and its kind are macros: each picks, at preprocessing
 * time, the -D constant where it is defined and the runtime argument
 * otherwise, which a function cannot do without losing the constant. */
#if defined(BT_SPEC_QUANTITY)
#define BT_KERNEL_QUANTITY_(runtime) (BT_SPEC_QUANTITY)
#else
#define BT_KERNEL_QUANTITY_(runtime) (runtime)
#endif
#if defined(BT_SPEC_METHOD)
#define BT_KERNEL_METHOD_(runtime) (BT_SPEC_METHOD)
/* Closed forms and quadrature always run one-sample batches (host/engine/estimate.cpp):
 * a constant trip count removes the loop. */
#if BT_SPEC_METHOD == BT_METHOD_CLOSED || BT_SPEC_METHOD == BT_METHOD_QUADRATURE
#define BT_KERNEL_BATCH_SIZE_(runtime) (1u)
#define BT_KERNEL_ONE_SAMPLE_ 1
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
 * walk-parallel launches remove the sample loop instead (estimate.cl). */
#if !defined(BT_SAMPLE_BARRIER)
#define BT_SAMPLE_BARRIER 0
#endif

/* A work item's options.  A macro, because only a declaration can turn the
 * -D BT_SPEC_OPTIONS list into a constant array in the kernel's own scope,
 * which is what lets the model's branches on its options fold away. */
#if defined(BT_SPEC_OPTIONS)
#define BT_KERNEL_LOAD_OPTIONS_(o, options, n_options)                         \
    const int o[BT_MAX_OPTIONS] = {BT_SPEC_OPTIONS};
#else
#define BT_KERNEL_LOAD_OPTIONS_(o, options, n_options)                         \
    int o[BT_MAX_OPTIONS];                                                     \
    bt_load_options(options, n_options, o);
#endif

/* A generic program's options: the first n_options, zero beyond. */
BT_INLINE void bt_load_options(__global const int* options, uint n_options, int* o)
{
    for (uint k = 0; k < BT_MAX_OPTIONS; ++k)
        o[k] = k < n_options ? options[k] : 0;
}

/* Work item w's point: its `stride` values, zero beyond.  The load is
 * unrolled: left as a loop, clang vectorises it as a 4-wide inner loop before
 * PoCL wraps the body in its work-item loop, which then is not innermost and
 * stays scalar (measured on the rough-dielectric bsdf kernel,
 * docs/contributing.md "What keeps PoCL's work-item loop scalar"). */
BT_INLINE void bt_load_point(__global const REAL* points, uint w, uint stride, REAL* p)
{
#pragma unroll
    for (uint k = 0; k < BT_MAX_POINT; ++k)
        p[k] = k < stride ? points[(size_t)w * stride + k] : R(0.0);
}

/* The item a work item `gid` of a launch of n items computes: itself, or
 * for the items past n (a launch is padded to whole work groups) item 0,
 * whose result they do not store.  Such kernels have no branch around their
 * work: a load under a branch that is not consecutive across work items
 * needs a masked gather, which AVX2 targets lack, and PoCL's work-item loop
 * then stays scalar there (docs/contributing.md). */
BT_INLINE uint bt_padding_item(uint gid, uint n)
{
    return gid < n ? gid : 0u;
}

/* The sampler state of a work item's (cell, batch); sample 0. */
BT_INLINE bt_sampler bt_work_sampler(uint key0, uint key1, uint cell, uint batch, uint method)
{
    bt_sampler s;
    s.key0 = key0;
    s.key1 = key1;
    s.cell = cell;
    s.batch = batch;
    s.method = method;
    s.sample = 0u;
    return s;
}

/* The entry points are plain OpenCL C in the .cl templates of kernels/common:
 * estimate.cl (the usual kernel), sample_parallel.cl, staged_samples.cl,
 * walk_parallel.cl, node_parallel.cl, node_split.cl and
 * nested_node_parallel.cl.  Each calls fixed hook names (bt_hook_sample,
 * ...) that the program's generated prelude binds to the model's functions
 * (host/engine/kernel_sources.cpp): OpenCL C 1.2 has neither function
 * pointers nor templates, so a one-line #define per hook is the binding.
 * Every kernel that loads work items takes the same first arguments, in
 * this order (the engine's set_work_args sets them):
 *     __global const REAL* points, uint stride, __global const int* options,
 *     uint n_options, int quantity, uint method, uint key0, uint key1,
 *     __global const uint* work_cell, __global const uint* work_batch
 * and the kernels launched like the usual one continue with
 *     uint n_work, uint batch_size, __global ACCUM* out_mean, __global ACCUM* out_m2 */
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
