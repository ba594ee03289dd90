// test_sampling.h — sampler set-up shared by the model tests (needs the
// kernels' sampler.h, so it is kept apart from test_support.h).
#pragma once

#include "kernels/common/sampler.h"

namespace brdftab::test {

// Plain Monte Carlo sample `sample` of cell `cell`, batch 0, under a fixed key.
inline bt_sampler mc_sampler(uint key0, uint key1, uint cell, uint sample) {
    bt_sampler s;
    s.key0 = key0;
    s.key1 = key1;
    s.cell = cell;
    s.batch = 0;
    s.sample = sample;
    s.method = BT_METHOD_MC;
    return s;
}

}  // namespace brdftab::test
