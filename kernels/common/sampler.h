/*
 * sampler.h — uniform random numbers indexed by (seed key, cell, batch,
 * sample, dimension).  API contract (implementation: philox.h, sobol.h):
 *
 *   BT_METHOD_MC          Philox-4x32-10, counter = (cell, batch, sample, dim/4)
 *   BT_METHOD_RQMC        Sobol point `sample` (0-based within the batch),
 *                         Owen-scrambled per (key, cell, batch, dim)
 *   BT_METHOD_CLOSED      no randomness; bt_uniform returns 0.5
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
#define BT_MAX_DIMS 8u

typedef struct {
    uint key0, key1;  /* the seed, split in two 32-bit words */
    uint cell;        /* global table cell index */
    uint batch;       /* batch number within the cell */
    uint sample;      /* sample number within the batch */
    uint method;      /* BT_METHOD_* */
} bt_sampler;

/* IMPLEMENTATION PENDING (helper A) */

#endif /* BRDFTAB_SAMPLER_H */
