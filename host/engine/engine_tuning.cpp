// engine_tuning.cpp — the environment's debugging switches, read once, and
// the batch policy of estimate() and the planner.
#include "host/engine/engine_tuning.h"

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <stdexcept>

namespace brdftab {

const char* environment_setting(const char* name) {
    // Listed in docs/contributing.md ("Engine tuning and debugging
    // switches"), each documented there or in the page it names.
    static const char* const kDocumented[] = {
        "BRDFTAB_DEVICE",          "BRDFTAB_SAMPLE_PARALLEL",   "BRDFTAB_NODE_PARALLEL",
        "BRDFTAB_WALK_PARALLEL",   "BRDFTAB_KERNEL_OPTIONS",    "BRDFTAB_TEST_RANK_ABORT",
        "BRDFTAB_READ_TIMEOUT",    "BRDFTAB_PROGRESS_INTERVAL", "BRDFTAB_TEST_ADAPTIVE_STOP",
    };
    if (std::none_of(std::begin(kDocumented), std::end(kDocumented),
                     [&](const char* d) { return std::strcmp(d, name) == 0; }))
        throw std::logic_error(std::string("environment_setting: undocumented variable ") + name);
    return std::getenv(name);
}

namespace {

// "0": Off, "1": On, anything else (or unset): Default.
LaunchChoice launch_choice(const char* value) {
    if (value && std::strcmp(value, "0") == 0) return LaunchChoice::Off;
    if (value && std::strcmp(value, "1") == 0) return LaunchChoice::On;
    return LaunchChoice::Default;
}

}  // namespace

const EngineTuning& environment_tuning() {
    static const EngineTuning tuning = [] {
        EngineTuning t;
        t.sample_parallel = launch_choice(environment_setting("BRDFTAB_SAMPLE_PARALLEL"));
        t.node_parallel = launch_choice(environment_setting("BRDFTAB_NODE_PARALLEL"));
        const char* walk = environment_setting("BRDFTAB_WALK_PARALLEL");
        t.walk_parallel = !(walk && std::strcmp(walk, "0") == 0);
        const char* extra = environment_setting("BRDFTAB_KERNEL_OPTIONS");
        if (extra) t.extra_kernel_options = extra;
        return t;
    }();
    return tuning;
}

std::size_t next_launch_size(std::size_t items, double seconds, std::size_t slab, std::size_t max_slab) {
    double ideal = seconds > 0 ? kLaunchSeconds * static_cast<double>(items) / seconds
                               : static_cast<double>(max_slab);
    ideal = std::clamp(ideal, static_cast<double>(slab) / 4, static_cast<double>(slab) * 4);
    const std::size_t rounded = static_cast<std::size_t>(ideal) / kMinLaunch * kMinLaunch;
    return std::clamp(rounded, std::min(kMinLaunch, max_slab), max_slab);
}

std::uint32_t floor_pow2(std::uint64_t x) {
    std::uint32_t p = 1;
    while (static_cast<std::uint64_t>(p) * 2 <= x && p < (1u << 30)) p *= 2;
    return p;
}

BatchLayout first_round_batches(Method method, std::uint64_t samples, std::uint64_t batch_size) {
    BatchLayout b;
    if (method == Method::Quadrature) {
        b.batches = 2;
        return b;
    }
    if (method != Method::MonteCarlo && method != Method::Rqmc) return b;
    const std::uint64_t n = samples ? samples : kDefaultSamplesPerCell;
    const bool rqmc = method == Method::Rqmc;
    if (batch_size)
        b.batch_size = batch_size;
    else if (rqmc)
        b.batch_size = std::max<std::uint64_t>(1, std::min<std::uint64_t>(floor_pow2(n / 8), kMaxRqmcBatch));
    else
        b.batch_size = std::min(n, kMaxMonteCarloBatch);
    b.batches = (n + b.batch_size - 1) / b.batch_size;
    if (rqmc) b.batches = std::max(b.batches, kMinRqmcBatches);
    return b;
}

}  // namespace brdftab
