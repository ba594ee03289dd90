/*
 * walk_parallel.h — the walk-parallel launch of a random-walk quantity.
 *
 * The usual kernel (estimator.h) runs a batch's samples in a loop inside one
 * work item, and each sample of a random walk is itself a loop of
 * data-dependent length (escape, absorption, Russian roulette).  PoCL runs the
 * work items of a group as a loop around the kernel body, so that loop is the
 * outermost one and is never vectorised.
 *
 * Here a work item is still one (cell, batch) pair, but its loop is flat: one
 * round advances its current walk by one collision, or, when that walk has
 * ended, adds the sample to the batch's Welford sums and starts the batch's
 * next sample ("regeneration": a work item whose walk ended does not wait for
 * the longest walk of the group).  Every round ends at a barrier, so PoCL puts
 * its work-item loop inside the round, where it can run the work items as SIMD
 * lanes.  The group leaves the loop together once every work item has drawn
 * all its samples: a flag in local memory, set by the work items still busy
 * after a barrier and read by all after a second one, so the exit is uniform
 * (three flags in rotation: a flag is cleared two rounds before it is set
 * again, and read only after it was set).  A round costs each lane the longer
 * of the two paths (step or regenerate); the rounds of a work item total its
 * walks' collisions plus its sample count, and the group runs as many rounds
 * as its busiest work item.
 *
 * Bit-identical to the usual kernel: sample k of a work item is
 * walk_begin + walk_step ... + walk_value (after walk_setup) on the sampler state {key, cell,
 * batch, sample = k} — the same functions the model's sample function runs in
 * a loop — and the Welford updates run in sample order on the same values
 * (tests/test_walk_parallel.cpp).
 *
 * A model provides, for a quantity (names given by its registration; the
 * entry point is walk_parallel.cl, the prelude binds its hooks to them):
 *     typedef struct {...} walk_state;
 *     void walk_setup(const REAL* p, const int* o, int quantity,
 *                     walk_state* st);        once per work item (the point)
 *     int  walk_begin(const REAL* p, const int* o, int quantity,
 *                     const bt_sampler* s, walk_state* st);  1: sample known
 *     int  walk_step(same arguments);                        1: walk ended
 *     REAL walk_value(const walk_state* st);                 the sample
 * The entry point takes the usual kernel's arguments, so the engine launches
 * both alike.  Padding work items (the global size is a whole number of
 * groups) reach every barrier with nothing to draw and store nothing.
 */
#ifndef BRDFTAB_WALK_PARALLEL_H
#define BRDFTAB_WALK_PARALLEL_H

#include "estimator.h"


#endif /* BRDFTAB_WALK_PARALLEL_H */
