// node_parallel_nested.cpp — node-parallel quadrature as nested sums
// (kernels/common/node_parallel.h, "Nested sums"): a work item's value sums
// groups of nodes whose count only the device knows (the host counts a work
// item's groups, a group kernel each group's nodes), so each block of work
// items runs in two steps with one read between them; bit-identical to the
// usual kernel.
#include <algorithm>

#include "kernels/common/estimator.h"
#include "host/engine/launch/node_parallel.h"

namespace brdftab::launch {

namespace {

// Nested sums' sizes, as fractions of the node cap (NodeParallelCommon::
// scratch_nodes(), 2^22 by default).  Nodes per sub-launch: cap / 16 (2^18;
// the scratch holds `terms` values per node): on the nested-sum bench case
// at 12 nodes the same speed within the noise with 1/4 and with all of the
// cap, 1/16 marginally ahead.  Groups per block: cap / 64 (2^16, about 30 MB
// of that case's group state): device / serial host 2.77x at 2^10 groups,
// 2.95x at 2^12, 3.43x at 2^14, 3.77x at 2^16, no better at 2^17 or 2^18
// (docs/benchmarks.md, "Node-parallel quadrature").  Work items per block:
// cap / 256 (2^14, about 21 MB of its item state), a memory bound.
constexpr std::size_t kSubLaunchShare = 16, kBlockGroupShare = 64, kBlockItemShare = 256;

class NestedNodeLaunch final : public LaunchStrategy {
public:
    NestedNodeLaunch(LaunchResources& r, std::shared_ptr<NodeParallelCommon> c)
        : LaunchStrategy(r), c_(std::move(c)) {}

    bool applies(const BatchLaunch& l) const override {
        return c_->applies(l) && NodeParallelCommon::functions(l)->nested();
    }
    bool prepare(const BatchLaunch& l) override {
        kernels_ = &c_->kernels_for(l);
        return true;
    }
    void enqueue(const BatchLaunch& l) override;

private:
    std::shared_ptr<NodeParallelCommon> c_;
    NodeParallelCommon::Kernels* kernels_ = nullptr;  // the prepared launch's
    std::vector<std::uint32_t> groups_;  // groups of the block's work items
    // The group layout and state, every node's group.
    cl::Buffer item_group_, group_item_, group_nodes_, group_node_, group_state_, chunk_group_;
    std::size_t item_group_bytes_ = 0, group_item_bytes_ = 0, group_nodes_bytes_ = 0,
                group_node_bytes_ = 0, group_state_bytes_ = 0, chunk_group_bytes_ = 0;
    cl::Buffer group_partial_;
    std::size_t group_partial_bytes_ = 0;
    // Every node's own value (e.g. an inner integration variable), written
    // by the chunk kernel.
    cl::Buffer node_x_;
    std::size_t node_x_bytes_ = 0;
};

// Every work item's groups from the host count function; per block of
// whole work items (at most block_groups groups and block_items work items;
// a work item with more groups alone), the prepare and group kernels, a
// read of the device's node counts and their offsets, then per sub-launch
// of whole groups (at most node_target nodes; a group with more alone) the
// chunk (node to group), node and reduce kernels, and the block's sum
// kernel.  Only the read waits: a block's sub-launches and sum are queued
// behind one another.
void NestedNodeLaunch::enqueue(const BatchLaunch& l) {
    NodeParallelCommon::Kernels& k = *kernels_;
    const std::size_t real_size = r_.real_size();
    cl::CommandQueue& queue = r_.runtime.queue();
    cl::Context& ctx = r_.runtime.context();
    const NodeParallelFunctions& f = *NodeParallelCommon::functions(l);
    const std::size_t n = l.cells.size();
    HostNodeCounter host(l);
    // A work item's groups, counted on the host as its block is formed:
    // while the previous block's kernels run (about 4 % of a launch's
    // time on the nested-sum bench case when counted up front with the
    // device idle).
    auto groups_of = [&](std::size_t w) {
        const int count = host(f.host_count, w);
        return static_cast<std::uint32_t>(std::clamp(count, 0, std::max(f.max_groups, 0)));
    };
    std::vector<std::uint32_t>& groups = groups_;  // groups of the block's work items
    // Sub-launches and blocks as fractions of the node cap (kSubLaunchShare,
    // kBlockGroupShare, kBlockItemShare).
    const std::size_t node_cap = c_->scratch_nodes();
    const std::size_t node_target = std::max<std::size_t>(node_cap / kSubLaunchShare, 1);
    const std::size_t block_groups = std::max<std::size_t>(node_cap / kBlockGroupShare, 1);
    const std::size_t block_items = std::max<std::size_t>(node_cap / kBlockItemShare, 1);
    const std::size_t item_bytes = static_cast<std::size_t>(std::max(f.state_size, 1)) * real_size;
    const std::size_t group_bytes =
        static_cast<std::size_t>(std::max(f.group_state_size, 1)) * real_size;
    const std::size_t term_bytes = static_cast<std::size_t>(std::max(f.terms, 1)) * real_size;
    const std::size_t partial_bytes = static_cast<std::size_t>(std::max(f.partials, 1)) * real_size;
    auto grow = [&](cl::Buffer& buffer, std::size_t& have, std::size_t need, cl_mem_flags flags) {
        grow_buffer(ctx, buffer, have, need, flags);
    };
    // Two sets of the block's item and group layout, by block parity:
    // their writes do not wait, and a set is rewritten only after the
    // read of the block after its own, which waits for its writes.
    std::vector<std::uint32_t> item_groups[2], group_items[2], group_node;
    std::vector<cl_int> group_nodes;
    std::size_t block = 0;
    bool have_next = false;
    std::uint32_t next_groups = 0;
    const cl::NDRange local = r_.local_range();
    if (!k.table_ready) {
        // The table, once per program (the queue is in order: the
        // first prepare runs after it).
        const bool own = !f.table.empty();
        const std::size_t entries = own ? static_cast<std::size_t>(std::max(f.table_entries, 1)) : 1;
        const std::size_t values = own ? static_cast<std::size_t>(std::max(f.table_size, 1)) : 1;
        k.table = cl::Buffer(ctx, CL_MEM_READ_WRITE, entries * values * real_size);
        k.table_kernel.setArg(0, k.table);
        queue.enqueueNDRangeKernel(k.table_kernel, cl::NullRange,
                                   cl::NDRange(r_.padded_global(entries)), local);
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
        grow(item_group_, item_group_bytes_, (items + 1) * 4, CL_MEM_READ_ONLY);
        grow(group_item_, group_item_bytes_, total_groups * 4, CL_MEM_READ_ONLY);
        grow(group_nodes_, group_nodes_bytes_, total_groups * 4, CL_MEM_READ_WRITE);
        grow(group_node_, group_node_bytes_, (total_groups + 1) * 4, CL_MEM_READ_ONLY);
        grow(c_->state, c_->state_bytes, items * item_bytes, CL_MEM_READ_WRITE);
        grow(group_state_, group_state_bytes_, total_groups * group_bytes,
             CL_MEM_READ_WRITE);
        grow(group_partial_, group_partial_bytes_, total_groups * partial_bytes,
             CL_MEM_READ_WRITE);
        // Without groups the block has no read: its write waits, so that
        // no write is pending when a set is rewritten or this returns.
        queue.enqueueWriteBuffer(item_group_, total_groups == 0 ? CL_TRUE : CL_FALSE, 0,
                                 (items + 1) * 4, item_group.data());
        if (total_groups > 0) {
            queue.enqueueWriteBuffer(group_item_, CL_FALSE, 0, total_groups * 4,
                                     group_item.data());
            int a = r_.set_work_args(k.prepare, l);  // first_work, n_work, item_state
            k.prepare.setArg(a++, static_cast<cl_uint>(first));
            k.prepare.setArg(a++, static_cast<cl_uint>(items));
            k.prepare.setArg(a++, k.table);
            k.prepare.setArg(a++, c_->state);
            queue.enqueueNDRangeKernel(k.prepare, cl::NullRange, cl::NDRange(r_.padded_global(items)),
                                       local);
            // options, n_options, quantity, group_item, item_group, n_groups,
            // item_state, group_state, group_nodes
            r_.set_option_args(k.group, l);
            k.group.setArg(3, group_item_);
            k.group.setArg(4, item_group_);
            k.group.setArg(5, static_cast<cl_uint>(total_groups));
            k.group.setArg(6, c_->state);
            k.group.setArg(7, group_state_);
            k.group.setArg(8, group_nodes_);
            queue.enqueueNDRangeKernel(k.group, cl::NullRange,
                                       cl::NDRange(r_.padded_global(total_groups)), local);
            group_nodes.resize(total_groups);
            queue.enqueueReadBuffer(group_nodes_, CL_TRUE, 0, total_groups * 4,
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
            queue.enqueueWriteBuffer(group_node_, CL_TRUE, 0, (total_groups + 1) * 4,
                                     group_node.data());
            grow(chunk_group_, chunk_group_bytes_, most_nodes * 4, CL_MEM_READ_WRITE);
            grow(c_->scratch, c_->scratch_bytes, most_nodes * term_bytes, CL_MEM_READ_WRITE);
            grow(node_x_, node_x_bytes_, most_nodes * real_size, CL_MEM_READ_WRITE);
            // The arguments that stay for the block; the sub-launch's
            // first group, group and node counts are set per sub-launch.
            // chunk: group_node, first_group, n_groups, node_group,
            // group_item, item_state, group_state, node_x
            k.chunk.setArg(0, group_node_);
            set_args_from(k.chunk, 3, chunk_group_, group_item_, c_->state,
                          group_state_, node_x_);
            // node: options, n_options, quantity, node_group, group_item,
            // n_nodes, item_state, group_state, scratch, node_x
            r_.set_option_args(k.node, l);
            set_args_from(k.node, 3, chunk_group_, group_item_);
            set_args_from(k.node, 6, c_->state, group_state_, c_->scratch,
                          node_x_);
            // reduce: options, n_options, quantity, group_node, first_group,
            // n_groups, group_item, item_state, group_state, scratch,
            // group_partial
            r_.set_option_args(k.reduce, l);
            k.reduce.setArg(3, group_node_);
            set_args_from(k.reduce, 6, group_item_, c_->state, group_state_,
                          c_->scratch, group_partial_);
            for (const auto& [g0, g1] : subs.runs) {
                const std::size_t nodes = group_node[g1] - group_node[g0];
                const std::size_t sub_groups = g1 - g0;
                if (nodes > 0) {
                    k.chunk.setArg(1, static_cast<cl_uint>(g0));
                    k.chunk.setArg(2, static_cast<cl_uint>(sub_groups));
                    queue.enqueueNDRangeKernel(k.chunk, cl::NullRange,
                                               cl::NDRange(r_.padded_global(sub_groups)), local);
                    k.node.setArg(5, static_cast<cl_uint>(nodes));
                    queue.enqueueNDRangeKernel(k.node, cl::NullRange,
                                               cl::NDRange(r_.padded_global(nodes)), local);
                }
                k.reduce.setArg(4, static_cast<cl_uint>(g0));
                k.reduce.setArg(5, static_cast<cl_uint>(sub_groups));
                queue.enqueueNDRangeKernel(k.reduce, cl::NullRange,
                                           cl::NDRange(r_.padded_global(sub_groups)), local);
            }
        }
        // first_work, n_work, item_group, item_state, group_state,
        // group_partial, out_mean, out_m2
        int a = r_.set_work_args(k.sum, l);
        k.sum.setArg(a++, static_cast<cl_uint>(first));
        k.sum.setArg(a++, static_cast<cl_uint>(items));
        k.sum.setArg(a++, item_group_);
        k.sum.setArg(a++, c_->state);
        k.sum.setArg(a++, group_state_);
        k.sum.setArg(a++, group_partial_);
        k.sum.setArg(a++, r_.out_mean);
        k.sum.setArg(a++, r_.out_m2);
        queue.enqueueNDRangeKernel(k.sum, cl::NullRange, cl::NDRange(r_.padded_global(items)), local);
        first = last;
    }
}

}  // namespace

std::unique_ptr<LaunchStrategy> make_nested_node_launch(LaunchResources& r,
                                                        std::shared_ptr<NodeParallelCommon> c) {
    return std::make_unique<NestedNodeLaunch>(r, std::move(c));
}

}  // namespace brdftab::launch
