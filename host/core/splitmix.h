// splitmix.h — splitmix64, a tiny fully specified generator for the host's
// own random choices (validation points, planner pilots), so that they depend
// only on the seed, on every platform and standard library.  (The kernels'
// integration uses Philox and Sobol: kernels/common/sampler.h.)
#pragma once

#include <cstddef>
#include <cstdint>

namespace brdftab {

struct SplitMix {
    std::uint64_t s;
    std::uint64_t next() {
        std::uint64_t z = (s += 0x9E3779B97F4A7C15ull);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
        return z ^ (z >> 31);
    }
    double uniform() { return (next() >> 11) * (1.0 / 9007199254740992.0); }  // [0, 1)
    std::size_t below(std::size_t n) { return static_cast<std::size_t>(next() % n); }
};

}  // namespace brdftab
