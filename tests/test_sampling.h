// test_sampling.h — sampler set-up shared by the model tests (needs the
// kernels' sampler.h, so it is kept apart from test_support.h).
#pragma once

#include "kernels/common/sampler.h"

namespace brdftab::test {

// The sampler state of sample `sample` of batch `batch` of cell `cell` under
// the key (key0, key1), for the method `method` (BT_METHOD_*).
inline bt_sampler make_sampler(uint method, uint key0, uint key1, uint cell, uint batch,
                               uint sample) {
    bt_sampler s;
    s.key0 = key0;
    s.key1 = key1;
    s.cell = cell;
    s.batch = batch;
    s.sample = sample;
    s.method = method;
    return s;
}

// Plain Monte Carlo sample `sample` of cell `cell`, batch 0, under a fixed key.
inline bt_sampler mc_sampler(uint key0, uint key1, uint cell, uint sample) {
    return make_sampler(BT_METHOD_MC, key0, key1, cell, 0, sample);
}

}  // namespace brdftab::test
