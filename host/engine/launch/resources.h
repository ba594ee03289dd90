// resources.h — what every launch strategy of the OpenCL backend shares: the
// runtime, the per-launch buffers (and the memory stage() lends), the
// program cache and the build options, the launch geometry and the argument
// helpers; and the strategy interface (LaunchStrategy) itself.
//
// A launch strategy (host/engine/launch/*.cpp) is one way to run a
// BatchLaunch on the device: the usual kernel, sample-parallel, staged,
// walk-parallel, node-parallel flat, split or nested.  The backend
// (opencl_backend.cpp) asks each in turn whether it applies to a launch,
// writes the launch's inputs, lets the first that applies enqueue its
// kernels, and reads the results.  Every strategy gives the usual kernel's
// bits; they differ in speed only (docs/benchmarks.md).
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "host/engine/engine.h"
#include "host/engine/opencl_runtime.h"

namespace brdftab::launch {

// Sets kernel arguments first, first + 1, ... to `args` in turn.
template <typename... Args>
void set_args_from(cl::Kernel& kernel, cl_uint first, const Args&... args) {
    (kernel.setArg(first++, args), ...);
}

// Runs [first, last) of whole entries 0 .. count - 1, given the exclusive
// prefix sums offset[0 .. count] of their sizes: each as long as its size
// stays at most `cap` (an entry larger than that alone), in order; with the
// largest size and the most entries of any run (at least 1 each).
struct EntryRuns {
    std::vector<std::pair<std::size_t, std::size_t>> runs;
    std::size_t most_size = 1, most_entries = 1;
};
EntryRuns runs_within(const std::vector<std::uint32_t>& offset, std::size_t count, std::size_t cap);

// The quantity a launch computes (its id in the model's list); null if none.
const QuantityInfo* launch_quantity(const BatchLaunch& l);
// Whether `options` (indices, in the order of model.options) set the option
// `name` to `choice`.
bool option_is(const ModelInfo& model, const std::vector<int>& options, const std::string& name,
               const std::string& choice);
// The launch's options as the kernels' fixed-size int array.
void options_array(const BatchLaunch& l, int* opts);

// A buffer of at least `need` bytes (at least 1), grown geometrically and
// kept: `have` is its size.
void grow_buffer(cl::Context& ctx, cl::Buffer& buffer, std::size_t& have, std::size_t need,
                 cl_mem_flags flags);

// Page-aligned host memory (CL_MEM_USE_HOST_PTR wants the device's base
// alignment; a page covers every device's).
class HostMemory {
public:
    HostMemory() = default;
    explicit HostMemory(std::size_t bytes);
    void* get() const { return data_.get(); }

private:
    struct Free {
        void operator()(void* p) const { std::free(p); }
    };
    std::unique_ptr<void, Free> data_;
};

// One buffer set's staged inputs (Backend::stage()): the host memory and the
// buffers over it.  The buffers are declared after the memory, so they are
// released before it is freed.
struct StagedInputs {
    HostMemory points_host, cells_host, batches_host;
    cl::Buffer points, cells, batches;
    std::size_t items = 0, point_doubles = 0;
};

class LaunchResources {
public:
    LaunchResources(const DeviceInfo& device, Precision precision, std::string kernel_dir,
                    const EngineTuning& tuning);

    ClRuntime runtime;
    const Precision precision;
    const std::string kernel_dir;
    EngineTuning tuning;

    // Whether the device computes in double (float otherwise) and
    // accumulates in double (a device with fp64).
    bool real_float() const { return precision == Precision::Float; }
    bool accum_double() const { return runtime.device_info().has_fp64; }
    std::size_t real_size() const { return real_float() ? sizeof(float) : sizeof(double); }
    std::size_t accum_size() const { return accum_double() ? sizeof(double) : sizeof(float); }

    // ---------------------------------------------- per-launch buffers
    // The active set; the second set (start(): one launch computes on one
    // set while the next is written to the other) is swapped in and out.
    cl::Buffer points, options, cells, batches, out_mean, out_m2;
    StagedInputs staged;  // the active set's staged inputs (stage())
    StagedInputs& idle_staged() { return idle_.staged; }
    void swap_buffer_sets();
    // Device buffers kept from launch to launch and grown when a launch
    // needs more: creating them per launch costs an allocation, a copy and
    // fresh pages (page faults) for every launch, which on a CPU device
    // weighs more than a closed-form kernel itself (docs/benchmarks.md,
    // "Closed forms: the engine's host work").
    void reserve_buffers(std::size_t items, std::size_t point_bytes, std::size_t accum_size);
    // Grows `target` to hold `items` work items and `point_doubles` doubles
    // of points (never while a launch uses it).
    void reserve_staged(StagedInputs& target, std::size_t items, std::size_t point_doubles);
    // The contents of `options`, when known.
    std::vector<int> options_written;
    bool options_known = false;

    // ---------------------------------------------- programs and kernels
    // The build options of the program of one (model, quantity, options,
    // method); every strategy's programs share them.
    std::string build_options(const BatchLaunch& l) const;
    // The program of `source` built with `options`, from the process's cache.
    cl::Program program(const std::string& source, const std::string& options);
    // The kernel `entry` of the program that source_of() returns, built with
    // l's build options: from `cache`, keyed by model and options, or built
    // (source_of called only then) and stored there.  `what` names the entry
    // point in the error when the program has no such kernel.
    template <class SourceFn>
    cl::Kernel& cached_kernel(std::map<std::string, cl::Kernel>& cache, const BatchLaunch& l,
                              const char* entry, const char* what, SourceFn&& source_of) {
        const std::string options = build_options(l);
        const std::string key = l.model->name + "\n" + options;
        auto it = cache.find(key);
        if (it != cache.end()) return it->second;
        cl::Program built = program(source_of(), options);
        try {
            return cache.emplace(key, cl::Kernel(built, entry)).first->second;
        } catch (const cl::Error& e) {
            throw entry_point_error(e, what, *l.model);
        }
    }
    // The error of a missing entry point `what` of `model`'s program.
    static OpenCLError entry_point_error(const cl::Error& e, const std::string& what,
                                         const ModelInfo& model);

    // ---------------------------------------------- launch geometry
    // Work-group size: a fixed kLocalSize (or tuning.local_size, a divisor
    // of 256 below 256; 0 or 256 = the driver's choice, on a global size
    // padded to a multiple of 256).  Fixed, because PoCL compiles a kernel
    // again for every new work-group size, and with the driver's choice that
    // size follows the global size, which varies from launch to launch.
    std::size_t local_group() const;
    // A launch of `items` work items is padded to whole work groups (the
    // kernels ignore the padding): round the global size up to a multiple of
    // 256 so PoCL can choose a reasonable work-group size (a prime global size
    // would force work-groups of one item), or with a fixed work-group size
    // (local_group()) to whole groups of it.
    std::size_t padded_global(std::size_t items) const;
    cl::NDRange local_range() const;

    // ---------------------------------------------- kernel arguments
    // The arguments the estimator's entry points take first, in the same
    // order (kernels/common/estimator.h): points, stride, options, n_options,
    // quantity, method, key0, key1, work_cell, work_batch.  Returns the index
    // of the next argument.
    int set_work_args(cl::Kernel& kernel, const BatchLaunch& l);
    // The three arguments the node-parallel node and group kernels take
    // first (kernels/common/node_parallel.h): options, n_options, quantity.
    void set_option_args(cl::Kernel& kernel, const BatchLaunch& l);

private:
    struct BufferSet {
        cl::Buffer points, cells, batches, out_mean, out_m2;
        std::size_t items = 0, point_bytes = 0, accum_size = 0;
        StagedInputs staged;
    };
    BufferSet idle_;
    std::size_t buffer_items_ = 0, buffer_point_bytes_ = 0, buffer_accum_size_ = 0;
};

// One way to run a launch on the device (see the top of this file).
class LaunchStrategy {
public:
    explicit LaunchStrategy(LaunchResources& resources) : r_(resources) {}
    virtual ~LaunchStrategy() = default;
    LaunchStrategy(const LaunchStrategy&) = delete;
    LaunchStrategy& operator=(const LaunchStrategy&) = delete;

    // Whether this strategy runs `l` under the present tuning (no side
    // effects; the backend asks the strategies in order and the first that
    // applies decides whether start() may overlap the launch).
    virtual bool applies(const BatchLaunch& l) const = 0;
    // Before the launch's inputs are written: the host-side work it needs
    // (node layouts) and its kernels, built or found.  False: it cannot run
    // this launch after all, and the next strategy that applies does.
    virtual bool prepare(const BatchLaunch& l) = 0;
    // Enqueues its kernels over every work item of `l`, whose inputs are
    // written; they leave the results in r_.out_mean / r_.out_m2, which the
    // backend reads.
    virtual void enqueue(const BatchLaunch& l) = 0;
    // Whether start() may enqueue the launch without blocking (and stage()
    // lend memory for it): only strategies that use no buffers or host
    // vectors of their own beyond the buffer sets.
    virtual bool overlaps() const { return false; }
    // The tuning changed (Backend::set_tuning): drop whatever depends on it.
    virtual void tuning_changed() {}

protected:
    LaunchResources& r_;
};

// The strategies, in the order the backend asks them (the first that
// applies and prepares runs the launch).
std::vector<std::unique_ptr<LaunchStrategy>> make_launch_strategies(LaunchResources& r);

// The individual strategies (one file each under host/engine/launch/).
std::unique_ptr<LaunchStrategy> make_usual_launch(LaunchResources& r);
std::unique_ptr<LaunchStrategy> make_walk_parallel_launch(LaunchResources& r);
// Sample-parallel and staged share their kernels (one program per build).
class SampleParallelCommon;
std::shared_ptr<SampleParallelCommon> make_sample_parallel_common(LaunchResources& r);
std::unique_ptr<LaunchStrategy> make_sample_parallel_launch(LaunchResources& r,
                                                            std::shared_ptr<SampleParallelCommon> c);
std::unique_ptr<LaunchStrategy> make_staged_launch(LaunchResources& r,
                                                   std::shared_ptr<SampleParallelCommon> c);
// Node-parallel flat, split and nested share their kernels and buffers.
class NodeParallelCommon;
std::shared_ptr<NodeParallelCommon> make_node_parallel_common(LaunchResources& r);
std::unique_ptr<LaunchStrategy> make_flat_node_launch(LaunchResources& r,
                                                      std::shared_ptr<NodeParallelCommon> c);
std::unique_ptr<LaunchStrategy> make_split_node_launch(LaunchResources& r,
                                                       std::shared_ptr<NodeParallelCommon> c);
std::unique_ptr<LaunchStrategy> make_nested_node_launch(LaunchResources& r,
                                                        std::shared_ptr<NodeParallelCommon> c);

}  // namespace brdftab::launch
