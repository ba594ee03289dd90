// engine.cpp — backends (OpenCL device, host serial reference) and the
// per-cell estimation loop with fixed or adaptive budgets.
#include "host/engine/engine.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <cmath>
#include <map>
#include <memory>
#include <mutex>
#include <new>
#include <thread>
#include <tuple>

#if defined(__linux__)
#include <sys/mman.h>
#endif

#include "kernels/common/estimator.h"
#include "host/core/error.h"
#include "host/core/text.h"
#include "host/engine/kernel_sources.h"
#include "host/engine/opencl_runtime.h"

namespace brdftab {

const char* precision_name(Precision p) { return p == Precision::Double ? "double" : "float"; }

Precision parse_precision(const std::string& s) {
    if (s == "double") return Precision::Double;
    if (s == "float") return Precision::Float;
    throw InputError("precision '" + s + "' is not valid; allowed: double, float");
}

void check_settings(const IntegrationSettings& s) {
    auto out_of_range = [](const char* name, const std::string& value, const std::string& range) {
        throw InputError(std::string(name) + " " + value + " is out of range; allowed: " + range);
    };
    if (s.samples > kMaxSampleCount)
        out_of_range("samples", std::to_string(s.samples), sample_count_range_text());
    if (s.max_samples < 1 || s.max_samples > kMaxSampleCount)
        out_of_range("max_samples", std::to_string(s.max_samples), sample_count_range_text());
    if (!(s.tolerance == 0 || (s.tolerance > 0 && s.tolerance < 1)))
        out_of_range("tolerance", number_text(s.tolerance), "(0, 1)");
    if (!(s.abs_floor > 0) || !std::isfinite(s.abs_floor))
        out_of_range("abs_floor", number_text(s.abs_floor), "> 0");
}

namespace {

// ------------------------------------------------------------ host backend

// Work items [begin, end) of a launch on the host: the very same kernel math,
// compiled as C++, one work item after another.
void run_host_items(const BatchLaunch& l, std::size_t begin, std::size_t end, double* mean,
                    double* m2) {
    int opts[BT_MAX_OPTIONS] = {0};
    for (std::size_t k = 0; k < l.options.size() && k < BT_MAX_OPTIONS; ++k)
        opts[k] = l.options[k];
    REAL point[BT_MAX_POINT] = {0};
    for (std::size_t w = begin; w < end; ++w) {
        std::copy_n(&l.points[w * l.stride], l.stride, point);
        bt_estimate_batch(l.model->host_fn, point, opts, l.quantity, l.method, l.key0, l.key1,
                          l.cells[w], l.batches[w], l.batch_size, &mean[w], &m2[w]);
    }
}

// Serial C++ evaluation of the very same kernel math: the reference path.
class HostBackend final : public Backend {
public:
    std::string device_name() const override { return "host"; }
    Precision precision() const override { return Precision::Double; }
    std::size_t preferred_slab() const override { return 1u << 14; }

    void run(const BatchLaunch& l, std::vector<double>& mean,
             std::vector<double>& m2) override {
        const std::size_t n = l.cells.size();
        if (!l.mean_out) mean.resize(n);  // every entry is written
        m2.resize(n);
        run_host_items(l, 0, n, l.mean_out ? l.mean_out : mean.data(), m2.data());
    }
};

// The host path on every core: the launch's work items split into one
// contiguous range per thread.  Each work item is computed exactly as by the
// serial backend (same function, same inputs, its own accumulators), so the
// results are bit-identical to --device host whatever the thread count.
class ThreadedHostBackend final : public Backend {
public:
    explicit ThreadedHostBackend(unsigned threads) : threads_(std::max(1u, threads)) {}
    std::string device_name() const override {
        return "host-threads (" + std::to_string(threads_) + " threads)";
    }
    Precision precision() const override { return Precision::Double; }
    std::size_t preferred_slab() const override { return (1u << 14) * threads_; }

    void run(const BatchLaunch& l, std::vector<double>& mean,
             std::vector<double>& m2) override {
        const std::size_t n = l.cells.size();
        if (!l.mean_out) mean.assign(n, 0.0);
        m2.assign(n, 0.0);
        double* const mean_out = l.mean_out ? l.mean_out : mean.data();
        const std::size_t parts = std::min<std::size_t>(threads_, n);
        if (parts <= 1) {
            run_host_items(l, 0, n, mean_out, m2.data());
            return;
        }
        std::vector<std::thread> pool;
        std::vector<std::exception_ptr> errors(parts);
        for (std::size_t t = 0; t < parts; ++t) {
            const std::size_t begin = n * t / parts, end = n * (t + 1) / parts;
            pool.emplace_back([&, t, begin, end] {
                try {
                    run_host_items(l, begin, end, mean_out, m2.data());
                } catch (...) {
                    errors[t] = std::current_exception();
                }
            });
        }
        for (auto& th : pool) th.join();
        for (auto& e : errors)
            if (e) std::rethrow_exception(e);
    }

private:
    unsigned threads_;
};

// ---------------------------------------------------------- OpenCL backend

}  // namespace

// The sample-parallel defaults every model declares (QuantityInfo::
// sample_parallel, in its registration file), as one list.
const std::vector<SampleParallelCase>& sample_parallel_default_cases() {
    static const std::vector<SampleParallelCase> cases = [] {
        std::vector<SampleParallelCase> out;
        for (const ModelInfo& m : all_models())
            for (const QuantityInfo& q : m.quantities)
                for (const SampleParallelRule& r : q.sample_parallel) {
                    SampleParallelCase c{m.name, q.name, r.method, {}};
                    for (const OptionChoice& o : r.options) c.options.emplace_back(o.option, o.choice);
                    out.push_back(std::move(c));
                }
        return out;
    }();
    return cases;
}

// The walk-parallel quantities every model declares (QuantityInfo::
// walk_parallel), as one list.
const std::vector<WalkParallelCase>& walk_parallel_cases() {
    static const std::vector<WalkParallelCase> cases = [] {
        std::vector<WalkParallelCase> out;
        for (const ModelInfo& m : all_models())
            for (const QuantityInfo& q : m.quantities)
                if (q.walk_parallel.enabled()) {
                    const WalkParallelFunctions& w = q.walk_parallel;
                    out.push_back({m.name, q.name, w.state, w.setup, w.begin, w.step, w.value});
                }
        return out;
    }();
    return cases;
}

// Node-parallel quadrature by default (engine.h): measured faster per
// CPU-second than the usual kernel on both bench cases that have node
// functions, a flat and a nested sum (1.8x each; docs/benchmarks.md
// "Node-parallel quadrature"), bit-identical to the usual kernel (tests/test_node_parallel.cpp).  A
// quantity can stay off by default (NodeParallelFunctions::by_default).
bool node_parallel_by_default() { return true; }

namespace {

// Whether `options` (indices, in the order of model.options) set the option
// `name` to `choice`.
bool option_is(const ModelInfo& model, const std::vector<int>& options, const std::string& name,
               const std::string& choice) {
    const OptionInfo* o = model.find_option(name);
    if (!o) return false;
    const std::size_t k = static_cast<std::size_t>(o - model.options.data());
    return k < options.size() && options[k] == o->index_of(choice);
}

}  // namespace

bool sample_parallel_by_default(const ModelInfo& model, const QuantityInfo& quantity,
                                Method method, const std::vector<int>& options) {
    return std::any_of(quantity.sample_parallel.begin(), quantity.sample_parallel.end(),
                       [&](const SampleParallelRule& r) {
                           return r.method == method &&
                                  std::all_of(r.options.begin(), r.options.end(),
                                              [&](const OptionChoice& o) {
                                                  return option_is(model, options, o.option, o.choice);
                                              });
                       });
}

namespace {

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
EntryRuns runs_within(const std::vector<std::uint32_t>& offset, std::size_t count, std::size_t cap) {
    EntryRuns out;
    for (std::size_t first = 0; first < count;) {
        std::size_t last = first + 1;
        while (last < count && offset[last + 1] - offset[first] <= cap) ++last;
        out.runs.emplace_back(first, last);
        out.most_size = std::max<std::size_t>(out.most_size, offset[last] - offset[first]);
        out.most_entries = std::max(out.most_entries, last - first);
        first = last;
    }
    return out;
}

// Built programs of this process, keyed by context, build options and source.
// A program holds a reference to its context, so a context's handle cannot be
// reused for another one while an entry names it.  PoCL's disk cache still
// makes the first build in a new process cheap.
cl::Program cached_program(ClRuntime& runtime, const std::string& source,
                           const std::string& options) {
    static std::mutex mutex;
    static std::map<std::string, cl::Program> programs;
    const std::string key = std::to_string(reinterpret_cast<std::uintptr_t>(runtime.context()())) +
                            "\n" + options + "\n" + source;
    std::lock_guard<std::mutex> lock(mutex);
    auto it = programs.find(key);
    if (it != programs.end()) return it->second;
    cl::Program program = runtime.build_program(source, options);
    programs.emplace(key, program);
    return program;
}


class OpenCLBackend final : public Backend {
public:
    OpenCLBackend(const DeviceInfo& device, Precision precision, std::string kernel_dir,
                  const EngineTuning& tuning)
        : runtime_(device), precision_(precision), kernel_dir_(std::move(kernel_dir)),
          tuning_(tuning) {
        if (precision == Precision::Double && !device.has_fp64)
            throw InputError("device '" + device.name +
                             "' does not support double precision (cl_khr_fp64); use "
                             "--precision float");
    }
    std::string device_name() const override { return runtime_.device_info().name; }
    Precision precision() const override { return precision_; }
    std::size_t preferred_slab() const override { return 1u << 17; }
    void set_tuning(const EngineTuning& tuning) override {
        tuning_ = tuning;
        last_kernel_ = nullptr;  // its build options may have changed
    }
    EngineTuning tuning() const override { return tuning_; }

    void run(const BatchLaunch& l, std::vector<double>& mean,
             std::vector<double>& m2) override {
        // A launch staged while another was unfinished is in the other
        // set's memory, which only start() switches to.
        if (l.staged && !unfinished_.empty())
            throw Error("OpenCL backend: run() of a launch staged for start()");
        while (!unfinished_.empty()) finish();
        enqueue_launch(l, mean, m2, nullptr);
    }

    // Overlapped launches (Backend::start): the writes, the kernel and the
    // reads of a launch are enqueued without blocking, on the buffer set the
    // unfinished launch (if any) does not use; finish() waits for the
    // oldest launch's last read.  Launches that stage data on the host
    // (float points, float accumulators) or run the sample-parallel or
    // node-parallel kernels (one set of scratch buffers and, for the node
    // layout, host vectors) run synchronously inside start() instead.
    void start(const BatchLaunch& l, std::vector<double>& mean,
               std::vector<double>& m2) override {
        if (unfinished_.size() >= 2)
            throw Error("OpenCL backend: start() with two launches unfinished");
        if (!overlaps(l)) {
            if (l.staged) throw Error("OpenCL backend: a staged launch that does not overlap");
            run(l, mean, m2);
            unfinished_.push_back(cl::Event());  // already complete
            return;
        }
        if (!unfinished_.empty()) swap_buffer_sets();
        cl::Event done;
        enqueue_launch(l, mean, m2, &done);
        unfinished_.push_back(done);
    }

    void finish() override {
        if (unfinished_.empty()) return;
        cl::Event done = unfinished_.front();
        unfinished_.pop_front();
        if (!done()) return;
        try {
            done.wait();
        } catch (const cl::Error& e) {
            abandon();
            throw OpenCLError(e.what(), e.err(), "while waiting for a kernel launch");
        }
    }

    void abandon() noexcept override {
        try {
            runtime_.queue().finish();
        } catch (...) {
        }
        unfinished_.clear();
    }

    // The staged inputs live in host memory of the buffer set the launch
    // will use (start(): the active set when nothing is unfinished, else the
    // idle one), wrapped by CL_MEM_USE_HOST_PTR buffers.  On PoCL's CPU
    // device such a buffer's storage is that memory, and the write that
    // hands it over (enqueue_launch) is no copy: the caller's one copy of a
    // point into its work item's slot is the only one (a write from other
    // memory would be a second copy, PoCL's, of the whole launch).  The
    // memory is kept from launch to launch: no page faults after the first.
    bool stage(const BatchLaunch& l, std::size_t items, LaunchStaging& staging) override {
        if (items == 0 || unfinished_.size() >= 2 || !overlaps(l)) return false;
        StagedInputs& target = unfinished_.empty() ? staged_ : idle_.staged;
        const std::size_t point_doubles = items * l.stride;
        try {
            if (items > target.items || point_doubles > target.point_doubles) {
                // Grown geometrically as launches grow; never while a launch
                // uses this set (start() alternates the sets).
                cl::Context& ctx = runtime_.context();
                const std::size_t want_items = std::max(items, 2 * target.items);
                const std::size_t want_doubles = std::max(point_doubles, 2 * target.point_doubles);
                target.points = target.cells = target.batches = cl::Buffer();
                target = StagedInputs{};
                target.points_host = HostMemory(want_doubles * sizeof(double));
                target.cells_host = HostMemory(want_items * sizeof(std::uint32_t));
                target.batches_host = HostMemory(want_items * sizeof(std::uint32_t));
                const cl_mem_flags flags = CL_MEM_READ_ONLY | CL_MEM_USE_HOST_PTR;
                target.points = cl::Buffer(ctx, flags, want_doubles * sizeof(double),
                                           target.points_host.get());
                target.cells = cl::Buffer(ctx, flags, want_items * sizeof(std::uint32_t),
                                          target.cells_host.get());
                target.batches = cl::Buffer(ctx, flags, want_items * sizeof(std::uint32_t),
                                            target.batches_host.get());
                target.items = want_items;
                target.point_doubles = want_doubles;
            }
        } catch (const cl::Error& e) {
            throw OpenCLError(e.what(), e.err(), "while creating the launch's input buffers");
        }
        staging.points = static_cast<double*>(target.points_host.get());
        staging.cells = static_cast<std::uint32_t*>(target.cells_host.get());
        staging.batches = static_cast<std::uint32_t*>(target.batches_host.get());
        return true;
    }

private:
    // Page-aligned host memory (CL_MEM_USE_HOST_PTR wants the device's base
    // alignment; a page covers every device's).
    class HostMemory {
    public:
        HostMemory() = default;
        explicit HostMemory(std::size_t bytes) {
            constexpr std::size_t kPage = 4096;
            const std::size_t rounded = std::max<std::size_t>(kPage, (bytes + kPage - 1) / kPage * kPage);
            data_.reset(std::aligned_alloc(kPage, rounded));
            if (!data_) throw std::bad_alloc();
        }
        void* get() const { return data_.get(); }

    private:
        struct Free {
            void operator()(void* p) const { std::free(p); }
        };
        std::unique_ptr<void, Free> data_;
    };
    // One buffer set's staged inputs (stage()): the host memory and the
    // buffers over it.  The buffers are declared after the memory, so they
    // are released before it is freed.
    struct StagedInputs {
        HostMemory points_host, cells_host, batches_host;
        cl::Buffer points, cells, batches;
        std::size_t items = 0, point_doubles = 0;
    };

    // Whether start() enqueues this launch without blocking (and stage()
    // lends memory for it): double on a device with fp64, the usual kernel.
    bool overlaps(const BatchLaunch& l) const {
        return precision_ == Precision::Double && runtime_.device_info().has_fp64 &&
               !use_sample_parallel(l) && !use_node_parallel(l);
    }

    // One launch's writes, kernel and reads on the active buffer set.  With
    // `done` null every call blocks until the results are in `mean`/`m2`;
    // otherwise nothing blocks and `done` is the event of the last read.
    void enqueue_launch(const BatchLaunch& l, std::vector<double>& mean,
                        std::vector<double>& m2, cl::Event* done) {
        const std::size_t n = l.work_items();
        const bool accum_double = runtime_.device_info().has_fp64;
        // Every entry is overwritten by the read below: no zero-fill.
        if (!l.mean_out) mean.resize(n);
        if (l.need_m2 || !accum_double) m2.resize(n);  // else left as it is: never read
        if (n == 0) return;
        double* const mean_out = l.mean_out ? l.mean_out : mean.data();
        const bool sample_parallel = use_sample_parallel(l);
        // Node-parallel quadrature (lays out the nodes on the host first).
        const bool node_parallel = !sample_parallel && use_node_parallel(l) &&
                                   (node_functions(l)->nested() || lay_out_nodes(l));
        NodeParallelKernels* nodes = node_parallel ? &node_parallel_kernels_for(l) : nullptr;
        cl::Kernel* kernel_ptr = sample_parallel || node_parallel ? nullptr : &kernel_for(l);
        SampleParallelKernels* pair = sample_parallel ? &sample_parallel_kernels_for(l) : nullptr;
        const bool real_float = precision_ == Precision::Float;
        try {
            cl::CommandQueue& queue = runtime_.queue();
            const std::size_t real_size = real_float ? sizeof(float) : sizeof(double);
            const std::size_t accum_size = accum_double ? sizeof(double) : sizeof(float);
            reserve_buffers(n, l.points.size() * real_size, accum_size);
            // The writes need not block: the in-order queue runs them before
            // the kernel, and their sources (the launch, points_f_) are not
            // touched before the blocking read at the end.
            if (l.staged) {
                // From the buffers' own host memory (stage()): what the
                // specification asks before a kernel reads memory the host
                // wrote, and no copy on PoCL's CPU device.
                if (!overlaps(l) || n > staged_.items || n * l.stride > staged_.point_doubles)
                    throw Error("OpenCL backend: staged launch does not fit its buffers");
                queue.enqueueWriteBuffer(staged_.points, CL_FALSE, 0, n * l.stride * sizeof(double),
                                         staged_.points_host.get());
                queue.enqueueWriteBuffer(staged_.cells, CL_FALSE, 0, n * sizeof(std::uint32_t),
                                         staged_.cells_host.get());
                queue.enqueueWriteBuffer(staged_.batches, CL_FALSE, 0, n * sizeof(std::uint32_t),
                                         staged_.batches_host.get());
            } else if (real_float) {
                points_f_.assign(l.points.begin(), l.points.end());
                queue.enqueueWriteBuffer(points_, CL_FALSE, 0, points_f_.size() * sizeof(float),
                                         points_f_.data());
            } else {
                queue.enqueueWriteBuffer(points_, CL_FALSE, 0, l.points.size() * sizeof(double),
                                         l.points.data());
            }
            if (!options_known_ || l.options != options_written_) {
                int opts[BT_MAX_OPTIONS] = {0};
                std::copy_n(l.options.begin(), std::min<std::size_t>(l.options.size(), BT_MAX_OPTIONS),
                            opts);
                queue.enqueueWriteBuffer(options_, CL_TRUE, 0, sizeof(opts), opts);
                options_written_ = l.options;
                options_known_ = true;
            }
            if (!l.staged) {
                queue.enqueueWriteBuffer(cells_, CL_FALSE, 0, n * sizeof(std::uint32_t),
                                         l.cells.data());
                queue.enqueueWriteBuffer(batches_, CL_FALSE, 0, n * sizeof(std::uint32_t),
                                         l.batches.data());
            }
            if (sample_parallel) {
                enqueue_sample_parallel(l, *pair, accum_size, real_size);
            } else if (node_parallel && node_functions(l)->nested()) {
                enqueue_nested_node_parallel(l, *nodes, real_size);
            } else if (node_parallel) {
                enqueue_node_parallel(l, *nodes, real_size);
            } else {
                cl::Kernel& kernel = *kernel_ptr;
                int a = set_work_args(kernel, l);
                kernel.setArg(a++, static_cast<cl_uint>(n));
                kernel.setArg(a++, static_cast<cl_uint>(l.batch_size));
                kernel.setArg(a++, out_mean_);
                kernel.setArg(a++, out_m2_);
                if (use_walk_parallel(l))  // its own work-group size (walk_group())
                    queue.enqueueNDRangeKernel(kernel, cl::NullRange,
                                               cl::NDRange((n + walk_group() - 1) / walk_group() * walk_group()),
                                               cl::NDRange(walk_group()));
                else
                    queue.enqueueNDRangeKernel(kernel, cl::NullRange, cl::NDRange(padded_global(n)),
                                               local_range());
            }
            if (accum_double) {
                const cl_bool block = done ? CL_FALSE : CL_TRUE;
                if (l.need_m2) {
                    queue.enqueueReadBuffer(out_mean_, CL_FALSE, 0, n * sizeof(double), mean_out);
                    queue.enqueueReadBuffer(out_m2_, block, 0, n * sizeof(double), m2.data(),
                                            nullptr, done);
                } else {
                    queue.enqueueReadBuffer(out_mean_, block, 0, n * sizeof(double), mean_out,
                                            nullptr, done);
                }
            } else {
                std::vector<float>& tmp = accum_f_;
                tmp.resize(2 * n);
                queue.enqueueReadBuffer(out_mean_, CL_FALSE, 0, n * sizeof(float), tmp.data());
                queue.enqueueReadBuffer(out_m2_, CL_TRUE, 0, n * sizeof(float), tmp.data() + n);
                std::copy_n(tmp.begin(), n, mean_out);
                std::copy_n(tmp.begin() + static_cast<std::ptrdiff_t>(n), n, m2.begin());
            }
        } catch (const cl::Error& e) {
            // Writes may still be pending from the launch's memory, which the
            // caller frees after the throw: let them finish first.
            try {
                runtime_.queue().finish();
            } catch (const cl::Error&) {
            }
            unfinished_.clear();
            options_known_ = false;
            throw OpenCLError(e.what(), e.err(), "while running the kernel of model '" + l.model->name + "'");
        }
    }

private:
    // The quantity a launch computes (its id in the model's list).
    static const QuantityInfo* launch_quantity(const BatchLaunch& l) {
        for (const QuantityInfo& q : l.model->quantities)
            if (q.id == l.quantity) return &q;
        return nullptr;
    }

    // The sample-parallel pair of kernels (kernels/common/estimator.h,
    // BT_DEFINE_SAMPLE_PARALLEL_KERNELS) of one (model, quantity, options,
    // method).
    // With `redo`: the sample and reduce kernels come from a fixed-step
    // build (uses_fixed_step_solver), and redo, from the usual build,
    // computes again every sample that build left as NaN.
    // Staged (QuantityInfo::staged): stage (from the fixed-step build where
    // there is one, with stage_redo from the usual build), rest and reduce
    // run instead of sample and reduce (estimator.h, "Staged samples").
    struct SampleParallelKernels {
        cl::Kernel sample, reduce, redo;
        bool has_redo = false;
        cl::Kernel stage, stage_redo, rest;
        std::size_t stage_size = 0;  // 0: not staged
    };

    // Launches whose sample-parallel kernels use microfacet.h's fixed-step
    // search (BT_MF_SOLVE_STEPS; QuantityInfo::fixed_step_solver, double
    // precision only): the search's loop is what kept the work-item loop
    // scalar; with a fixed number of steps it vectorises, and the rare
    // sample whose search has not ended is redone with the loop, so the
    // values are the usual kernel's (docs/benchmarks.md, "Sample-parallel
    // launches").
    bool uses_fixed_step_solver(const BatchLaunch& l) const {
        if (precision_ != Precision::Double || !runtime_.device_info().has_fp64) return false;
        const QuantityInfo* q = launch_quantity(l);
        if (!q) return false;
        return std::any_of(q->fixed_step_solver.begin(), q->fixed_step_solver.end(),
                           [&](const OptionChoice& o) {
                               return option_is(*l.model, l.options, o.option, o.choice);
                           });
    }

    // Whether this launch runs sample-parallel: only Monte Carlo / RQMC
    // batches of several samples that fit the scratch cap, and then as
    // tuning_.sample_parallel says (Off: never, On: always), or by default
    // where sample_parallel_by_default() says so.
    bool use_sample_parallel(const BatchLaunch& l) const {
        if (l.method != BT_METHOD_MC && l.method != BT_METHOD_RQMC) return false;
        if (l.batch_size < 2 || l.batch_size > sample_parallel_scratch_samples()) return false;
        if (tuning_.sample_parallel == LaunchChoice::Off) return false;
        if (tuning_.sample_parallel == LaunchChoice::On) return true;
        const Method method = l.method == BT_METHOD_MC ? Method::MonteCarlo : Method::Rqmc;
        const QuantityInfo* q = launch_quantity(l);
        if (!q) return false;
        // A staged quantity's first stage vectorises only with the fixed-step
        // search: elsewhere its launch stays the usual one.
        if (q->staged.enabled() && !uses_fixed_step_solver(l)) return false;
        return sample_parallel_by_default(*l.model, *q, method, l.options);
    }

    // The arguments both entry points take first, in the same order
    // (kernels/common/estimator.h): points, stride, options, n_options,
    // quantity, method, key0, key1, work_cell, work_batch.  Returns the index
    // of the next argument.
    int set_work_args(cl::Kernel& kernel, const BatchLaunch& l) {
        int a = 0;
        kernel.setArg(a++, l.staged ? staged_.points : points_);
        kernel.setArg(a++, static_cast<cl_uint>(l.stride));
        kernel.setArg(a++, options_);
        kernel.setArg(a++, static_cast<cl_uint>(l.options.size()));
        kernel.setArg(a++, static_cast<cl_int>(l.quantity));
        kernel.setArg(a++, static_cast<cl_uint>(l.method));
        kernel.setArg(a++, static_cast<cl_uint>(l.key0));
        kernel.setArg(a++, static_cast<cl_uint>(l.key1));
        kernel.setArg(a++, l.staged ? staged_.cells : cells_);
        kernel.setArg(a++, l.staged ? staged_.batches : batches_);
        return a;
    }

    // The three arguments the node-parallel node and group kernels take
    // first (kernels/common/node_parallel.h): options, n_options, quantity.
    void set_option_args(cl::Kernel& kernel, const BatchLaunch& l) {
        kernel.setArg(0, options_);
        kernel.setArg(1, static_cast<cl_uint>(l.options.size()));
        kernel.setArg(2, static_cast<cl_int>(l.quantity));
    }

    // A launch of `items` work items is padded to whole work groups (the
    // kernels ignore the padding): round the global size up to a multiple of
    // 256 so PoCL can choose a reasonable work-group size (a prime global size
    // would force work-groups of one item), or with a fixed work-group size
    // (local_group()) to whole groups of it.
    std::size_t padded_global(std::size_t items) const {
        const std::size_t group = local_group();
        return (items + group - 1) / group * group;
    }
    cl::NDRange local_range() const {
        const std::size_t group = local_group();
        return group == 256 ? cl::NullRange : cl::NDRange(group);
    }

    // Samples per sub-launch of the sample-parallel path
    // (tuning_.sample_parallel_scratch_samples); a launch of more work items
    // is split into sub-launches of whole batches, which changes no result;
    // a batch larger than the cap runs the usual kernel.
    std::size_t sample_parallel_scratch_samples() const {
        // At most 2^31 samples: a sub-launch's sample count is a uint.
        const std::size_t v =
            std::min(tuning_.sample_parallel_scratch_samples, std::size_t{1} << 31);
        return v >= 2 ? v : kSampleParallelScratchSamples;
    }

    // Enqueues the sample and reduce kernels over every work item of `l`,
    // in sub-launches of at most sample_parallel_scratch_samples() samples.
    // The inputs are already written; the outputs are read by run().
    void enqueue_sample_parallel(const BatchLaunch& l, SampleParallelKernels& k,
                                 std::size_t accum_size, std::size_t real_size) {
        cl::CommandQueue& queue = runtime_.queue();
        const std::size_t n = l.cells.size();
        const std::size_t batch = l.batch_size;
        const std::size_t per_sub = std::max<std::size_t>(1, sample_parallel_scratch_samples() / batch);
        const std::size_t scratch_bytes = std::min(n, per_sub) * batch * accum_size;
        if (scratch_bytes > scratch_bytes_) {
            // In-order queue: a sub-launch's sample kernel runs after the
            // previous reduce kernel has read the buffer, so one suffices.
            scratch_ = cl::Buffer(runtime_.context(), CL_MEM_READ_WRITE, scratch_bytes);
            scratch_bytes_ = scratch_bytes;
        }
        // The kernels run per sample: the sample kernel, and the redo kernel,
        // which takes its arguments, after it; staged: stage, its redo (both
        // write the stage buffer) and rest (scratch, then the stage buffer).
        std::vector<cl::Kernel*> per_sample{&k.sample};
        if (k.has_redo) per_sample.push_back(&k.redo);
        if (k.stage_size > 0) {
            const std::size_t stage_bytes = std::min(n, per_sub) * batch * k.stage_size * real_size;
            if (stage_bytes > stage_bytes_) {
                stage_ = cl::Buffer(runtime_.context(), CL_MEM_READ_WRITE, stage_bytes);
                stage_bytes_ = stage_bytes;
            }
            per_sample = {&k.stage};
            if (k.has_redo) per_sample.push_back(&k.stage_redo);
            per_sample.push_back(&k.rest);
        }
        int sample_first_arg = 0;  // first_work, n_samples
        for (cl::Kernel* kernel : per_sample) {
            sample_first_arg = set_work_args(*kernel, l);
            if (k.stage_size == 0)
                set_args_from(*kernel, sample_first_arg + 2, static_cast<cl_uint>(batch), scratch_);
            else if (kernel == &k.rest)
                set_args_from(*kernel, sample_first_arg + 2, static_cast<cl_uint>(batch), scratch_,
                              stage_);
            else
                set_args_from(*kernel, sample_first_arg + 2, static_cast<cl_uint>(batch), stage_);
        }
        k.reduce.setArg(0, scratch_);
        k.reduce.setArg(3, static_cast<cl_uint>(batch));
        k.reduce.setArg(4, out_mean_);
        k.reduce.setArg(5, out_m2_);
        const cl::NDRange local = local_range();
        for (std::size_t first = 0; first < n; first += per_sub) {
            const std::size_t count = std::min(per_sub, n - first);
            const std::size_t samples = count * batch;
            for (cl::Kernel* kernel : per_sample) {
                set_args_from(*kernel, sample_first_arg, static_cast<cl_uint>(first),
                              static_cast<cl_uint>(samples));
                queue.enqueueNDRangeKernel(*kernel, cl::NullRange, cl::NDRange(padded_global(samples)),
                                           local);
            }
            k.reduce.setArg(1, static_cast<cl_uint>(first));
            k.reduce.setArg(2, static_cast<cl_uint>(count));
            queue.enqueueNDRangeKernel(k.reduce, cl::NullRange, cl::NDRange(padded_global(count)), local);
        }
    }

    SampleParallelKernels& sample_parallel_kernels_for(const BatchLaunch& l) {
        const ModelInfo& model = *l.model;
        const std::string options = build_options(l);
        const bool fixed = uses_fixed_step_solver(l);
        std::string fixed_options;
        if (fixed) {
            fixed_options = options + " -D BT_MF_SOLVE_STEPS=1";
            // tuning_.fixed_solver_steps_x/y: other step counts for the x
            // and y searches (tests: 1, 1 makes most samples take the redo).
            const int sx = tuning_.fixed_solver_steps_x, sy = tuning_.fixed_solver_steps_y;
            if (sx > 0 && sy > 0)
                fixed_options += " -D BT_MF_SOLVE_STEPS_X=" + std::to_string(sx) +
                                 " -D BT_MF_SOLVE_STEPS_Y=" + std::to_string(sy);
        }
        const std::string key = model.name + "\n" + options + "\n" + fixed_options;
        auto it = sample_parallel_kernels_.find(key);
        if (it != sample_parallel_kernels_.end()) return it->second;
        const QuantityInfo* quantity = launch_quantity(l);
        const QuantityInfo::StagedSample staged =
            quantity && quantity->staged.enabled() ? quantity->staged : QuantityInfo::StagedSample{};
        const std::string source =
            sample_parallel_kernel_source(model.kernel_header, model.sample_function, kernel_dir_,
                                          staged.size, staged.stage, staged.rest);
        cl::Program program = cached_program(runtime_, source, options);
        try {
            SampleParallelKernels k;
            if (staged.enabled()) {
                k.stage_size = static_cast<std::size_t>(staged.size);
                k.rest = cl::Kernel(program, kStageRestKernelName);
                k.reduce = cl::Kernel(program, kReduceKernelName);
                if (fixed) {
                    cl::Program fixed_program = cached_program(runtime_, source, fixed_options);
                    k.stage = cl::Kernel(fixed_program, kStageKernelName);
                    k.stage_redo = cl::Kernel(program, kStageRedoKernelName);
                    k.has_redo = true;
                } else {
                    k.stage = cl::Kernel(program, kStageKernelName);
                }
            } else if (fixed) {
                cl::Program fixed_program = cached_program(runtime_, source, fixed_options);
                k.sample = cl::Kernel(fixed_program, kSampleKernelName);
                k.reduce = cl::Kernel(fixed_program, kReduceKernelName);
                k.redo = cl::Kernel(program, kRedoKernelName);
                k.has_redo = true;
            } else {
                k.sample = cl::Kernel(program, kSampleKernelName);
                k.reduce = cl::Kernel(program, kReduceKernelName);
            }
            return sample_parallel_kernels_.emplace(key, std::move(k)).first->second;
        } catch (const cl::Error& e) {
            throw OpenCLError(e.what(), e.err(), "sample-parallel entry points of model '" +
                                                     model.name + "' (kernels/" +
                                                     model.kernel_header + ")");
        }
    }

    // ------------------------------------------------ walk-parallel launch
    // (kernels/common/walk_parallel.h; the cases: walk_parallel_cases()).
    static const WalkParallelFunctions* walk_parallel_case(const BatchLaunch& l) {
        const QuantityInfo* q = launch_quantity(l);
        return q && q->walk_parallel.enabled() ? &q->walk_parallel : nullptr;
    }
    // Monte Carlo only: with RQMC the round runs the first collision's
    // Sobol' draws (if-converted) for every lane in every round, and the
    // launch measured no faster than the usual kernel (docs/benchmarks.md).
    bool use_walk_parallel(const BatchLaunch& l) const {
        if (l.method != BT_METHOD_MC || !tuning_.walk_parallel) return false;
        return walk_parallel_case(l) != nullptr;
    }
    // The work-group size of walk-parallel launches: kWalkLocalSize (one
    // SIMD vector of doubles as PoCL vectorised the round: width 4), or
    // tuning_.walk_local_size (1..256).  A group runs as many rounds as its
    // busiest work item, so small groups waste fewer lanes on the long walks'
    // tails: measured 4 > 8 > 16 > 64, and 1 or 2 (no SIMD) slower
    // (docs/benchmarks.md, "Walk-parallel launch").
    std::size_t walk_group() const {
        const std::size_t chosen = tuning_.walk_local_size;
        const std::size_t group = chosen >= 1 && chosen <= 256 ? chosen : kWalkLocalSize;
        return std::min<std::size_t>(group, runtime_.device_info().max_work_group_size);
    }
    cl::Kernel& walk_parallel_kernel_for(const BatchLaunch& l) {
        return cached_kernel(walk_parallel_kernels_, l, kWalkKernelName,
                             "walk-parallel entry point", [&] {
                                 const WalkParallelFunctions& c = *walk_parallel_case(l);
                                 return walk_parallel_kernel_source(
                                     l.model->kernel_header,
                                     {c.state, c.setup, c.begin, c.step, c.value}, kernel_dir_);
                             });
    }

    // ------------------------------------------- node-parallel quadrature
    // The node-parallel kernels (kernels/common/node_parallel.h) of one
    // (model, quantity, options, method).
    struct NodeParallelKernels {
        cl::Kernel prepare, node, sum;
        cl::Kernel group = {}, chunk = {}, reduce = {};  // nested sums only
        // Split terms (flat sums; NodeParallelFunctions::split()): the
        // kernels of the first and second form, instead of node.
        cl::Kernel first = {}, second = {};
        bool split = false;
        // Nested sums: the table prepare reads, computed by the program's
        // table kernel before its first launch.
        cl::Kernel table_kernel = {};
        cl::Buffer table = {};
        bool table_ready = false;
    };

    static const NodeParallelFunctions* node_functions(const BatchLaunch& l) {
        const QuantityInfo* q = launch_quantity(l);
        return q && q->node_parallel.enabled() ? &q->node_parallel : nullptr;
    }

    // Whether this launch runs node-parallel: quadrature (or closed-form)
    // launches of one-sample batches of a quantity that names node functions
    // (QuantityInfo::node_parallel), then as tuning_.node_parallel says (Off:
    // never, On: always), by default where node_parallel_by_default() says so.
    bool use_node_parallel(const BatchLaunch& l) const {
        if (l.method != BT_METHOD_QUADRATURE && l.method != BT_METHOD_CLOSED) return false;
        if (l.batch_size != 1 || !node_functions(l)) return false;
        if (tuning_.node_parallel == LaunchChoice::Off) return false;
        if (tuning_.node_parallel == LaunchChoice::On) return true;
        return node_parallel_by_default() && node_functions(l)->by_default;
    }

    // Nodes per sub-launch of the node-parallel path (the scratch buffer's
    // size: 2^22 terms); a launch with more nodes is split into sub-launches
    // of whole work items, which changes no result (a work item with more
    // nodes than the cap gets a sub-launch of its own);
    // tuning_.node_parallel_scratch_nodes sets another cap.
    std::size_t node_parallel_scratch_nodes() const {
        const std::size_t v = std::min(tuning_.node_parallel_scratch_nodes, std::size_t{1} << 31);
        return v >= 1 ? v : kNodeParallelScratchNodes;
    }

    // The node layout of `l` (kernels/common/node_parallel.h): every work
    // item's node count from the host count function, their exclusive prefix
    // sum node_offset_host_[0..n] and the work item of every node.  False (and
    // the usual kernel runs) when the node numbers would not fit a uint.
    // tuning_.node_layout_cap = N >= 0 lays out at most N nodes per work
    // item, for tests of the sum kernel's own terms (what it does when the
    // device counts more nodes than the host, e.g. in float).
    bool lay_out_nodes(const BatchLaunch& l) {
        const NodeParallelFunctions& f = *node_functions(l);
        const long long layout_cap = tuning_.node_layout_cap;
        const std::size_t n = l.cells.size();
        int opts[BT_MAX_OPTIONS] = {0};
        for (std::size_t k = 0; k < l.options.size() && k < BT_MAX_OPTIONS; ++k)
            opts[k] = l.options[k];
        double point[BT_MAX_POINT] = {0};
        bt_sampler s{};
        s.key0 = l.key0;
        s.key1 = l.key1;
        s.method = l.method;
        s.sample = 0;
        // Split terms: the first-form nodes (a work item's first host_split
        // ones), node_first_before_[w]: those of the work items before w.
        // tuning_.node_split_shift = D moves every guess by D nodes (tests:
        // the nodes put on the wrong side must come out the same).
        const bool split = f.split() && use_split_terms();
        const int shift = split ? tuning_.node_split_shift : 0;
        node_first_before_.assign(split ? n + 1 : 0, 0);
        std::uint32_t firsts = 0;
        node_offset_host_.resize(n + 1);
        std::uint64_t total = 0;
        for (std::size_t w = 0; w < n; ++w) {
            std::copy_n(&l.points[w * l.stride], l.stride, point);
            s.cell = l.cells[w];
            s.batch = l.batches[w];
            int count = f.host_count(point, opts, l.quantity, &s);
            if (layout_cap >= 0 && count > layout_cap) count = static_cast<int>(layout_cap);
            count = std::max(count, 0);
            if (total > 0xFFFFFFFFull) return false;
            node_offset_host_[w] = static_cast<std::uint32_t>(total);
            total += static_cast<std::uint64_t>(count);
            if (split) {
                node_first_before_[w] = firsts;
                const int guess = f.host_split(point, opts, l.quantity, &s) + shift;
                firsts += static_cast<std::uint32_t>(std::clamp(guess, 0, count));
            }
        }
        if (total > 0xFFFFFFFFull) return false;
        if (split) node_first_before_[n] = firsts;
        node_offset_host_[n] = static_cast<std::uint32_t>(total);
        node_item_host_.resize(static_cast<std::size_t>(total));
        for (std::size_t w = 0; w < n; ++w)
            std::fill(node_item_host_.begin() + node_offset_host_[w],
                      node_item_host_.begin() + node_offset_host_[w + 1],
                      static_cast<std::uint32_t>(w));
        // Split terms: both node lists, first form then second, each in
        // node order.
        node_list_host_.clear();
        if (split) {
            node_list_host_.resize(static_cast<std::size_t>(total));
            for (std::size_t w = 0; w < n; ++w) {
                const std::uint32_t a = node_first_before_[w], b = node_first_before_[w + 1];
                const std::uint32_t base = node_offset_host_[w];
                for (std::uint32_t j = 0; j < b - a; ++j) node_list_host_[a + j] = base + j;
                const std::uint32_t second_at = firsts + base - a;  // list B follows list A
                for (std::uint32_t j = b - a; j < node_offset_host_[w + 1] - base; ++j)
                    node_list_host_[second_at + j - (b - a)] = base + j;
            }
        }
        return true;
    }

    // Split terms on (NodeParallelFunctions::split()) unless
    // tuning_.split_node_terms is false (one node kernel with both forms;
    // the same bits either way, tests/test_node_parallel.cpp).
    bool use_split_terms() const { return tuning_.split_node_terms; }

    // Writes the node layout and enqueues the node and sum kernels over every
    // work item of `l`, in sub-launches of at most
    // node_parallel_scratch_nodes() nodes.  The launch's inputs are already
    // written; the outputs are read by run().
    void enqueue_node_parallel(const BatchLaunch& l, NodeParallelKernels& k, std::size_t real_size) {
        cl::CommandQueue& queue = runtime_.queue();
        cl::Context& ctx = runtime_.context();
        const std::size_t n = l.cells.size();
        const std::vector<std::uint32_t>& offset = node_offset_host_;
        // Sub-launches [first, last) of whole work items.
        const EntryRuns sub_launches = runs_within(offset, n, node_parallel_scratch_nodes());
        const std::size_t most_nodes = sub_launches.most_size, most_items = sub_launches.most_entries;
        const NodeParallelFunctions& f = *node_functions(l);
        // Buffers grown geometrically and kept (reserve_buffers); the
        // scratch once per launch: the in-order queue runs a sub-launch's
        // node kernel after the previous sum kernel has read it.
        const std::size_t total = offset[n];
        if (n + 1 > node_offset_items_) {
            node_offset_items_ = std::max(n + 1, 2 * node_offset_items_);
            node_offset_ = cl::Buffer(ctx, CL_MEM_READ_ONLY, node_offset_items_ * sizeof(std::uint32_t));
        }
        if (std::max<std::size_t>(total, 1) > node_item_items_) {
            node_item_items_ = std::max(std::max<std::size_t>(total, 1), 2 * node_item_items_);
            node_item_ = cl::Buffer(ctx, CL_MEM_READ_ONLY, node_item_items_ * sizeof(std::uint32_t));
        }
        if (most_nodes * real_size > node_scratch_bytes_) {
            node_scratch_bytes_ = most_nodes * real_size;
            node_scratch_ = cl::Buffer(ctx, CL_MEM_READ_WRITE, node_scratch_bytes_);
        }
        const std::size_t state_bytes =
            most_items * static_cast<std::size_t>(std::max(f.state_size, 1)) * real_size;
        if (state_bytes > node_state_bytes_) {
            node_state_bytes_ = state_bytes;
            node_state_ = cl::Buffer(ctx, CL_MEM_READ_WRITE, node_state_bytes_);
        }
        // Not blocking: the host vectors are members, unchanged until the
        // blocking read that ends run().
        queue.enqueueWriteBuffer(node_offset_, CL_FALSE, 0, (n + 1) * sizeof(std::uint32_t),
                                 offset.data());
        if (total > 0)
            queue.enqueueWriteBuffer(node_item_, CL_FALSE, 0, total * sizeof(std::uint32_t),
                                     node_item_host_.data());
        const bool split = k.split && node_list_host_.size() == total && node_first_before_.size() == n + 1;
        if (split && total > 0) {
            if (total > node_list_items_) {
                node_list_items_ = std::max(total, 2 * node_list_items_);
                node_list_ = cl::Buffer(ctx, CL_MEM_READ_ONLY, node_list_items_ * sizeof(std::uint32_t));
            }
            queue.enqueueWriteBuffer(node_list_, CL_FALSE, 0, total * sizeof(std::uint32_t),
                                     node_list_host_.data());
        }
        const int prepare_first_arg = set_work_args(k.prepare, l);  // first_work, n_work, state
        k.prepare.setArg(prepare_first_arg + 2, node_state_);
        // options, n_options, quantity, node_item, node_offset, first_work,
        // first_node, n_nodes, state, scratch
        // first and second (split terms): the same, then node_list, list_first
        for (cl::Kernel* kernel : {&k.node, &k.first, &k.second}) {
            if (kernel != &k.node && !split) continue;
            set_option_args(*kernel, l);
            kernel->setArg(3, node_item_);
            kernel->setArg(4, node_offset_);
            kernel->setArg(8, node_state_);
            kernel->setArg(9, node_scratch_);
            if (kernel != &k.node) kernel->setArg(10, node_list_);
        }
        const std::uint32_t firsts = split ? node_first_before_[n] : 0;
        const int sum_first_arg = set_work_args(k.sum, l);  // node_offset, first_node, first_work, n_work, scratch, out_mean, out_m2
        k.sum.setArg(sum_first_arg, node_offset_);
        k.sum.setArg(sum_first_arg + 4, node_scratch_);
        k.sum.setArg(sum_first_arg + 5, out_mean_);
        k.sum.setArg(sum_first_arg + 6, out_m2_);
        const cl::NDRange local = local_range();
        for (const auto& [first, last] : sub_launches.runs) {
            const std::size_t nodes = offset[last] - offset[first];
            if (nodes > 0) {
                k.prepare.setArg(prepare_first_arg, static_cast<cl_uint>(first));
                k.prepare.setArg(prepare_first_arg + 1, static_cast<cl_uint>(last - first));
                queue.enqueueNDRangeKernel(k.prepare, cl::NullRange,
                                           cl::NDRange(padded_global(last - first)), local);
                if (!split) {
                    k.node.setArg(5, static_cast<cl_uint>(first));
                    k.node.setArg(6, static_cast<cl_uint>(offset[first]));
                    k.node.setArg(7, static_cast<cl_uint>(nodes));
                    queue.enqueueNDRangeKernel(k.node, cl::NullRange, cl::NDRange(padded_global(nodes)),
                                               local);
                } else {
                    // The sub-launch's stretch of each list: [begin, begin + count).
                    const std::uint32_t a0 = node_first_before_[first], a1 = node_first_before_[last];
                    const std::uint32_t b0 = firsts + offset[first] - a0, b1 = firsts + offset[last] - a1;
                    for (const auto& [kernel, begin, count] :
                         {std::tuple<cl::Kernel*, std::uint32_t, std::uint32_t>{&k.first, a0, a1 - a0},
                          {&k.second, b0, b1 - b0}}) {
                        if (count == 0) continue;
                        kernel->setArg(5, static_cast<cl_uint>(first));
                        kernel->setArg(6, static_cast<cl_uint>(offset[first]));
                        kernel->setArg(7, static_cast<cl_uint>(count));
                        kernel->setArg(11, static_cast<cl_uint>(begin));
                        queue.enqueueNDRangeKernel(*kernel, cl::NullRange,
                                                   cl::NDRange(padded_global(count)), local);
                    }
                }
            }
            k.sum.setArg(sum_first_arg + 1, static_cast<cl_uint>(offset[first]));
            k.sum.setArg(sum_first_arg + 2, static_cast<cl_uint>(first));
            k.sum.setArg(sum_first_arg + 3, static_cast<cl_uint>(last - first));
            queue.enqueueNDRangeKernel(k.sum, cl::NullRange, cl::NDRange(padded_global(last - first)),
                                       local);
        }
    }

    // Nested sums (kernels/common/node_parallel.h, "Nested sums"): every
    // work item's groups from the host count function; per block of whole
    // work items (at most node_parallel_scratch_nodes() / 64 groups and / 256
    // work items; a work item with more groups alone), the prepare and group
    // kernels, a read of the device's node counts and their offsets, then
    // per sub-launch of whole groups (at most node_parallel_scratch_nodes() /
    // 16 nodes; a group with more alone) the chunk (node to group), node and
    // reduce kernels, and the block's sum kernel.  Only the read waits: a
    // block's sub-launches and sum are queued behind one another.  The
    // launch's inputs are already written; the outputs are read by run().
    void enqueue_nested_node_parallel(const BatchLaunch& l, NodeParallelKernels& k,
                                      std::size_t real_size) {
        cl::CommandQueue& queue = runtime_.queue();
        cl::Context& ctx = runtime_.context();
        const NodeParallelFunctions& f = *node_functions(l);
        const std::size_t n = l.cells.size();
        int opts[BT_MAX_OPTIONS] = {0};
        for (std::size_t j = 0; j < l.options.size() && j < BT_MAX_OPTIONS; ++j) opts[j] = l.options[j];
        double point[BT_MAX_POINT] = {0};
        bt_sampler s{};
        s.key0 = l.key0;
        s.key1 = l.key1;
        s.method = l.method;
        s.sample = 0;
        // A work item's groups, counted on the host as its block is formed:
        // while the previous block's kernels run (about 4 % of a launch's
        // time on the nested-sum bench case when counted up front with the
        // device idle).
        auto groups_of = [&](std::size_t w) {
            std::copy_n(&l.points[w * l.stride], l.stride, point);
            s.cell = l.cells[w];
            s.batch = l.batches[w];
            const int count = f.host_count(point, opts, l.quantity, &s);
            return static_cast<std::uint32_t>(std::clamp(count, 0, std::max(f.max_groups, 0)));
        };
        std::vector<std::uint32_t>& groups = node_offset_host_;  // groups of the block's work items
        // Nodes per sub-launch: node_parallel_scratch_nodes() / 16 (2^18 by
        // default; the scratch holds `terms` values per node).  Measured on
        // the nested-sum bench case at 12 nodes: the same speed within the
        // noise with a target of 1/4 and of all of
        // node_parallel_scratch_nodes(), 1/16 marginally ahead.  Groups per
        // block: / 64 (2^16 by default, about 30 MB of that case's group
        // state); work items per block: / 256 (2^14, about 21 MB of its item
        // state).
        const std::size_t node_cap = node_parallel_scratch_nodes();
        const std::size_t node_target = std::max<std::size_t>(node_cap / 16, 1);
        const std::size_t block_groups = std::max<std::size_t>(node_cap / 64, 1);
        const std::size_t block_items = std::max<std::size_t>(node_cap / 256, 1);
        const std::size_t item_bytes = static_cast<std::size_t>(std::max(f.state_size, 1)) * real_size;
        const std::size_t group_bytes =
            static_cast<std::size_t>(std::max(f.group_state_size, 1)) * real_size;
        const std::size_t term_bytes = static_cast<std::size_t>(std::max(f.terms, 1)) * real_size;
        const std::size_t partial_bytes = static_cast<std::size_t>(std::max(f.partials, 1)) * real_size;
        auto grow = [&](cl::Buffer& buffer, std::size_t& have, std::size_t need, cl_mem_flags flags) {
            need = std::max<std::size_t>(need, 1);
            if (need <= have) return;
            have = std::max(need, 2 * have);
            buffer = cl::Buffer(ctx, flags, have);
        };
        // Two sets of the block's item and group layout, by block parity:
        // their writes do not wait, and a set is rewritten only after the
        // read of the block after its own, which waits for its writes.
        std::vector<std::uint32_t> item_groups[2], group_items[2], group_node;
        std::vector<cl_int> group_nodes;
        std::size_t block = 0;
        bool have_next = false;
        std::uint32_t next_groups = 0;
        const cl::NDRange local = local_range();
        if (!k.table_ready) {
            // The table, once per program (the queue is in order: the
            // first prepare runs after it).
            const bool own = !f.table.empty();
            const std::size_t entries = own ? static_cast<std::size_t>(std::max(f.table_entries, 1)) : 1;
            const std::size_t values = own ? static_cast<std::size_t>(std::max(f.table_size, 1)) : 1;
            k.table = cl::Buffer(ctx, CL_MEM_READ_WRITE, entries * values * real_size);
            k.table_kernel.setArg(0, k.table);
            queue.enqueueNDRangeKernel(k.table_kernel, cl::NullRange,
                                       cl::NDRange(padded_global(entries)), local);
            k.table_ready = true;
        }
        for (std::size_t first = 0; first < n;) {
            std::size_t last = first, total_groups = 0;
            groups.clear();
            while (last < n) {
                const std::uint32_t g = have_next ? next_groups : groups_of(last);
                have_next = false;
                if (last > first && (total_groups + g > block_groups || last - first >= block_items)) {
                    have_next = true;  // the next block's first work item, counted
                    next_groups = g;
                    break;
                }
                groups.push_back(g);
                total_groups += g;
                ++last;
            }
            const std::size_t items = last - first;
            std::vector<std::uint32_t>& item_group = item_groups[block % 2];
            std::vector<std::uint32_t>& group_item = group_items[block % 2];
            ++block;
            item_group.assign(items + 1, 0);
            group_item.resize(total_groups);
            for (std::size_t i = 0, g = 0; i < items; ++i) {
                item_group[i] = static_cast<std::uint32_t>(g);
                for (std::uint32_t j = 0; j < groups[i]; ++j) group_item[g++] = static_cast<std::uint32_t>(i);
            }
            item_group[items] = static_cast<std::uint32_t>(total_groups);
            grow(nested_item_group_, nested_item_group_bytes_, (items + 1) * 4, CL_MEM_READ_ONLY);
            grow(nested_group_item_, nested_group_item_bytes_, total_groups * 4, CL_MEM_READ_ONLY);
            grow(nested_group_nodes_, nested_group_nodes_bytes_, total_groups * 4, CL_MEM_READ_WRITE);
            grow(nested_group_node_, nested_group_node_bytes_, (total_groups + 1) * 4, CL_MEM_READ_ONLY);
            grow(node_state_, node_state_bytes_, items * item_bytes, CL_MEM_READ_WRITE);
            grow(nested_group_state_, nested_group_state_bytes_, total_groups * group_bytes,
                 CL_MEM_READ_WRITE);
            grow(nested_group_partial_, nested_group_partial_bytes_, total_groups * partial_bytes,
                 CL_MEM_READ_WRITE);
            // Without groups the block has no read: its write waits, so that
            // no write is pending when a set is rewritten or this returns.
            queue.enqueueWriteBuffer(nested_item_group_, total_groups == 0 ? CL_TRUE : CL_FALSE, 0,
                                     (items + 1) * 4, item_group.data());
            if (total_groups > 0) {
                queue.enqueueWriteBuffer(nested_group_item_, CL_FALSE, 0, total_groups * 4,
                                         group_item.data());
                int a = set_work_args(k.prepare, l);  // first_work, n_work, item_state
                k.prepare.setArg(a++, static_cast<cl_uint>(first));
                k.prepare.setArg(a++, static_cast<cl_uint>(items));
                k.prepare.setArg(a++, k.table);
                k.prepare.setArg(a++, node_state_);
                queue.enqueueNDRangeKernel(k.prepare, cl::NullRange, cl::NDRange(padded_global(items)),
                                           local);
                // options, n_options, quantity, group_item, item_group, n_groups,
                // item_state, group_state, group_nodes
                set_option_args(k.group, l);
                k.group.setArg(3, nested_group_item_);
                k.group.setArg(4, nested_item_group_);
                k.group.setArg(5, static_cast<cl_uint>(total_groups));
                k.group.setArg(6, node_state_);
                k.group.setArg(7, nested_group_state_);
                k.group.setArg(8, nested_group_nodes_);
                queue.enqueueNDRangeKernel(k.group, cl::NullRange,
                                           cl::NDRange(padded_global(total_groups)), local);
                group_nodes.resize(total_groups);
                queue.enqueueReadBuffer(nested_group_nodes_, CL_TRUE, 0, total_groups * 4,
                                        group_nodes.data());
                // Node offsets, and the sub-launches of whole groups.
                group_node.resize(total_groups + 1);
                std::size_t total_nodes = 0;
                for (std::size_t g = 0; g < total_groups; ++g) {
                    group_node[g] = static_cast<std::uint32_t>(total_nodes);
                    total_nodes += static_cast<std::size_t>(std::max(group_nodes[g], 0));
                    if (total_nodes > 0xFFFFFFFFull)
                        throw Error("node-parallel: more than 2^32 nodes in one block");
                }
                group_node[total_groups] = static_cast<std::uint32_t>(total_nodes);
                // Sub-launches [first group, last group) of whole groups.
                const EntryRuns subs = runs_within(group_node, total_groups, node_target);
                const std::size_t most_nodes = subs.most_size;
                // Blocking: group_node is this function's own and is rewritten
                // for the next block; the last block's write must not still
                // be reading it after the return.
                queue.enqueueWriteBuffer(nested_group_node_, CL_TRUE, 0, (total_groups + 1) * 4,
                                         group_node.data());
                grow(nested_chunk_group_, nested_chunk_group_bytes_, most_nodes * 4, CL_MEM_READ_WRITE);
                grow(node_scratch_, node_scratch_bytes_, most_nodes * term_bytes, CL_MEM_READ_WRITE);
                grow(nested_node_x_, nested_node_x_bytes_, most_nodes * real_size, CL_MEM_READ_WRITE);
                // The arguments that stay for the block; the sub-launch's
                // first group, group and node counts are set per sub-launch.
                // chunk: group_node, first_group, n_groups, node_group,
                // group_item, item_state, group_state, node_x
                k.chunk.setArg(0, nested_group_node_);
                set_args_from(k.chunk, 3, nested_chunk_group_, nested_group_item_, node_state_,
                              nested_group_state_, nested_node_x_);
                // node: options, n_options, quantity, node_group, group_item,
                // n_nodes, item_state, group_state, scratch, node_x
                set_option_args(k.node, l);
                set_args_from(k.node, 3, nested_chunk_group_, nested_group_item_);
                set_args_from(k.node, 6, node_state_, nested_group_state_, node_scratch_,
                              nested_node_x_);
                // reduce: options, n_options, quantity, group_node, first_group,
                // n_groups, group_item, item_state, group_state, scratch,
                // group_partial
                set_option_args(k.reduce, l);
                k.reduce.setArg(3, nested_group_node_);
                set_args_from(k.reduce, 6, nested_group_item_, node_state_, nested_group_state_,
                              node_scratch_, nested_group_partial_);
                for (const auto& [g0, g1] : subs.runs) {
                    const std::size_t nodes = group_node[g1] - group_node[g0];
                    const std::size_t sub_groups = g1 - g0;
                    if (nodes > 0) {
                        k.chunk.setArg(1, static_cast<cl_uint>(g0));
                        k.chunk.setArg(2, static_cast<cl_uint>(sub_groups));
                        queue.enqueueNDRangeKernel(k.chunk, cl::NullRange,
                                                   cl::NDRange(padded_global(sub_groups)), local);
                        k.node.setArg(5, static_cast<cl_uint>(nodes));
                        queue.enqueueNDRangeKernel(k.node, cl::NullRange,
                                                   cl::NDRange(padded_global(nodes)), local);
                    }
                    k.reduce.setArg(4, static_cast<cl_uint>(g0));
                    k.reduce.setArg(5, static_cast<cl_uint>(sub_groups));
                    queue.enqueueNDRangeKernel(k.reduce, cl::NullRange,
                                               cl::NDRange(padded_global(sub_groups)), local);
                }
            }
            // first_work, n_work, item_group, item_state, group_state,
            // group_partial, out_mean, out_m2
            int a = set_work_args(k.sum, l);
            k.sum.setArg(a++, static_cast<cl_uint>(first));
            k.sum.setArg(a++, static_cast<cl_uint>(items));
            k.sum.setArg(a++, nested_item_group_);
            k.sum.setArg(a++, node_state_);
            k.sum.setArg(a++, nested_group_state_);
            k.sum.setArg(a++, nested_group_partial_);
            k.sum.setArg(a++, out_mean_);
            k.sum.setArg(a++, out_m2_);
            queue.enqueueNDRangeKernel(k.sum, cl::NullRange, cl::NDRange(padded_global(items)), local);
            first = last;
        }
    }

    NodeParallelKernels& node_parallel_kernels_for(const BatchLaunch& l) {
        const ModelInfo& model = *l.model;
        const NodeParallelFunctions& f = *node_functions(l);
        const std::string options = build_options(l);
        const std::string key = model.name + "\n" + f.term + "\n" + options;
        auto it = node_parallel_kernels_.find(key);
        if (it != node_parallel_kernels_.end()) return it->second;
        const std::string source =
            f.nested()
                ? nested_node_parallel_kernel_source(
                      model.kernel_header,
                      {std::to_string(f.table.empty() ? 1 : f.table_entries),
                       std::to_string(f.table.empty() ? 1 : f.table_size),
                       std::to_string(f.state_size), std::to_string(f.group_state_size),
                       std::to_string(f.terms), std::to_string(f.partials),
                       std::to_string(f.acc_size), f.table, f.count, f.prepare, f.group_prepare,
                       f.term, f.group_reduce, f.group_add, f.finish, f.sample},
                      kernel_dir_)
                : node_parallel_kernel_source(model.kernel_header, std::to_string(f.state_size),
                                              f.count, f.prepare, f.term, f.finish, kernel_dir_,
                                              f.split() ? f.term_first : "",
                                              f.split() ? f.term_second : "");
        cl::Program program = cached_program(runtime_, source, options);
        try {
            NodeParallelKernels k{cl::Kernel(program, kNodePrepareKernelName),
                                  cl::Kernel(program, kNodeKernelName),
                                  cl::Kernel(program, kNodeSumKernelName)};
            if (!f.nested() && f.split()) {
                k.first = cl::Kernel(program, kNodeFirstKernelName);
                k.second = cl::Kernel(program, kNodeSecondKernelName);
                k.split = true;
            }
            if (f.nested()) {
                k.group = cl::Kernel(program, kNodeGroupKernelName);
                k.chunk = cl::Kernel(program, kNodeChunkKernelName);
                k.reduce = cl::Kernel(program, kNodeReduceKernelName);
                k.table_kernel = cl::Kernel(program, kNodeTableKernelName);
            }
            return node_parallel_kernels_.emplace(key, std::move(k)).first->second;
        } catch (const cl::Error& e) {
            throw OpenCLError(e.what(), e.err(), "node-parallel entry points of model '" +
                                                     model.name + "' (kernels/" +
                                                     model.kernel_header + ")");
        }
    }

    // Work-group size: a fixed kLocalSize (or tuning_.local_size, a
    // divisor of 256 below 256; 0 or 256 = the driver's choice, on a global
    // size padded to a multiple of 256).  Fixed, because PoCL compiles
    // a kernel again for every new work-group size, and with the driver's
    // choice that size follows the global size, which varies from launch to
    // launch.  64 is a multiple of every SIMD width and lets PoCL vectorise
    // the work-item loop (docs/benchmarks.md).
    std::size_t local_group() const {
        const std::size_t chosen = tuning_.local_size;
        if (chosen == 0 || chosen >= 256 || 256 % chosen != 0 ||
            chosen > runtime_.device_info().max_work_group_size)
            return 256;  // the driver's choice (PoCL: within a multiple of 256)
        return chosen;
    }

    // The program of one (model, quantity, options, method): the model's
    // generic source built with them as compile-time constants
    // (kernels/common/estimator.h, "Specialisation").
    cl::Kernel& kernel_for(const BatchLaunch& l) {
        if (use_walk_parallel(l)) return walk_parallel_kernel_for(l);
        // Consecutive launches of one estimate() use the same kernel: skip
        // building its key (strings, a map look-up) then.
        if (last_kernel_ && last_model_ == l.model && last_quantity_ == l.quantity &&
            last_method_ == l.method && last_stride_ == l.stride && last_options_ == l.options)
            return *last_kernel_;
        cl::Kernel& kernel = lookup_kernel(l);
        last_kernel_ = &kernel;  // std::map: the reference stays valid
        last_model_ = l.model;
        last_quantity_ = l.quantity;
        last_method_ = l.method;
        last_stride_ = l.stride;
        last_options_ = l.options;
        return kernel;
    }

    // The build options of the program of one (model, quantity, options,
    // method); the usual and the sample-parallel program share them.
    std::string build_options(const BatchLaunch& l) const {
        const ModelInfo& model = *l.model;
        std::string options = "-cl-std=CL1.2";
        options += runtime_.device_info().has_fp64 ? " -D BT_HAS_FP64=1" : " -D BT_HAS_FP64=0";
        if (precision_ == Precision::Float) options += " -D BT_REAL_IS_FLOAT=1";
        // tuning_.extra_kernel_options: extra build options, for experiments
        // (e.g. "-D BT_SAMPLE_BARRIER=0").
        const std::string extra =
            tuning_.extra_kernel_options.empty() ? std::string() : " " + tuning_.extra_kernel_options;
        options += specialisation_options(l.quantity, l.options, l.method, l.stride);
        // Forced inlining (kernels/common/estimator.h) where the model asks
        // for it (ModelInfo::force_inline, measured there); extra kernel
        // options naming BT_FORCE_INLINE decide instead.
        if (extra.find("BT_FORCE_INLINE") == std::string::npos && model.force_inline)
            options += " -D BT_FORCE_INLINE=1";
        options += extra;
        return options;
    }

    cl::Kernel& lookup_kernel(const BatchLaunch& l) {
        return cached_kernel(kernels_, l, kEstimateKernelName, "entry point", [&] {
            return estimate_kernel_source(l.model->kernel_header, l.model->sample_function,
                                          kernel_dir_);
        });
    }

    // The kernel `entry` of the program that source_of() returns, built with
    // l's build options: from `cache`, keyed by model and options, or built
    // (source_of called only then) and stored there.  `what` names the entry
    // point in the error when the program has no such kernel.
    template <class SourceFn>
    cl::Kernel& cached_kernel(std::map<std::string, cl::Kernel>& cache, const BatchLaunch& l,
                              const char* entry, const char* what, SourceFn&& source_of) {
        const ModelInfo& model = *l.model;
        const std::string options = build_options(l);
        const std::string key = model.name + "\n" + options;
        auto it = cache.find(key);
        if (it != cache.end()) return it->second;
        cl::Program program = cached_program(runtime_, source_of(), options);
        try {
            return cache.emplace(key, cl::Kernel(program, entry)).first->second;
        } catch (const cl::Error& e) {
            throw OpenCLError(e.what(), e.err(), std::string(what) + " of model '" + model.name +
                                                     "' (kernels/" + model.kernel_header + ")");
        }
    }

    // Device buffers kept from launch to launch and grown when a launch
    // needs more: creating them per launch costs an allocation, a copy and
    // fresh pages (page faults) for every launch, which on a CPU device
    // weighs more than a closed-form kernel itself (docs/benchmarks.md,
    // "Closed forms: the engine's host work").  Sizes are for `buffer_items_` work items and
    // `buffer_point_bytes_` bytes of points.
    void reserve_buffers(std::size_t items, std::size_t point_bytes, std::size_t accum_size) {
        cl::Context& ctx = runtime_.context();
        if (items > buffer_items_ || accum_size != buffer_accum_size_) {
            // Grow geometrically, so that launches that grow step by step
            // (engine.cpp: at most 4x per launch) reallocate a few times only.
            const std::size_t want = std::max(items, 2 * buffer_items_);
            cells_ = cl::Buffer(ctx, CL_MEM_READ_ONLY, want * sizeof(std::uint32_t));
            batches_ = cl::Buffer(ctx, CL_MEM_READ_ONLY, want * sizeof(std::uint32_t));
            out_mean_ = cl::Buffer(ctx, CL_MEM_WRITE_ONLY, want * accum_size);
            out_m2_ = cl::Buffer(ctx, CL_MEM_WRITE_ONLY, want * accum_size);
            buffer_items_ = want;
            buffer_accum_size_ = accum_size;
        }
        if (point_bytes > buffer_point_bytes_) {
            const std::size_t want = std::max(point_bytes, 2 * buffer_point_bytes_);
            points_ = cl::Buffer(ctx, CL_MEM_READ_ONLY, want);
            buffer_point_bytes_ = want;
        }
        if (!options_()) {
            options_ = cl::Buffer(ctx, CL_MEM_READ_ONLY, BT_MAX_OPTIONS * sizeof(int));
            options_known_ = false;
        }
    }

    ClRuntime runtime_;
    Precision precision_;
    std::string kernel_dir_;
    EngineTuning tuning_;
    std::map<std::string, cl::Kernel> kernels_;
    std::map<std::string, SampleParallelKernels> sample_parallel_kernels_;
    cl::Buffer stage_;  // staged samples' first stages (one sub-launch)
    std::size_t stage_bytes_ = 0;
    std::map<std::string, cl::Kernel> walk_parallel_kernels_;  // walk-parallel launch
    cl::Buffer scratch_;  // sample-parallel path: one sub-launch's samples
    std::size_t scratch_bytes_ = 0;
    // Node-parallel path: the layout (host copies and buffers) and one
    // sub-launch's terms.
    std::map<std::string, NodeParallelKernels> node_parallel_kernels_;
    std::vector<std::uint32_t> node_offset_host_, node_item_host_;
    // Split terms: both node lists (first form, then second) and the
    // first-form nodes before each work item (lay_out_nodes); their buffer.
    std::vector<std::uint32_t> node_list_host_, node_first_before_;
    cl::Buffer node_list_;
    std::size_t node_list_items_ = 0;
    cl::Buffer node_offset_, node_item_, node_scratch_, node_state_;
    std::size_t node_offset_items_ = 0, node_item_items_ = 0, node_scratch_bytes_ = 0;
    std::size_t node_state_bytes_ = 0;
    // Nested sums: the group layout and state, every node's group.
    cl::Buffer nested_item_group_, nested_group_item_, nested_group_nodes_, nested_group_node_,
        nested_group_state_, nested_chunk_group_;
    std::size_t nested_item_group_bytes_ = 0, nested_group_item_bytes_ = 0,
                nested_group_nodes_bytes_ = 0, nested_group_node_bytes_ = 0,
                nested_group_state_bytes_ = 0, nested_chunk_group_bytes_ = 0;
    cl::Buffer nested_group_partial_;
    std::size_t nested_group_partial_bytes_ = 0;
    // Every node's own value (e.g. an inner integration variable), written by
    // the chunk kernel.
    cl::Buffer nested_node_x_;
    std::size_t nested_node_x_bytes_ = 0;
    cl::Buffer points_, options_, cells_, batches_, out_mean_, out_m2_;
    std::size_t buffer_items_ = 0, buffer_point_bytes_ = 0, buffer_accum_size_ = 0;
    // The second set of per-launch buffers (start(): one launch computes on
    // one set while the next is written to the other), swapped in and out.
    StagedInputs staged_;  // the active set's staged inputs (stage())
    struct BufferSet {
        cl::Buffer points, cells, batches, out_mean, out_m2;
        std::size_t items = 0, point_bytes = 0, accum_size = 0;
        StagedInputs staged;
    };
    BufferSet idle_;
    void swap_buffer_sets() {
        std::swap(staged_, idle_.staged);
        std::swap(points_, idle_.points);
        std::swap(cells_, idle_.cells);
        std::swap(batches_, idle_.batches);
        std::swap(out_mean_, idle_.out_mean);
        std::swap(out_m2_, idle_.out_m2);
        std::swap(buffer_items_, idle_.items);
        std::swap(buffer_point_bytes_, idle_.point_bytes);
        std::swap(buffer_accum_size_, idle_.accum_size);
    }
    std::deque<cl::Event> unfinished_;  // start()ed launches, oldest first
    cl::Kernel* last_kernel_ = nullptr;  // the kernel of the last launch, and its key
    const ModelInfo* last_model_ = nullptr;
    int last_quantity_ = 0;
    std::uint32_t last_method_ = 0;
    std::size_t last_stride_ = 0;
    std::vector<int> last_options_;
    std::vector<int> options_written_;  // contents of options_, when options_known_
    bool options_known_ = false;
    std::vector<float> points_f_, accum_f_;  // float precision staging
};

void merge_batch(CellState& c, double mean, double m2, std::uint32_t batch_size) {
    // Chan, Golub & LeVeque: combine (n_a, mean_a, M2_a) with (n_b, mean_b, M2_b).
    if (c.batches == 0) c.first_batch = mean;
    if (c.batches == 1) c.second_batch = mean;
    const double na = static_cast<double>(c.samples), nb = batch_size;
    const double n = na + nb;
    const double delta = mean - c.mean;
    c.mean += delta * nb / n;
    c.m2 += m2 + delta * delta * na * nb / n;
    c.samples += batch_size;
    // Welford over batch means (the RQMC error estimate).
    c.batches += 1;
    const double d = mean - c.batch_mean;
    c.batch_mean += d / c.batches;
    c.batch_m2 += d * (mean - c.batch_mean);
}

double cell_stderr(const CellState& c, bool rqmc) {
    if (rqmc) {
        if (c.batches < 2) return INFINITY;
        return std::sqrt(c.batch_m2 / (c.batches - 1) / c.batches);
    }
    if (c.samples < 2) return INFINITY;
    return std::sqrt(c.m2 / static_cast<double>(c.samples - 1) / static_cast<double>(c.samples));
}

// v = n copies of `fill`, for the result arrays of large runs: where the
// kernel allows, the fresh memory is asked to be backed by transparent huge
// pages first (madvise), so that filling it takes a page fault per 2 MiB
// instead of per 4 KiB.  Measured on 4 M closed-form cells: the faults of the
// three result arrays took about a sixth of the process's time (411 page
// faults per run instead of 18 700).  Only the mapping changes, not a value.
template <typename T>
void assign_large(std::vector<T>& v, std::size_t n, T fill) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    constexpr std::size_t kHuge = std::size_t{2} << 20;
    if (n * sizeof(T) >= 2 * kHuge && v.capacity() < n) {
        std::vector<T>().swap(v);
        // Allocated, not yet touched; 2 MiB more, so that the huge page
        // holding the array's end lies inside the allocation.
        v.reserve(n + kHuge / sizeof(T));
        const auto begin = reinterpret_cast<std::uintptr_t>(v.data());
        const std::uintptr_t first = (begin + kHuge - 1) / kHuge * kHuge;
        const std::uintptr_t last = (begin + n * sizeof(T) + kHuge - 1) / kHuge * kHuge;
        if (last > first)
            madvise(reinterpret_cast<void*>(first), last - first, MADV_HUGEPAGE);  // a hint
    }
#endif
    v.assign(n, fill);
}

// Continue from `from`: each cell's next batch index is its merged count and
// its remaining work this round is what its target still lacks.  Returns the
// time spent before.  Throws Error on a state that cannot have come from a
// run of this table.
double restore_state(EstimateState& state, EstimateState&& from,
                     std::vector<std::uint32_t>& wanted, std::vector<std::uint32_t>& issued) {
    const std::size_t n = state.cells.size();
    if (from.cells.size() != n || from.round_target.size() != n)
        throw Error("stored estimator state has " + std::to_string(from.cells.size()) +
                    " cells, the table " + std::to_string(n));
    for (std::size_t c = 0; c < n; ++c) {
        const CellState& s = from.cells[c];
        if (from.round_target[c] < s.batches || (s.done && from.round_target[c] != s.batches))
            throw Error("stored estimator state of cell " + std::to_string(c) +
                        " is inconsistent (batches beyond the round's target)");
        issued[c] = s.batches;
        wanted[c] = from.round_target[c] - s.batches;
    }
    state.cells = std::move(from.cells);
    return from.elapsed_seconds;
}

}  // namespace

std::unique_ptr<Backend> make_backend(const std::string& device_selector, Precision precision,
                                      const std::string& kernel_dir, const EngineTuning& tuning) {
    if (device_selector == "host") {
        if (precision != Precision::Double)
            throw InputError("--device host computes in double only; drop --precision float");
        return std::make_unique<HostBackend>();
    }
    const std::string threaded = "host-threads";
    if (device_selector.compare(0, threaded.size(), threaded) == 0) {
        const std::string rest = device_selector.substr(threaded.size());
        unsigned threads = std::max(1u, std::thread::hardware_concurrency());
        if (!rest.empty()) {
            const bool digits = rest.size() >= 2 && rest.size() <= 5 && rest[0] == ':' &&
                                rest.find_first_not_of("0123456789", 1) == std::string::npos;
            const long n = digits ? std::stol(rest.substr(1)) : 0;
            if (n < 1 || n > 1024)
                throw InputError("device '" + device_selector +
                                 "' is not valid; use host-threads or host-threads:N with N in "
                                 "[1, 1024]");
            threads = static_cast<unsigned>(n);
        }
        if (precision != Precision::Double)
            throw InputError("--device " + device_selector +
                             " computes in double only; drop --precision float");
        return std::make_unique<ThreadedHostBackend>(threads);
    }
    return std::make_unique<OpenCLBackend>(select_device(device_selector), precision,
                                           kernel_dir, tuning);
}

EstimateResult estimate(Backend& backend, const ModelInfo& model, const QuantityInfo& quantity,
                        const std::vector<int>& options, std::size_t cell_count,
                        const PointFn& point_of, const IntegrationSettings& settings,
                        const ProgressFn& progress, EstimateCheckpoint* checkpoint) {
    const std::size_t point_stride = model.point_stride();
    const PointsFn points_of = [&](std::size_t first_cell, std::size_t count, double* points) {
        for (std::size_t k = 0; k < count; ++k) point_of(first_cell + k, points + k * point_stride);
    };
    return estimate(backend, model, quantity, options, cell_count, points_of, settings, progress,
                    checkpoint);
}

EstimateResult estimate(Backend& backend, const ModelInfo& model, const QuantityInfo& quantity,
                        const std::vector<int>& options, std::size_t cell_count,
                        const PointsFn& points_of, const IntegrationSettings& settings,
                        const ProgressFn& progress, EstimateCheckpoint* checkpoint) {
    if (!model.host_fn) throw Error("model '" + model.name + "' has no sample function");
    check_settings(settings);
    if (cell_count > 0xFFFFFFFFull)
        throw InputError("table has " + std::to_string(cell_count) +
                         " cells; at most 2^32 - 1 are supported");
    if (settings.cell_base > 0xFFFFFFFFull - cell_count)
        throw InputError("cells " + std::to_string(settings.cell_base) + " + " +
                         std::to_string(cell_count) + " reach past cell 2^32 - 1");
    // The model's cross-checks of parameters and options (ModelInfo::
    // check_cell) on every cell before anything runs: one point per cell, far
    // cheaper than the kernel, and no launch computes a cell that is invalid.
    // Closed forms without a checkpoint (the direct path below) check each
    // cell's point as it is built for its launch instead: there the separate
    // pass built every point twice and cost about as much as the kernel
    // (bench/bench_engine_closed_form), and a launch of closed forms is cheap
    // enough that a bad cell still stops the run before any long work.
    const Method method_resolved = resolve_method(quantity, settings.method);
    const bool check_while_building =
        method_resolved == Method::ClosedForm && !(checkpoint && (checkpoint->save || checkpoint->resume));
    // The check of `count` cells' points (point k at points + k * pitch):
    // the model's fast form first (ModelInfo::cells_pass), and its message-
    // building check_cell, cell by cell, only where that refuses the span,
    // so the first refused cell is reported as a check of every cell would.
    auto check_cells = [&](const double* points, std::size_t count, std::size_t pitch) {
        if (model.cells_pass && model.cells_pass(quantity, points, count, pitch, options)) return;
        for (std::size_t k = 0; k < count; ++k) {
            const std::string problem = model.check_cell(quantity, points + k * pitch, options);
            if (!problem.empty()) throw InputError(problem);
        }
    };
    if (model.check_cell && !check_while_building) {
        constexpr std::size_t kCheckSpan = 1024;  // cells per points_of call
        const std::size_t pitch = model.point_stride();
        std::vector<double> span_points(std::min(cell_count, kCheckSpan) * pitch);
        for (std::size_t first = 0; first < cell_count; first += kCheckSpan) {
            const std::size_t count = std::min(kCheckSpan, cell_count - first);
            points_of(first, count, span_points.data());
            check_cells(span_points.data(), count, pitch);
        }
    }
    const auto start = std::chrono::steady_clock::now();
    auto elapsed = [&] {
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    };

    EstimateResult result;
    result.method = method_resolved;
    const bool quadrature = result.method == Method::Quadrature;
    // Quadrature runs like a closed form with two one-sample batches.
    const bool closed = result.method == Method::ClosedForm || quadrature;
    const bool rqmc = result.method == Method::Rqmc;
    const bool adaptive = !closed && settings.tolerance > 0;  // < 1: check_settings

    BatchLaunch launch;
    launch.model = &model;
    launch.quantity = quantity.id;
    launch.options = options;
    launch.method = quadrature ? BT_METHOD_QUADRATURE
                    : closed   ? BT_METHOD_CLOSED
                    : rqmc     ? BT_METHOD_RQMC
                               : BT_METHOD_MC;
    launch.key0 = static_cast<std::uint32_t>(settings.seed);
    launch.key1 = static_cast<std::uint32_t>(settings.seed >> 32);
    launch.stride = model.point_stride();
    // The quantity's per-cell invariants (ModelInfo::derive), computed here
    // once per cell and appended to its point.
    const CellDerivation derivation =
        model.derive ? model.derive(quantity, options) : CellDerivation{};
    if (derivation.slots > 0) {
        launch.stride += static_cast<std::size_t>(derivation.slots);
        if (launch.stride > BT_MAX_POINT || !derivation.fill)
            throw Error("model '" + model.name + "', quantity '" + quantity.name + "': " +
                        std::to_string(derivation.slots) +
                        " derived slots need a fill function and at most BT_MAX_POINT (" +
                        std::to_string(BT_MAX_POINT) + ") point slots in all");
    }
    // The kernels see cell numbers from cell_base on (random streams); the
    // per-cell state here is indexed from 0.
    const std::uint32_t cell_base = static_cast<std::uint32_t>(settings.cell_base);

    // Budget: the batch policy the planner shares (first_round_batches,
    // engine_tuning.h).
    const BatchLayout first_round =
        first_round_batches(result.method, settings.samples, settings.batch_size);
    const std::uint32_t batch_size = static_cast<std::uint32_t>(first_round.batch_size);
    const std::uint32_t first_batches = static_cast<std::uint32_t>(first_round.batches);
    const std::uint64_t max_samples =
        adaptive ? std::max<std::uint64_t>(settings.max_samples,
                                           static_cast<std::uint64_t>(first_batches) * batch_size)
                 : static_cast<std::uint64_t>(first_batches) * batch_size;
    const std::uint32_t max_batches =
        static_cast<std::uint32_t>(std::min<std::uint64_t>(max_samples / batch_size, 0xFFFFFFFFu));
    launch.batch_size = batch_size;

    EstimateState state;
    std::vector<CellState>& cells = state.cells;
    // Launch size.  A fixed --slab is kept as given.  Otherwise launches start
    // small and grow towards kLaunchSeconds each (next_launch_size,
    // engine_tuning.h, which the planner's engine_launch_sizes follows too).
    // Results do not depend on the launch size.
    const bool fixed_slab = settings.slab_work_items != 0;
    const std::size_t max_slab =
        std::max<std::size_t>(1, fixed_slab ? settings.slab_work_items : backend.preferred_slab());
    std::size_t slab = fixed_slab ? max_slab : std::min(max_slab, kFirstLaunch);
    auto resize_slab = [&](std::size_t items, double seconds) {
        if (fixed_slab || items < slab) return;  // a short tail launch says little
        slab = next_launch_size(items, seconds, slab, max_slab);
    };
    std::vector<double> slab_mean, slab_m2;

    Progress prog;
    prog.cells_total = cell_count;
    // The figures every path derives from the per-cell results in the same
    // way: the worst relative error, unconverged cells, the last progress.
    // errors_all_zero: every stderr is 0 (closed forms), so every cell's
    // relative error is 0 or NaN (0 / 0), which std::max below ignores:
    // the worst is 0, and the loop and its divisions are skipped.
    auto finish = [&](double elapsed_before_run, bool errors_all_zero) {
        double worst = 0;
        std::size_t unconverged = 0;
        // Relative error with the absolute floor folded in: under a tolerance
        // a cell whose stderr met abs_floor scores at most `tolerance`, so the
        // figure is comparable with the requested tolerance.
        const double floor_value =
            adaptive ? settings.abs_floor / settings.tolerance : settings.abs_floor;
        for (std::size_t c = 0; c < cell_count && !(errors_all_zero && !adaptive); ++c) {
            const double rel = result.stderr_[c] / std::max(std::fabs(result.value[c]), floor_value);
            worst = std::max(worst, rel);
            if (adaptive && result.stderr_[c] > std::max(settings.tolerance * std::fabs(result.value[c]),
                                                         settings.abs_floor))
                ++unconverged;
        }
        result.tolerance_achieved = worst;
        result.cells_unconverged = unconverged;
        result.elapsed_seconds = elapsed_before_run + elapsed();
        if (progress) {
            prog.cells_done = cell_count;
            prog.fraction = 1.0;
            prog.elapsed_seconds = result.elapsed_seconds;
            prog.samples_done = result.total_samples;
            progress(prog);
        }
    };

    // A launch's work items `items`, `items + 1`, ... for batches first_batch,
    // first_batch + 1, ... (take of them) of one cell: its point is built
    // straight into the first item's slot and copied to the others.  Both
    // paths below fill their launches with it.
    // The inputs are written through `to`: a launch's vectors, or memory the
    // backend lends (Backend::stage).
    const std::size_t stride = launch.stride;
    auto add_items_to = [&](const LaunchStaging& to, std::size_t cell, std::uint32_t first_batch,
                            std::uint32_t take, std::size_t& items) {
        double* const first_point = to.points + items * stride;
        points_of(cell, 1, first_point);
        if (check_while_building && model.check_cell) check_cells(first_point, 1, stride);
        if (derivation.slots > 0) derivation.fill(first_point);
        for (std::uint32_t k = 0; k < take; ++k, ++items) {
            if (k) std::copy_n(first_point, stride, to.points + items * stride);
            to.cells[items] = cell_base + static_cast<std::uint32_t>(cell);
            to.batches[items] = first_batch + k;
        }
    };
    auto vectors_of = [](BatchLaunch& l) {
        LaunchStaging to;
        to.points = l.points.data();
        to.cells = l.cells.data();
        to.batches = l.batches.data();
        return to;
    };
    auto add_items = [&](std::size_t cell, std::uint32_t first_batch, std::uint32_t take,
                         std::size_t& items) {
        add_items_to(vectors_of(launch), cell, first_batch, take, items);
    };

    // Closed forms and quadratures without a checkpoint: every cell runs its
    // fixed one (closed form) or two (quadrature: accurate and coarse rule)
    // one-sample batches and nothing else, so the per-cell estimator state,
    // the work lists and the stopping rule are not needed: each launch's
    // results go straight into the result arrays.  Measured: the state alone
    // (72 bytes per cell, fresh memory on every call) cost more page faults
    // and memory traffic than the closed-form kernel (`perf record` of
    // bench_engine_closed_form).  The values are those the general path below
    // computes.
    const bool direct = closed && !(checkpoint && (checkpoint->save || checkpoint->resume));
    if (direct) {
        assign_large(result.value, cell_count, 0.0);
        assign_large(result.stderr_, cell_count, 0.0);
        assign_large(result.samples, cell_count, 1u);
        std::size_t cell_cursor = 0;
        std::uint32_t batch_cursor = 0;  // next batch of cell_cursor
        std::uint64_t work_done = 0;
        const std::uint64_t total_work = static_cast<std::uint64_t>(cell_count) * first_batches;
        // Two launches in turn (Backend::start/finish): once the launches
        // have grown to the backend's largest, the next one's points are
        // built here while the device computes one, so the host's share of
        // a closed form's cost overlaps the kernel's instead of adding to it.
        // Launches are merged in the order they were built, so the results
        // do not depend on it.
        struct Slot {
            BatchLaunch launch;
            std::vector<double> mean, m2;
            double started = 0;
            std::size_t items = 0, cells_complete = 0;
            std::size_t first_cell = 0;       // the launch's first work item's
            std::uint32_t first_batch = 0;    // cell and batch
        };
        Slot slots[2];
        for (Slot& slot : slots) {
            slot.launch = launch;
            slot.launch.need_m2 = false;  // one-sample batches: m2 = 0
        }
        // Unfinished launches read and write the slots: on any exception they
        // are waited for and dropped before the slots go away.
        struct AbandonOnUnwind {
            Backend& backend;
            bool armed = true;
            ~AbandonOnUnwind() {
                if (armed) backend.abandon();
            }
        } abandon_guard{backend};
        std::size_t unfinished = 0, oldest = 0, next = 0;
        double last_finish = 0;
        auto merge_oldest = [&] {
            Slot& slot = slots[oldest];
            backend.finish();
            --unfinished;
            oldest ^= 1;
            const double now = elapsed();
            // The device's time for this launch: from its start or the end of
            // the one before it, whichever came later.
            resize_slab(slot.items, now - std::max(slot.started, last_finish));
            last_finish = now;
            if (!quadrature) {
                // One work item per cell, in cell order; the means are in
                // the result array already (BatchLaunch::mean_out).
                // merge_batch's first merge: 0 + (x - 0) * 1 / 1, which
                // turns -0 into +0; the rest of it is exact.
                double* const value = result.value.data() + slot.first_cell;
                for (std::size_t w = 0; w < slot.items; ++w) value[w] = 0.0 + value[w];
            } else {
                // Work items (cell, batch) in order from the launch's first.
                std::size_t c = slot.first_cell;
                std::uint32_t b = slot.first_batch;
                for (std::size_t w = 0; w < slot.items; ++w) {
                    const double x = slot.mean[w];
                    if (b == 0) {
                        result.value[c] = x;  // the accurate rule, taken as it is
                    } else {
                        // Batch 0 of this cell came first (same or earlier launch).
                        result.stderr_[c] = std::fabs(result.value[c] - x);
                    }
                    if (++b == first_batches) {
                        ++c;
                        b = 0;
                    }
                }
            }
            work_done += slot.items;
            if (progress) {
                // A cell is finished once its last batch is merged.
                prog.cells_done = slot.cells_complete;
                prog.samples_done = work_done;
                prog.elapsed_seconds = now;
                prog.fraction = std::min(1.0, static_cast<double>(work_done) /
                                                  static_cast<double>(std::max<std::uint64_t>(
                                                      total_work, 1)));
                progress(prog);
            }
        };
        while (cell_cursor < cell_count) {
            Slot& slot = slots[next];
            BatchLaunch& l = slot.launch;
            slot.first_cell = cell_cursor;
            slot.first_batch = batch_cursor;
            // Built where the backend reads it (no copy on PoCL's CPU
            // device), or in the launch's vectors.
            LaunchStaging to;
            l.staged = false;
            l.mean_out = nullptr;
            if (backend.stage(l, slab, to)) {
                l.staged = true;
                l.cells.clear();
                l.batches.clear();
                l.points.clear();
            } else {
                l.cells.resize(slab);
                l.batches.resize(slab);
                l.points.resize(slab * stride);
                to = vectors_of(l);
            }
            std::size_t items = 0;
            if (first_batches == 1 && derivation.slots == 0) {
                // Closed forms: one work item per cell (add_items_to, without
                // its per-cell loop over batches), the launch's points asked
                // for in one call and checked as one span (the stride is the
                // model's: no derived slots).
                const std::size_t count = std::min(cell_count - cell_cursor, slab);
                points_of(cell_cursor, count, to.points);
                if (check_while_building && model.check_cell) check_cells(to.points, count, stride);
                const std::uint32_t first = cell_base + static_cast<std::uint32_t>(cell_cursor);
                for (std::size_t w = 0; w < count; ++w) {
                    to.cells[w] = first + static_cast<std::uint32_t>(w);
                    to.batches[w] = 0;
                }
                cell_cursor += count;
                items = count;
            }
            while (cell_cursor < cell_count && items < slab) {
                const std::uint32_t take = static_cast<std::uint32_t>(
                    std::min<std::size_t>(first_batches - batch_cursor, slab - items));
                add_items_to(to, cell_cursor, batch_cursor, take, items);
                batch_cursor += take;
                if (batch_cursor == first_batches) {
                    ++cell_cursor;
                    batch_cursor = 0;
                }
            }
            if (l.staged) {
                l.staged_items = items;
            } else {
                l.cells.resize(items);
                l.batches.resize(items);
                l.points.resize(items * stride);
            }
            if (!quadrature) l.mean_out = result.value.data() + slot.first_cell;
            slot.items = items;
            slot.cells_complete = cell_cursor;
            slot.started = elapsed();
            backend.start(l, slot.mean, slot.m2);
            ++unfinished;
            next ^= 1;
            // While the launches still grow (resize_slab), each one's time
            // sets the next one's size, so it is finished before the next is
            // built: the launch sizes are those of the general path (which
            // plan's cost model follows, tests/test_plan_cost.cpp).  At the
            // largest size one launch computes while the next is built.
            if (unfinished == 2 || slab < max_slab) merge_oldest();
        }
        while (unfinished > 0) merge_oldest();
        abandon_guard.armed = false;
        result.total_samples = total_work;  // batch_size is 1
        finish(0.0, !quadrature);
        return result;
    }

    cells.resize(cell_count);
    // Per-cell batches wanted this round (0 = cell done).
    std::vector<std::uint32_t> wanted(cell_count, first_batches);
    // Batches handed out so far per cell: the next batch's index.  (A cell's
    // batches may straddle two slabs, so the merged count cannot serve.)
    std::vector<std::uint32_t> issued(cell_count, 0);
    std::uint64_t total_work_estimate = static_cast<std::uint64_t>(cell_count) * first_batches;
    std::uint64_t work_done = 0;
    double elapsed_before = 0;
    if (checkpoint && checkpoint->resume) {
        elapsed_before = restore_state(state, std::move(*checkpoint->resume), wanted, issued);
        checkpoint->resume.reset();
        total_work_estimate = 0;
        for (std::uint32_t w : wanted) total_work_estimate += w;
    }
    auto save_state = [&](bool finished) {
        if (!checkpoint || !checkpoint->save) return;
        state.elapsed_seconds = elapsed_before + elapsed();
        checkpoint->save(state, finished);
    };

    for (int round = 0;; ++round) {
        if (checkpoint) {
            state.round_target.resize(cell_count);
            for (std::size_t c = 0; c < cell_count; ++c)
                state.round_target[c] = issued[c] + wanted[c];
        }
        // Work list of this round, ordered by (cell, batch), so every cell
        // merges its batches in batch order whatever the slab size.
        std::size_t cell_cursor = 0;
        std::uint32_t batch_cursor = 0;
        auto advance_to_work = [&] {
            while (cell_cursor < cell_count && batch_cursor >= wanted[cell_cursor]) {
                ++cell_cursor;
                batch_cursor = 0;
            }
        };
        advance_to_work();
        // No early exit when the round has no work: continued from a stored
        // state, it may only lack the stopping rule below.
        while (cell_cursor < cell_count) {
            // The launch's arrays are written in place (they keep their
            // capacity from launch to launch).
            launch.cells.resize(slab);
            launch.batches.resize(slab);
            launch.points.resize(slab * stride);
            std::size_t items = 0;
            while (cell_cursor < cell_count && items < slab) {
                if (batch_cursor == 0 && wanted[cell_cursor] == 1 && derivation.slots == 0) {
                    // A run of cells that want one batch each (closed forms,
                    // a first round of one batch per cell): one work item
                    // each, their points asked for in one call, as
                    // add_items would put them.
                    std::size_t end = cell_cursor + 1;
                    while (end < cell_count && end - cell_cursor < slab - items && wanted[end] == 1)
                        ++end;
                    const std::size_t count = end - cell_cursor;
                    double* const points = launch.points.data() + items * stride;
                    points_of(cell_cursor, count, points);
                    if (check_while_building && model.check_cell) check_cells(points, count, stride);
                    for (std::size_t c = cell_cursor; c < end; ++c, ++items) {
                        launch.cells[items] = cell_base + static_cast<std::uint32_t>(c);
                        launch.batches[items] = issued[c]++;
                    }
                    cell_cursor = end;
                    advance_to_work();
                    continue;
                }
                // This cell's remaining batches of the round, as many as fit.
                const std::uint32_t take = static_cast<std::uint32_t>(std::min<std::size_t>(
                    wanted[cell_cursor] - batch_cursor, slab - items));
                add_items(cell_cursor, issued[cell_cursor], take, items);
                issued[cell_cursor] += take;
                batch_cursor += take;
                advance_to_work();
            }
            launch.cells.resize(items);
            launch.batches.resize(items);
            launch.points.resize(items * stride);
            const double launch_start = elapsed();
            backend.run(launch, slab_mean, slab_m2);
            resize_slab(launch.cells.size(), elapsed() - launch_start);
            for (std::size_t w = 0; w < launch.cells.size(); ++w)
                merge_batch(cells[launch.cells[w] - cell_base], slab_mean[w], slab_m2[w], batch_size);
            work_done += launch.cells.size();
            save_state(false);
            if (progress) {
                // Without a tolerance every cell is finished once its batches
                // are merged: the cursor counts them.
                if (!adaptive) prog.cells_done = cell_cursor;
                prog.samples_done = work_done * batch_size;
                prog.elapsed_seconds = elapsed();
                prog.fraction = std::min(1.0, static_cast<double>(work_done) /
                                                  static_cast<double>(std::max<std::uint64_t>(
                                                      total_work_estimate, 1)));
                progress(prog);
            }
        }
        // Decide which cells continue.
        std::uint64_t next_work = 0;
        std::size_t done = 0;
        for (std::size_t c = 0; c < cell_count; ++c) {
            CellState& s = cells[c];
            wanted[c] = 0;
            if (s.done) {
                ++done;
                continue;
            }
            if (!adaptive || s.batches >= max_batches) {
                s.done = true;
                ++done;
                continue;
            }
            const double se = cell_stderr(s, rqmc);
            const double target = std::max(settings.tolerance * std::fabs(s.mean), settings.abs_floor);
            if (se <= target) {
                s.done = true;
                ++done;
                continue;
            }
            // The error falls as 1/sqrt(batches): ask for the total that should
            // meet the target (+10 %), but at least double and at most 16x the
            // current count per round, so a noisy early estimate cannot explode
            // the budget.
            const double ratio = se / target;
            double need = std::ceil(s.batches * ratio * ratio * 1.1);
            need = std::clamp(need, 2.0 * s.batches, 16.0 * s.batches);
            const std::uint32_t more = static_cast<std::uint32_t>(
                std::min<double>(need, max_batches) - s.batches);
            wanted[c] = more;
            next_work += more;
        }
        prog.cells_done = done;
        total_work_estimate = work_done + next_work;
        if (next_work == 0) break;
    }
    save_state(true);

    result.value.resize(cell_count);
    result.stderr_.resize(cell_count);
    result.samples.resize(cell_count);
    for (std::size_t c = 0; c < cell_count; ++c) {
        const CellState& s = cells[c];
        // RQMC: the mean of the batch means is the estimator whose error we report.
        // Quadrature: the accurate rule, with the coarse rule's distance as error.
        result.value[c] = quadrature ? s.first_batch : rqmc ? s.batch_mean : s.mean;
        result.stderr_[c] = quadrature ? std::fabs(s.first_batch - s.second_batch)
                            : closed   ? 0.0
                                       : cell_stderr(s, rqmc);
        result.samples[c] = quadrature ? 1u : static_cast<std::uint32_t>(std::min<std::uint64_t>(s.samples, 0xFFFFFFFFu));
        result.total_samples += s.samples;
    }
    finish(elapsed_before, false);
    return result;
}

}  // namespace brdftab
