// staged.cpp — staged sample-parallel launches (QuantityInfo::staged;
// kernels/common/estimator.h, "Staged samples"): each sample's first stage
// (from the fixed-step build where there is one, then its redo from the
// usual build) writes a stage buffer, the rest kernel finishes the samples
// from it, and the reduce kernel merges them in sample order, bit-identical
// to the usual kernel.
#include "host/engine/launch/sample_parallel.h"

namespace brdftab::launch {

namespace {

class StagedLaunch final : public LaunchStrategy {
public:
    StagedLaunch(LaunchResources& r, std::shared_ptr<SampleParallelCommon> c)
        : LaunchStrategy(r), c_(std::move(c)) {}

    bool applies(const BatchLaunch& l) const override {
        const QuantityInfo* q = launch_quantity(l);
        return q && q->staged.enabled() && c_->applies(l);
    }
    bool prepare(const BatchLaunch& l) override {
        kernels_ = &c_->kernels_for(l);
        return true;
    }
    void enqueue(const BatchLaunch& l) override {
        SampleParallelCommon::Kernels& k = *kernels_;
        c_->reserve(l, k.stage_size);
        // stage and its redo write the stage buffer; rest reads it and
        // writes the scratch.
        std::vector<cl::Kernel*> per_sample{&k.stage};
        std::vector<std::vector<cl::Buffer*>> tails{{&c_->stage}};
        if (k.has_redo) {
            per_sample.push_back(&k.stage_redo);
            tails.push_back({&c_->stage});
        }
        per_sample.push_back(&k.rest);
        tails.push_back({&c_->scratch, &c_->stage});
        c_->enqueue(l, k, per_sample, tails);
    }

private:
    std::shared_ptr<SampleParallelCommon> c_;
    SampleParallelCommon::Kernels* kernels_ = nullptr;  // the prepared launch's
};

}  // namespace

std::unique_ptr<LaunchStrategy> make_staged_launch(LaunchResources& r,
                                                   std::shared_ptr<SampleParallelCommon> c) {
    return std::make_unique<StagedLaunch>(r, std::move(c));
}

}  // namespace brdftab::launch
