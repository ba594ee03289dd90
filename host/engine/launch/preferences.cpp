// preferences.cpp — the launch preferences the models declare
// (QuantityInfo::sample_parallel, walk_parallel, node_parallel; engine.h),
// read from the registry: no model is named here.
#include <algorithm>

#include "host/engine/launch/resources.h"

namespace brdftab {

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
// "Node-parallel quadrature"), bit-identical to the usual kernel
// (tests/test_node_parallel.cpp).  A quantity can stay off by default (NodeParallelFunctions::by_default).
bool node_parallel_by_default() { return true; }

bool sample_parallel_by_default(const ModelInfo& model, const QuantityInfo& quantity,
                                Method method, const std::vector<int>& options) {
    return std::any_of(quantity.sample_parallel.begin(), quantity.sample_parallel.end(),
                       [&](const SampleParallelRule& r) {
                           return r.method == method &&
                                  std::all_of(r.options.begin(), r.options.end(),
                                              [&](const OptionChoice& o) {
                                                  return launch::option_is(model, options, o.option, o.choice);
                                              });
                       });
}

}  // namespace brdftab
