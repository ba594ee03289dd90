/*
 * sampler.h — uniform random numbers indexed by (seed key, cell, batch,
 * sample, dimension).  API contract (implementation: philox.h, sobol.h):
 *
 *   BT_METHOD_MC          Philox-4x32-10, counter = (cell, batch, sample, dim/4)
 *   BT_METHOD_RQMC        Sobol point `sample` (0-based within the batch),
 *                         Owen-scrambled per (key, cell, batch, dim)
 *   BT_METHOD_CLOSED      no randomness; bt_uniform returns 0.5
 *   BT_METHOD_QUADRATURE  deterministic quadrature: no randomness either.  The
 *                         engine runs two one-sample batches per cell: batch 0
 *                         must return the accurate rule, batch 1 a coarser one
 *                         (e.g. half the nodes); |batch0 - batch1| is reported
 *                         as the error estimate.  A sample function reads
 *                         `s->batch` to tell which.
 *
 *   REAL bt_uniform(const bt_sampler* s, uint dim)   in [0, 1), never 1.0
 *   dim < BT_MAX_DIMS
 */
#ifndef BRDFTAB_SAMPLER_H
#define BRDFTAB_SAMPLER_H

#include "compat.h"

#define BT_METHOD_MC 0u
#define BT_METHOD_RQMC 1u
#define BT_METHOD_CLOSED 2u
#define BT_METHOD_QUADRATURE 3u
#define BT_MAX_DIMS 8u

typedef struct bt_sampler {
    uint key0, key1;  /* the seed, split in two 32-bit words */
    uint cell;        /* global table cell index */
    uint batch;       /* batch number within the cell */
    uint sample;      /* sample number within the batch */
    uint method;      /* BT_METHOD_* */
} bt_sampler;

#include "philox.h"
#include "sobol.h"

/* u32 -> REAL in [0, 1).  Double: x / 2^32 (exact, max 1 - 2^-32).  Float:
 * the top 24 bits / 2^24 (exact in float, max 1 - 2^-24); using all 32 bits
 * would round values above 1 - 2^-25 up to 1.0f. */
BT_INLINE REAL bt_u32_to_unit(uint x)
{
#if defined(BT_REAL_IS_FLOAT) && BT_REAL_IS_FLOAT && BT_DEVICE
    return (REAL)(x >> 8) * R(5.9604644775390625e-08); /* 2^-24 */
#else
    return (REAL)x * R(2.3283064365386962890625e-10); /* 2^-32 */
#endif
}

/* Philox word for (key, cell, batch, sample, dim): counter
 * (cell, batch, sample, dim / 4), word dim % 4. */
BT_INLINE uint bt_philox_u32(const bt_sampler* s, uint dim)
{
    return bt_philox4x32_10_word(s->cell, s->batch, s->sample, dim >> 2, s->key0,
                                 s->key1, dim & 3u);
}

/* The uniform number of dimension `dim` for this sampler state: a pure
 * function of (key0, key1, cell, batch, sample, dim, method).
 * RQMC covers dims 0..BT_SOBOL_DIMS-1; any higher dim (beyond the API's
 * BT_MAX_DIMS contract) falls back to Philox so it is still a valid uniform. */
BT_INLINE REAL bt_uniform(const bt_sampler* s, uint dim)
{
    if (s->method == BT_METHOD_MC) return bt_u32_to_unit(bt_philox_u32(s, dim));
    if (s->method == BT_METHOD_RQMC) {
        if (dim >= BT_SOBOL_DIMS) return bt_u32_to_unit(bt_philox_u32(s, dim));
        uint seed = bt_scramble_seed(s->key0, s->key1, s->cell, s->batch, dim);
        return bt_u32_to_unit(bt_owen_scramble(bt_sobol_u32(s->sample, dim), seed));
    }
    return R(0.5); /* BT_METHOD_CLOSED (and any unknown method) */
}

#endif /* BRDFTAB_SAMPLER_H */
