// walk_parallel.cpp — walk-parallel launches (kernels/common/walk_parallel.h):
// a random-walk quantity that names its walk functions
// (QuantityInfo::walk_parallel) runs its Monte Carlo batches on a kernel that
// advances every work item's walk one collision per round and starts a
// batch's next sample as soon as a walk ends, bit-identical to the usual
// kernel.
#include <algorithm>

#include "kernels/common/estimator.h"
#include "host/engine/kernel_sources.h"
#include "host/engine/launch/resources.h"

namespace brdftab::launch {

namespace {

const WalkParallelFunctions* walk_functions(const BatchLaunch& l) {
    const QuantityInfo* q = launch_quantity(l);
    return q && q->walk_parallel.enabled() ? &q->walk_parallel : nullptr;
}

class WalkParallelLaunch final : public LaunchStrategy {
public:
    using LaunchStrategy::LaunchStrategy;

    // Monte Carlo only: with RQMC the round runs the first collision's
    // Sobol' draws (if-converted) for every lane in every round, and the
    // launch measured no faster than the usual kernel (docs/benchmarks.md).
    bool applies(const BatchLaunch& l) const override {
        if (l.method != BT_METHOD_MC || !r_.tuning.walk_parallel) return false;
        return walk_functions(l) != nullptr;
    }
    bool overlaps() const override { return true; }

    bool prepare(const BatchLaunch& l) override {
        kernel_ = &r_.cached_kernel(kernels_, l, kWalkKernelName, "walk-parallel entry point", [&] {
            const WalkParallelFunctions& c = *walk_functions(l);
            return walk_parallel_kernel_source(l.model->kernel_header,
                                               {c.state, c.setup, c.begin, c.step, c.value},
                                               r_.kernel_dir);
        });
        return true;
    }

    void enqueue(const BatchLaunch& l) override {
        cl::Kernel& kernel = *kernel_;
        const std::size_t n = l.work_items();
        int a = r_.set_work_args(kernel, l);
        kernel.setArg(a++, static_cast<cl_uint>(n));
        kernel.setArg(a++, static_cast<cl_uint>(l.batch_size));
        kernel.setArg(a++, r_.out_mean);
        kernel.setArg(a++, r_.out_m2);
        const std::size_t group = walk_group();
        r_.runtime.queue().enqueueNDRangeKernel(kernel, cl::NullRange,
                                                cl::NDRange((n + group - 1) / group * group),
                                                cl::NDRange(group));
    }

private:
    // The work-group size of walk-parallel launches: kWalkLocalSize (one
    // SIMD vector of doubles as PoCL vectorised the round: width 4), or
    // tuning.walk_local_size (1..256).  A group runs as many rounds as its
    // busiest work item, so small groups waste fewer lanes on the long walks'
    // tails: measured 4 > 8 > 16 > 64, and 1 or 2 (no SIMD) slower
    // (docs/benchmarks.md, "Walk-parallel launch").
    std::size_t walk_group() const {
        const std::size_t chosen = r_.tuning.walk_local_size;
        const std::size_t group = chosen >= 1 && chosen <= 256 ? chosen : kWalkLocalSize;
        return std::min<std::size_t>(group, r_.runtime.device_info().max_work_group_size);
    }

    std::map<std::string, cl::Kernel> kernels_;
    cl::Kernel* kernel_ = nullptr;  // the prepared launch's
};

}  // namespace

std::unique_ptr<LaunchStrategy> make_walk_parallel_launch(LaunchResources& r) {
    return std::make_unique<WalkParallelLaunch>(r);
}

}  // namespace brdftab::launch
