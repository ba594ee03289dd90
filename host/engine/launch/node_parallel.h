// node_parallel.h — what the node-parallel launches share
// (node_parallel_flat.cpp: flat sums and split terms; node_parallel_nested.cpp:
// nested sums): when they apply, their kernels (one program per build) and
// the buffers of a launch's node layout and terms.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "kernels/common/estimator.h"
#include "host/engine/launch/resources.h"

namespace brdftab::launch {

// The host count functions (NodeParallelFunctions::host_count, host_split)
// called on a launch's work items as the device's count function sees them:
// the work item's point, the options and a sampler at its cell and batch.
class HostNodeCounter {
public:
    explicit HostNodeCounter(const BatchLaunch& l) : l_(l) {
        options_array(l, opts_);
        s_.key0 = l.key0;
        s_.key1 = l.key1;
        s_.method = l.method;
        s_.sample = 0;
    }
    int operator()(HostNodeCountFn fn, std::size_t w) {
        if (w != loaded_) {
            std::copy_n(&l_.points[w * l_.stride], l_.stride, point_);
            s_.cell = l_.cells[w];
            s_.batch = l_.batches[w];
            loaded_ = w;
        }
        return fn(point_, opts_, l_.quantity, &s_);
    }

private:
    const BatchLaunch& l_;
    int opts_[BT_MAX_OPTIONS];
    double point_[BT_MAX_POINT] = {0};
    bt_sampler s_{};
    std::size_t loaded_ = static_cast<std::size_t>(-1);
};

class NodeParallelCommon {
public:
    explicit NodeParallelCommon(LaunchResources& r) : r_(r) {}

    // The node-parallel kernels (kernels/common/node_parallel.h) of one
    // (model, quantity, options, method).
    struct Kernels {
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

    static const NodeParallelFunctions* functions(const BatchLaunch& l);
    // Whether this launch runs node-parallel: quadrature (or closed-form)
    // launches of one-sample batches of a quantity that names node functions
    // (QuantityInfo::node_parallel), then as tuning.node_parallel says (Off:
    // never, On: always), by default where node_parallel_by_default() and
    // the quantity (NodeParallelFunctions::by_default) say so.
    bool applies(const BatchLaunch& l) const;
    Kernels& kernels_for(const BatchLaunch& l);
    // Nodes per sub-launch of the node-parallel path (the scratch buffer's
    // size: 2^22 terms); a launch with more nodes is split into sub-launches
    // of whole work items, which changes no result (a work item with more
    // nodes than the cap gets a sub-launch of its own);
    // tuning.node_parallel_scratch_nodes sets another cap.
    std::size_t scratch_nodes() const;

    // The buffers every kind of node-parallel launch uses: every work
    // item's prepared state and one sub-launch's terms.
    cl::Buffer state, scratch;
    std::size_t state_bytes = 0, scratch_bytes = 0;

private:
    LaunchResources& r_;
    std::map<std::string, Kernels> kernels_;
};

}  // namespace brdftab::launch
