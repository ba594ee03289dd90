// sample_parallel.h — what the sample-parallel and the staged launches share
// (sample_parallel.cpp, staged.cpp): when they apply, their kernels (one
// program per build, both strategies' entry points in it) and the sub-launch
// loop over the per-sample kernels and the reduce kernel.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "host/engine/launch/resources.h"

namespace brdftab::launch {

class SampleParallelCommon {
public:
    explicit SampleParallelCommon(LaunchResources& r) : r_(r) {}

    // The sample-parallel kernels of one (model, quantity, options, method)
    // (kernels/common/sample_parallel.cl).  With
    // a redo: the sample and reduce kernels come from a fixed-step build
    // (uses_fixed_step_solver), and redo, from the usual build, computes
    // again every sample that build left as NaN.  Staged
    // (QuantityInfo::staged): stage (from the fixed-step build where there
    // is one, with stage_redo from the usual build), rest and reduce run
    // instead of sample and reduce (estimator.h, "Staged samples").
    struct Kernels {
        cl::Kernel sample, reduce, redo;
        bool has_redo = false;
        cl::Kernel stage, stage_redo, rest;
        std::size_t stage_size = 0;  // 0: not staged
    };

    // Whether this launch runs sample-parallel: only Monte Carlo / RQMC
    // batches of several samples that fit the scratch cap, and then as
    // tuning.sample_parallel says (Off: never, On: always), or by default
    // where the quantity declares it (sample_parallel_by_default()).
    bool applies(const BatchLaunch& l) const;
    // Whether its sample-parallel kernels use microfacet.h's fixed-step
    // search (QuantityInfo::fixed_step_solver; double precision only).
    bool uses_fixed_step_solver(const BatchLaunch& l) const;
    Kernels& kernels_for(const BatchLaunch& l);
    // Enqueues `per_sample` (each over every sample, in turn) and k.reduce
    // over every work item of `l`, in sub-launches of at most
    // scratch_samples() samples.  The per-sample kernels' arguments after
    // the work arguments: first_work, n_samples, batch and then `tail`
    // (scratch_, stage_ or both: staged_args()).
    void enqueue(const BatchLaunch& l, Kernels& k, const std::vector<cl::Kernel*>& per_sample,
                 const std::vector<std::vector<cl::Buffer*>>& tails);
    // The scratch of one sub-launch's samples and (staged) their first stages.
    cl::Buffer scratch, stage;
    // Sizes scratch (and stage, with stage_size > 0) for `l`.
    void reserve(const BatchLaunch& l, std::size_t stage_size);

private:
    // Samples per sub-launch (tuning.sample_parallel_scratch_samples); a
    // launch of more work items is split into sub-launches of whole batches,
    // which changes no result; a batch larger than the cap runs the usual
    // kernel.
    std::size_t scratch_samples() const;
    std::size_t per_sub(const BatchLaunch& l) const;

    LaunchResources& r_;
    std::map<std::string, Kernels> kernels_;
    std::size_t scratch_bytes_ = 0, stage_bytes_ = 0;
};

}  // namespace brdftab::launch
