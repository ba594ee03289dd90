// engine_tuning.h — every knob of the OpenCL backend's launches in one
// struct with named defaults, the batch policy that the engine and the
// planner share, and the one place the library reads the environment.
//
// An EngineTuning is filled once and given to make_backend() (engine.h).
// No field changes a result: every launch strategy is bit-identical to the
// usual kernel, and the sizes only split work differently.  Tests set fields
// (Backend::set_tuning); a user or developer sets the few documented
// debugging switches in the environment (environment_tuning(),
// docs/contributing.md "Debugging switches").
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "host/core/vocabulary.h"

namespace brdftab {

// A launch strategy: where the engine's measured defaults choose it, never,
// or for every launch it can run.
enum class LaunchChoice { Default, Off, On };

// Samples per sub-launch of the sample-parallel path: a bound on the memory
// a launch takes (a scratch buffer of 2^22 doubles, 32 MiB), not a measured
// optimum.
inline constexpr std::size_t kSampleParallelScratchSamples = std::size_t{1} << 22;
// Nodes per sub-launch of the node-parallel path (2^22 terms of scratch); the
// nested sums take fractions of it (host/engine/launch/node_parallel_nested.cpp).
inline constexpr std::size_t kNodeParallelScratchNodes = std::size_t{1} << 22;
// Work-group size of the usual and the sample- and node-parallel launches: a
// multiple of every SIMD width that lets PoCL vectorise the work-item loop;
// fixed because PoCL compiles a kernel again for every new size, and forcing
// size 1 measured 13x slower (docs/contributing.md, PoCL findings).
inline constexpr std::size_t kLocalSize = 64;
// Work-group size of walk-parallel launches: measured 184-197 k evaluations
// per CPU-second against 156-174 k for 8 and 135-139 k for 64
// (docs/benchmarks.md, "Walk-parallel launch").
inline constexpr std::size_t kWalkLocalSize = 4;

struct EngineTuning {
    // Sample-parallel launches of Monte Carlo / RQMC batches (engine.h,
    // SampleParallelCase): Default where sample_parallel_by_default() says so.
    LaunchChoice sample_parallel = LaunchChoice::Default;
    // Samples per sample-parallel sub-launch (>= 2, at most 2^31; other
    // values: the default); a batch larger than the cap runs the usual kernel.
    std::size_t sample_parallel_scratch_samples = kSampleParallelScratchSamples;
    // Step counts of the fixed-step visible-normal searches (x, y) of the
    // sample-parallel builds that use them; 0: kernels/common/microfacet.h's
    // own (BT_MF_SOLVE_STEPS_X/Y).  Tests: 1, 1 sends most samples to the redo.
    int fixed_solver_steps_x = 0;
    int fixed_solver_steps_y = 0;

    // Walk-parallel launches (engine.h, WalkParallelCase); false: the usual
    // kernel.  Work-group size 1..256 (other values: the default), at most
    // the device's.
    bool walk_parallel = true;
    std::size_t walk_local_size = kWalkLocalSize;

    // Node-parallel quadrature (engine.h, node_parallel_by_default()).
    LaunchChoice node_parallel = LaunchChoice::Default;
    // Nodes per node-parallel sub-launch (>= 1, at most 2^31; other values:
    // the default).
    std::size_t node_parallel_scratch_nodes = kNodeParallelScratchNodes;
    // Lays out at most this many nodes per work item (< 0: all), so the sum
    // kernel computes the rest itself (tests: what it does when the device
    // counts more nodes than the host, e.g. in float).
    long long node_layout_cap = -1;
    // Split terms (NodeParallelFunctions::split()): two node kernels, one per
    // form of the term; false: one kernel with both forms.
    bool split_node_terms = true;
    // Moves every host guess of a work item's first-form nodes by this many
    // nodes (tests: nodes put on the wrong side must come out the same).
    int node_split_shift = 0;

    // Work-group size of the other launches: a divisor of 256 below 256, at
    // most the device's; 0, 256 or any other value: the driver's choice, on
    // global sizes padded to multiples of 256.
    std::size_t local_size = kLocalSize;
    // Appended to every program's build options (e.g. "-D
    // BT_SAMPLE_BARRIER=1"); naming BT_FORCE_INLINE there replaces the
    // engine's own choice of forced inlining.
    std::string extra_kernel_options;
};

// The defaults with the documented debugging switches of the environment
// applied, read once per process (docs/contributing.md, "Debugging
// switches"): BRDFTAB_SAMPLE_PARALLEL, BRDFTAB_NODE_PARALLEL ("0": Off, "1":
// On), BRDFTAB_WALK_PARALLEL ("0": off) and BRDFTAB_KERNEL_OPTIONS
// (extra_kernel_options).
const EngineTuning& environment_tuning();

// The value of one of the environment variables the library reads, or
// nullptr when it is unset: BRDFTAB_DEVICE (the default device), the
// debugging switches above, BRDFTAB_TEST_RANK_ABORT (a test hook of
// distributed runs) and the CLI's BRDFTAB_READ_TIMEOUT and
// BRDFTAB_PROGRESS_INTERVAL.  Throws std::logic_error for any other name, so
// that every variable read is one of the documented ones.
const char* environment_setting(const char* name);

// ------------------------------------------------------------ batch policy
// The default samples per cell when a spec gives none.
inline constexpr std::uint64_t kDefaultSamplesPerCell = 4096;
// Monte Carlo batches: plain chunks of the sample stream, at most this long.
inline constexpr std::uint64_t kMaxMonteCarloBatch = 4096;
// RQMC batches: independently scrambled Sobol' point sets whose size is a
// power of two (where the nets are balanced), floor_pow2(N / 8) within
// [1, kMaxRqmcBatch], and at least kMinRqmcBatches of them so that their
// spread gives a usable error estimate.
inline constexpr std::uint64_t kMaxRqmcBatch = 8192;
inline constexpr std::uint64_t kMinRqmcBatches = 4;

// How estimate() lays out `samples` per cell (0: kDefaultSamplesPerCell) of
// a run by `method` (resolved: not Auto) in its first round, which is every
// round of a non-adaptive run: samples per batch (one work item each) and
// batches per cell.  Closed form: 1 x 1; quadrature: 1 x 2 (the accurate and
// the coarse rule); `batch_size` > 0 replaces the Monte Carlo / RQMC batch
// size.
struct BatchLayout {
    std::uint64_t batch_size = 1;
    std::uint64_t batches = 1;
};
BatchLayout first_round_batches(Method method, std::uint64_t samples, std::uint64_t batch_size = 0);

// ------------------------------------------------------------ launch sizes
// estimate()'s launches start at kFirstLaunch work items and grow (at most 4x
// per launch) towards kLaunchSeconds each, capped by the backend's preferred
// slab: progress comes every fraction of a second even when one work item
// runs thousands of samples, while closed forms still get launches large
// enough to amortise the launch overhead.
inline constexpr double kLaunchSeconds = 0.5;
inline constexpr std::size_t kFirstLaunch = 256;
// Sizes are whole multiples of kMinLaunch (four work groups of 64), so that
// the groups of a launch spread evenly over 2 or 4 cores: with odd group
// counts one core idles at the end of every launch (measured: 5 % of the
// throughput with 0.4 s launches of about 585 work items).
inline constexpr std::size_t kMinLaunch = 256;

// The size of the launch after a full one of `items` work items (launches of
// `slab`) that took `seconds`, with at most `max_slab` (>= 1) per launch.
std::size_t next_launch_size(std::size_t items, double seconds, std::size_t slab, std::size_t max_slab);

// The largest power of two <= x, within [1, 2^30].
std::uint32_t floor_pow2(std::uint64_t x);

}  // namespace brdftab
