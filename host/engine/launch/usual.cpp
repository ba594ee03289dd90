// usual.cpp — the usual launch: one work item per (cell, batch), each looping
// over its batch's samples (kernels/common/estimator.h,
// kernels/common/estimate.cl).  It runs every launch no other strategy takes.
#include "host/engine/kernel_sources.h"
#include "host/engine/launch/resources.h"

namespace brdftab::launch {

namespace {

class UsualLaunch final : public LaunchStrategy {
public:
    using LaunchStrategy::LaunchStrategy;

    bool applies(const BatchLaunch&) const override { return true; }
    bool overlaps() const override { return true; }
    void tuning_changed() override { last_kernel_ = nullptr; }  // build options may differ

    bool prepare(const BatchLaunch& l) override {
        kernel_ = &kernel_for(l);
        return true;
    }

    void enqueue(const BatchLaunch& l) override {
        cl::Kernel& kernel = *kernel_;
        int a = r_.set_work_args(kernel, l);
        kernel.setArg(a++, static_cast<cl_uint>(l.work_items()));
        kernel.setArg(a++, static_cast<cl_uint>(l.batch_size));
        kernel.setArg(a++, r_.out_mean);
        kernel.setArg(a++, r_.out_m2);
        r_.runtime.queue().enqueueNDRangeKernel(kernel, cl::NullRange,
                                                cl::NDRange(r_.padded_global(l.work_items())),
                                                r_.local_range());
    }

private:
    // The program of one (model, quantity, options, method): the model's
    // generic source built with them as compile-time constants
    // (kernels/common/estimator.h, "Specialisation").
    cl::Kernel& kernel_for(const BatchLaunch& l) {
        // Consecutive launches of one estimate() use the same kernel: skip
        // building its key (strings, a map look-up) then.
        if (last_kernel_ && last_model_ == l.model && last_quantity_ == l.quantity &&
            last_method_ == l.method && last_stride_ == l.stride && last_options_ == l.options)
            return *last_kernel_;
        cl::Kernel& kernel = r_.cached_kernel(kernels_, l, kEstimateKernelName, "entry point", [&] {
            return estimate_kernel_source(l.model->kernel_header, l.model->sample_function,
                                          r_.kernel_dir);
        });
        last_kernel_ = &kernel;  // std::map: the reference stays valid
        last_model_ = l.model;
        last_quantity_ = l.quantity;
        last_method_ = l.method;
        last_stride_ = l.stride;
        last_options_ = l.options;
        return kernel;
    }

    std::map<std::string, cl::Kernel> kernels_;
    cl::Kernel* kernel_ = nullptr;       // the prepared launch's
    cl::Kernel* last_kernel_ = nullptr;  // the kernel of the last launch, and its key
    const ModelInfo* last_model_ = nullptr;
    int last_quantity_ = 0;
    std::uint32_t last_method_ = 0;
    std::size_t last_stride_ = 0;
    std::vector<int> last_options_;
};

}  // namespace

std::unique_ptr<LaunchStrategy> make_usual_launch(LaunchResources& r) {
    return std::make_unique<UsualLaunch>(r);
}

}  // namespace brdftab::launch
