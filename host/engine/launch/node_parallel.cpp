// node_parallel.cpp — the parts every node-parallel launch shares
// (node_parallel.h).
#include "host/engine/launch/node_parallel.h"

#include <algorithm>

#include "kernels/common/estimator.h"
#include "host/engine/kernel_sources.h"

namespace brdftab::launch {

const NodeParallelFunctions* NodeParallelCommon::functions(const BatchLaunch& l) {
    const QuantityInfo* q = launch_quantity(l);
    return q && q->node_parallel.enabled() ? &q->node_parallel : nullptr;
}

bool NodeParallelCommon::applies(const BatchLaunch& l) const {
    if (l.method != BT_METHOD_QUADRATURE && l.method != BT_METHOD_CLOSED) return false;
    if (l.batch_size != 1 || !functions(l)) return false;
    if (r_.tuning.node_parallel == LaunchChoice::Off) return false;
    if (r_.tuning.node_parallel == LaunchChoice::On) return true;
    return node_parallel_by_default() && functions(l)->by_default;
}

std::size_t NodeParallelCommon::scratch_nodes() const {
    const std::size_t v = std::min(r_.tuning.node_parallel_scratch_nodes, std::size_t{1} << 31);
    return v >= 1 ? v : kNodeParallelScratchNodes;
}

NodeParallelCommon::Kernels& NodeParallelCommon::kernels_for(const BatchLaunch& l) {
    const ModelInfo& model = *l.model;
    const NodeParallelFunctions& f = *functions(l);
    const std::string options = r_.build_options(l);
    const std::string key = model.name + "\n" + f.term + "\n" + options;
    auto it = kernels_.find(key);
    if (it != kernels_.end()) return it->second;
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
                  r_.kernel_dir)
            : node_parallel_kernel_source(model.kernel_header, std::to_string(f.state_size),
                                          f.count, f.prepare, f.term, f.finish, r_.kernel_dir,
                                          f.split() ? f.term_first : "",
                                          f.split() ? f.term_second : "");
    cl::Program program = r_.program(source, options);
    try {
        Kernels k{cl::Kernel(program, kNodePrepareKernelName), cl::Kernel(program, kNodeKernelName),
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
        return kernels_.emplace(key, std::move(k)).first->second;
    } catch (const cl::Error& e) {
        throw LaunchResources::entry_point_error(e, "node-parallel entry points", model);
    }
}

std::shared_ptr<NodeParallelCommon> make_node_parallel_common(LaunchResources& r) {
    return std::make_shared<NodeParallelCommon>(r);
}

}  // namespace brdftab::launch
