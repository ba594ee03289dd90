// sample_parallel.cpp — sample-parallel launches (engine.h): a Monte Carlo /
// RQMC batch of batch_size samples runs as batch_size work items of a sample
// kernel, one sample each, and one work item of a reduce kernel that merges
// them in sample order (kernels/common/estimator.h,
// kernels/common/sample_parallel.cl), bit-identical to the usual kernel.
// Also the parts the staged launch (staged.cpp) shares.
#include "host/engine/launch/sample_parallel.h"

#include <algorithm>

#include "kernels/common/estimator.h"
#include "host/engine/kernel_sources.h"

namespace brdftab::launch {

bool SampleParallelCommon::uses_fixed_step_solver(const BatchLaunch& l) const {
    // The search's loop is what kept the work-item loop scalar; with a fixed
    // number of steps it vectorises, and the rare sample whose search has
    // not ended is redone with the loop, so the values are the usual
    // kernel's (docs/benchmarks.md, "Sample-parallel launches").
    if (r_.precision != Precision::Double || !r_.runtime.device_info().has_fp64) return false;
    const QuantityInfo* q = launch_quantity(l);
    if (!q) return false;
    return std::any_of(q->fixed_step_solver.begin(), q->fixed_step_solver.end(),
                       [&](const OptionChoice& o) {
                           return option_is(*l.model, l.options, o.option, o.choice);
                       });
}

bool SampleParallelCommon::applies(const BatchLaunch& l) const {
    if (l.method != BT_METHOD_MC && l.method != BT_METHOD_RQMC) return false;
    if (l.batch_size < 2 || l.batch_size > scratch_samples()) return false;
    if (r_.tuning.sample_parallel == LaunchChoice::Off) return false;
    if (r_.tuning.sample_parallel == LaunchChoice::On) return true;
    const Method method = l.method == BT_METHOD_MC ? Method::MonteCarlo : Method::Rqmc;
    const QuantityInfo* q = launch_quantity(l);
    if (!q) return false;
    // A staged quantity's first stage vectorises only with the fixed-step
    // search: elsewhere its launch stays the usual one.
    if (q->staged.enabled() && !uses_fixed_step_solver(l)) return false;
    return sample_parallel_by_default(*l.model, *q, method, l.options);
}

std::size_t SampleParallelCommon::scratch_samples() const {
    // At most 2^31 samples: a sub-launch's sample count is a uint.
    const std::size_t v = std::min(r_.tuning.sample_parallel_scratch_samples, std::size_t{1} << 31);
    return v >= 2 ? v : kSampleParallelScratchSamples;
}

std::size_t SampleParallelCommon::per_sub(const BatchLaunch& l) const {
    return std::max<std::size_t>(1, scratch_samples() / l.batch_size);
}

void SampleParallelCommon::reserve(const BatchLaunch& l, std::size_t stage_size) {
    const std::size_t n = l.cells.size(), batch = l.batch_size;
    const std::size_t samples = std::min(n, per_sub(l)) * batch;
    const std::size_t scratch_bytes = samples * r_.accum_size();
    if (scratch_bytes > scratch_bytes_) {
        // In-order queue: a sub-launch's sample kernel runs after the
        // previous reduce kernel has read the buffer, so one suffices.
        scratch = cl::Buffer(r_.runtime.context(), CL_MEM_READ_WRITE, scratch_bytes);
        scratch_bytes_ = scratch_bytes;
    }
    const std::size_t stage_bytes = samples * stage_size * r_.real_size();
    if (stage_size > 0 && stage_bytes > stage_bytes_) {
        stage = cl::Buffer(r_.runtime.context(), CL_MEM_READ_WRITE, stage_bytes);
        stage_bytes_ = stage_bytes;
    }
}

void SampleParallelCommon::enqueue(const BatchLaunch& l, Kernels& k,
                                   const std::vector<cl::Kernel*>& per_sample,
                                   const std::vector<std::vector<cl::Buffer*>>& tails) {
    cl::CommandQueue& queue = r_.runtime.queue();
    const std::size_t n = l.cells.size();
    const std::size_t batch = l.batch_size;
    const std::size_t sub = per_sub(l);
    int sample_first_arg = 0;  // first_work, n_samples
    for (std::size_t j = 0; j < per_sample.size(); ++j) {
        cl::Kernel& kernel = *per_sample[j];
        sample_first_arg = r_.set_work_args(kernel, l);
        cl_uint a = static_cast<cl_uint>(sample_first_arg + 2);
        kernel.setArg(a++, static_cast<cl_uint>(batch));
        for (cl::Buffer* buffer : tails[j]) kernel.setArg(a++, *buffer);
    }
    k.reduce.setArg(0, scratch);
    k.reduce.setArg(3, static_cast<cl_uint>(batch));
    k.reduce.setArg(4, r_.out_mean);
    k.reduce.setArg(5, r_.out_m2);
    const cl::NDRange local = r_.local_range();
    for (std::size_t first = 0; first < n; first += sub) {
        const std::size_t count = std::min(sub, n - first);
        const std::size_t samples = count * batch;
        for (cl::Kernel* kernel : per_sample) {
            set_args_from(*kernel, sample_first_arg, static_cast<cl_uint>(first),
                          static_cast<cl_uint>(samples));
            queue.enqueueNDRangeKernel(*kernel, cl::NullRange, cl::NDRange(r_.padded_global(samples)),
                                       local);
        }
        k.reduce.setArg(1, static_cast<cl_uint>(first));
        k.reduce.setArg(2, static_cast<cl_uint>(count));
        queue.enqueueNDRangeKernel(k.reduce, cl::NullRange, cl::NDRange(r_.padded_global(count)), local);
    }
}

SampleParallelCommon::Kernels& SampleParallelCommon::kernels_for(const BatchLaunch& l) {
    const ModelInfo& model = *l.model;
    const std::string options = r_.build_options(l);
    const bool fixed = uses_fixed_step_solver(l);
    std::string fixed_options;
    if (fixed) {
        fixed_options = options + " -D BT_MF_SOLVE_STEPS=1";
        // tuning.fixed_solver_steps_x/y: other step counts for the x and y
        // searches (tests: 1, 1 makes most samples take the redo).
        const int sx = r_.tuning.fixed_solver_steps_x, sy = r_.tuning.fixed_solver_steps_y;
        if (sx > 0 && sy > 0)
            fixed_options += " -D BT_MF_SOLVE_STEPS_X=" + std::to_string(sx) +
                             " -D BT_MF_SOLVE_STEPS_Y=" + std::to_string(sy);
    }
    const std::string key = model.name + "\n" + options + "\n" + fixed_options;
    auto it = kernels_.find(key);
    if (it != kernels_.end()) return it->second;
    const QuantityInfo* quantity = launch_quantity(l);
    const QuantityInfo::StagedSample staged =
        quantity && quantity->staged.enabled() ? quantity->staged : QuantityInfo::StagedSample{};
    const std::string source = sample_parallel_kernel_source(
        model.kernel_header, model.sample_function, r_.kernel_dir, staged.size, staged.stage, staged.rest);
    cl::Program program = r_.program(source, options);
    try {
        Kernels k;
        if (staged.enabled()) {
            k.stage_size = static_cast<std::size_t>(staged.size);
            k.rest = cl::Kernel(program, kStageRestKernelName);
            k.reduce = cl::Kernel(program, kReduceKernelName);
            if (fixed) {
                cl::Program fixed_program = r_.program(source, fixed_options);
                k.stage = cl::Kernel(fixed_program, kStageKernelName);
                k.stage_redo = cl::Kernel(program, kStageRedoKernelName);
                k.has_redo = true;
            } else {
                k.stage = cl::Kernel(program, kStageKernelName);
            }
        } else if (fixed) {
            cl::Program fixed_program = r_.program(source, fixed_options);
            k.sample = cl::Kernel(fixed_program, kSampleKernelName);
            k.reduce = cl::Kernel(fixed_program, kReduceKernelName);
            k.redo = cl::Kernel(program, kRedoKernelName);
            k.has_redo = true;
        } else {
            k.sample = cl::Kernel(program, kSampleKernelName);
            k.reduce = cl::Kernel(program, kReduceKernelName);
        }
        return kernels_.emplace(key, std::move(k)).first->second;
    } catch (const cl::Error& e) {
        throw LaunchResources::entry_point_error(e, "sample-parallel entry points", model);
    }
}

namespace {

// The sample kernel (and its redo, which takes the same arguments, after
// it) per sample, then the reduce kernel.
class SampleParallelLaunch final : public LaunchStrategy {
public:
    SampleParallelLaunch(LaunchResources& r, std::shared_ptr<SampleParallelCommon> c)
        : LaunchStrategy(r), c_(std::move(c)) {}

    bool applies(const BatchLaunch& l) const override {
        const QuantityInfo* q = launch_quantity(l);
        return c_->applies(l) && !(q && q->staged.enabled());
    }
    bool prepare(const BatchLaunch& l) override {
        kernels_ = &c_->kernels_for(l);
        return true;
    }
    void enqueue(const BatchLaunch& l) override {
        SampleParallelCommon::Kernels& k = *kernels_;
        c_->reserve(l, 0);
        std::vector<cl::Kernel*> per_sample{&k.sample};
        if (k.has_redo) per_sample.push_back(&k.redo);
        c_->enqueue(l, k, per_sample,
                    std::vector<std::vector<cl::Buffer*>>(per_sample.size(), {&c_->scratch}));
    }

private:
    std::shared_ptr<SampleParallelCommon> c_;
    SampleParallelCommon::Kernels* kernels_ = nullptr;  // the prepared launch's
};

}  // namespace

std::shared_ptr<SampleParallelCommon> make_sample_parallel_common(LaunchResources& r) {
    return std::make_shared<SampleParallelCommon>(r);
}

std::unique_ptr<LaunchStrategy> make_sample_parallel_launch(LaunchResources& r,
                                                            std::shared_ptr<SampleParallelCommon> c) {
    return std::make_unique<SampleParallelLaunch>(r, std::move(c));
}

}  // namespace brdftab::launch
