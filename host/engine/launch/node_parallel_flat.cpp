// node_parallel_flat.cpp — node-parallel quadrature as a flat sum
// (kernels/common/node_parallel.h): the host lays out every work item's
// nodes from the quantity's count function, a prepare kernel writes each
// work item's state, a node kernel computes one term per node and a sum
// kernel adds each work item's terms in node order, bit-identical to the
// usual kernel.  Split terms (NodeParallelFunctions::split()): the two
// forms of a term run on two node kernels of their own, each over the list
// of the nodes the host takes to be of its form.
#include <algorithm>
#include <tuple>

#include "kernels/common/estimator.h"
#include "host/engine/launch/node_parallel.h"

namespace brdftab::launch {

namespace {

class FlatNodeLaunch : public LaunchStrategy {
public:
    FlatNodeLaunch(LaunchResources& r, std::shared_ptr<NodeParallelCommon> c)
        : LaunchStrategy(r), c_(std::move(c)) {}

    bool applies(const BatchLaunch& l) const override {
        if (!c_->applies(l)) return false;
        const NodeParallelFunctions& f = *NodeParallelCommon::functions(l);
        return !f.nested() && splits(f) == split_;
    }
    bool prepare(const BatchLaunch& l) override {
        if (!lay_out_nodes(l)) return false;
        kernels_ = &c_->kernels_for(l);
        return true;
    }
    void enqueue(const BatchLaunch& l) override;

protected:
    // Whether a quantity with these functions runs split terms: where it
    // has them, unless tuning.split_node_terms is false (one node kernel
    // with both forms; the same bits either way, tests/test_node_parallel.cpp).
    bool splits(const NodeParallelFunctions& f) const { return f.split() && r_.tuning.split_node_terms; }
    // Enqueues the node kernel(s) of one sub-launch: work items [first,
    // last), `nodes` nodes from offset_[first].
    virtual void enqueue_nodes(std::size_t first, std::size_t last, std::size_t nodes);
    // Writes the layout's extra buffers and sets the node kernels' arguments
    // after the common ones (split terms: the node lists).
    virtual void set_node_args(const BatchLaunch& l);

    bool split_ = false;
    std::shared_ptr<NodeParallelCommon> c_;
    NodeParallelCommon::Kernels* kernels_ = nullptr;  // the prepared launch's
    // The layout: every work item's first node offset_[w] (exclusive prefix
    // sum, offset_[n] nodes in all) and the work item of every node.
    std::vector<std::uint32_t> offset_, item_;
    // Split terms: both node lists (first form, then second) and the
    // first-form nodes before each work item (lay_out_nodes).
    std::vector<std::uint32_t> list_, first_before_;
    cl::Buffer offset_buffer_, item_buffer_, list_buffer_;
    std::size_t offset_items_ = 0, item_items_ = 0, list_items_ = 0;

private:
    bool lay_out_nodes(const BatchLaunch& l);
};

// The node layout of `l`: every work item's node count from the host count
// function, their exclusive prefix sum offset_[0..n] and the work item of
// every node.  False (and another strategy runs) when the node numbers
// would not fit a uint.  tuning.node_layout_cap = N >= 0 lays out at most N
// nodes per work item, for tests of the sum kernel's own terms (what it
// does when the device counts more nodes than the host, e.g. in float).
bool FlatNodeLaunch::lay_out_nodes(const BatchLaunch& l) {
    const NodeParallelFunctions& f = *NodeParallelCommon::functions(l);
    const long long layout_cap = r_.tuning.node_layout_cap;
    const std::size_t n = l.cells.size();
    HostNodeCounter host(l);
    // Split terms: the first-form nodes (a work item's first host_split
    // ones), first_before_[w]: those of the work items before w.
    // tuning.node_split_shift = D moves every guess by D nodes (tests: the
    // nodes put on the wrong side must come out the same).
    const bool split = split_;
    const int shift = split ? r_.tuning.node_split_shift : 0;
    first_before_.assign(split ? n + 1 : 0, 0);
    std::uint32_t firsts = 0;
    offset_.resize(n + 1);
    std::uint64_t total = 0;
    for (std::size_t w = 0; w < n; ++w) {
        int count = host(f.host_count, w);
        if (layout_cap >= 0 && count > layout_cap) count = static_cast<int>(layout_cap);
        count = std::max(count, 0);
        if (total > 0xFFFFFFFFull) return false;
        offset_[w] = static_cast<std::uint32_t>(total);
        total += static_cast<std::uint64_t>(count);
        if (split) {
            first_before_[w] = firsts;
            const int guess = host(f.host_split, w) + shift;
            firsts += static_cast<std::uint32_t>(std::clamp(guess, 0, count));
        }
    }
    if (total > 0xFFFFFFFFull) return false;
    if (split) first_before_[n] = firsts;
    offset_[n] = static_cast<std::uint32_t>(total);
    item_.resize(static_cast<std::size_t>(total));
    for (std::size_t w = 0; w < n; ++w)
        std::fill(item_.begin() + offset_[w], item_.begin() + offset_[w + 1],
                  static_cast<std::uint32_t>(w));
    // Split terms: both node lists, first form then second, each in node
    // order.
    list_.clear();
    if (split) {
        list_.resize(static_cast<std::size_t>(total));
        for (std::size_t w = 0; w < n; ++w) {
            const std::uint32_t a = first_before_[w], b = first_before_[w + 1];
            const std::uint32_t base = offset_[w];
            for (std::uint32_t j = 0; j < b - a; ++j) list_[a + j] = base + j;
            const std::uint32_t second_at = firsts + base - a;  // list B follows list A
            for (std::uint32_t j = b - a; j < offset_[w + 1] - base; ++j)
                list_[second_at + j - (b - a)] = base + j;
        }
    }
    return true;
}

// Writes the node layout and enqueues the prepare, node and sum kernels over
// every work item of `l`, in sub-launches of at most c_->scratch_nodes()
// nodes.  Not blocking: the host vectors are members, unchanged until the
// blocking read that ends the launch.
void FlatNodeLaunch::enqueue(const BatchLaunch& l) {
    NodeParallelCommon::Kernels& k = *kernels_;
    cl::CommandQueue& queue = r_.runtime.queue();
    cl::Context& ctx = r_.runtime.context();
    const std::size_t n = l.cells.size();
    const std::size_t real_size = r_.real_size();
    // Sub-launches [first, last) of whole work items.
    const EntryRuns sub_launches = runs_within(offset_, n, c_->scratch_nodes());
    const std::size_t most_nodes = sub_launches.most_size, most_items = sub_launches.most_entries;
    const NodeParallelFunctions& f = *NodeParallelCommon::functions(l);
    // Buffers grown geometrically and kept; the scratch once per launch:
    // the in-order queue runs a sub-launch's node kernel after the previous
    // sum kernel has read it.
    const std::size_t total = offset_[n];
    if (n + 1 > offset_items_) {
        offset_items_ = std::max(n + 1, 2 * offset_items_);
        offset_buffer_ = cl::Buffer(ctx, CL_MEM_READ_ONLY, offset_items_ * sizeof(std::uint32_t));
    }
    if (std::max<std::size_t>(total, 1) > item_items_) {
        item_items_ = std::max(std::max<std::size_t>(total, 1), 2 * item_items_);
        item_buffer_ = cl::Buffer(ctx, CL_MEM_READ_ONLY, item_items_ * sizeof(std::uint32_t));
    }
    if (most_nodes * real_size > c_->scratch_bytes) {
        c_->scratch_bytes = most_nodes * real_size;
        c_->scratch = cl::Buffer(ctx, CL_MEM_READ_WRITE, c_->scratch_bytes);
    }
    const std::size_t state_bytes =
        most_items * static_cast<std::size_t>(std::max(f.state_size, 1)) * real_size;
    if (state_bytes > c_->state_bytes) {
        c_->state_bytes = state_bytes;
        c_->state = cl::Buffer(ctx, CL_MEM_READ_WRITE, c_->state_bytes);
    }
    queue.enqueueWriteBuffer(offset_buffer_, CL_FALSE, 0, (n + 1) * sizeof(std::uint32_t),
                             offset_.data());
    if (total > 0)
        queue.enqueueWriteBuffer(item_buffer_, CL_FALSE, 0, total * sizeof(std::uint32_t), item_.data());
    set_node_args(l);
    const int prepare_first_arg = r_.set_work_args(k.prepare, l);  // first_work, n_work, state
    k.prepare.setArg(prepare_first_arg + 2, c_->state);
    // first_work, n_work after the work arguments: node_offset, first_node,
    // first_work, n_work, scratch, out_mean, out_m2
    const int sum_first_arg = r_.set_work_args(k.sum, l);
    k.sum.setArg(sum_first_arg, offset_buffer_);
    k.sum.setArg(sum_first_arg + 4, c_->scratch);
    k.sum.setArg(sum_first_arg + 5, r_.out_mean);
    k.sum.setArg(sum_first_arg + 6, r_.out_m2);
    const cl::NDRange local = r_.local_range();
    for (const auto& [first, last] : sub_launches.runs) {
        const std::size_t nodes = offset_[last] - offset_[first];
        if (nodes > 0) {
            k.prepare.setArg(prepare_first_arg, static_cast<cl_uint>(first));
            k.prepare.setArg(prepare_first_arg + 1, static_cast<cl_uint>(last - first));
            queue.enqueueNDRangeKernel(k.prepare, cl::NullRange,
                                       cl::NDRange(r_.padded_global(last - first)), local);
            enqueue_nodes(first, last, nodes);
        }
        k.sum.setArg(sum_first_arg + 1, static_cast<cl_uint>(offset_[first]));
        k.sum.setArg(sum_first_arg + 2, static_cast<cl_uint>(first));
        k.sum.setArg(sum_first_arg + 3, static_cast<cl_uint>(last - first));
        queue.enqueueNDRangeKernel(k.sum, cl::NullRange, cl::NDRange(r_.padded_global(last - first)),
                                   local);
    }
}

// options, n_options, quantity, node_item, node_offset, first_work,
// first_node, n_nodes, state, scratch (the split kernels: then node_list,
// list_first).
void FlatNodeLaunch::set_node_args(const BatchLaunch& l) {
    cl::Kernel& kernel = kernels_->node;
    r_.set_option_args(kernel, l);
    kernel.setArg(3, item_buffer_);
    kernel.setArg(4, offset_buffer_);
    kernel.setArg(8, c_->state);
    kernel.setArg(9, c_->scratch);
}

void FlatNodeLaunch::enqueue_nodes(std::size_t first, std::size_t, std::size_t nodes) {
    cl::Kernel& node = kernels_->node;
    node.setArg(5, static_cast<cl_uint>(first));
    node.setArg(6, static_cast<cl_uint>(offset_[first]));
    node.setArg(7, static_cast<cl_uint>(nodes));
    r_.runtime.queue().enqueueNDRangeKernel(node, cl::NullRange, cl::NDRange(r_.padded_global(nodes)),
                                            r_.local_range());
}

class SplitNodeLaunch final : public FlatNodeLaunch {
public:
    SplitNodeLaunch(LaunchResources& r, std::shared_ptr<NodeParallelCommon> c)
        : FlatNodeLaunch(r, std::move(c)) {
        split_ = true;
    }

private:
    void set_node_args(const BatchLaunch& l) override {
        FlatNodeLaunch::set_node_args(l);
        const std::size_t total = offset_.back();
        if (total > 0) {
            if (total > list_items_) {
                list_items_ = std::max(total, 2 * list_items_);
                list_buffer_ = cl::Buffer(r_.runtime.context(), CL_MEM_READ_ONLY,
                                          list_items_ * sizeof(std::uint32_t));
            }
            r_.runtime.queue().enqueueWriteBuffer(list_buffer_, CL_FALSE, 0,
                                                  total * sizeof(std::uint32_t), list_.data());
        }
        for (cl::Kernel* kernel : {&kernels_->first, &kernels_->second}) {
            r_.set_option_args(*kernel, l);
            kernel->setArg(3, item_buffer_);
            kernel->setArg(4, offset_buffer_);
            kernel->setArg(8, c_->state);
            kernel->setArg(9, c_->scratch);
            kernel->setArg(10, list_buffer_);
        }
    }

    // The sub-launch's stretch of each list: [begin, begin + count).
    void enqueue_nodes(std::size_t first, std::size_t last, std::size_t) override {
        const std::uint32_t firsts = first_before_.back();
        const std::uint32_t a0 = first_before_[first], a1 = first_before_[last];
        const std::uint32_t b0 = firsts + offset_[first] - a0, b1 = firsts + offset_[last] - a1;
        for (const auto& [kernel, begin, count] :
             {std::tuple<cl::Kernel*, std::uint32_t, std::uint32_t>{&kernels_->first, a0, a1 - a0},
              {&kernels_->second, b0, b1 - b0}}) {
            if (count == 0) continue;
            kernel->setArg(5, static_cast<cl_uint>(first));
            kernel->setArg(6, static_cast<cl_uint>(offset_[first]));
            kernel->setArg(7, static_cast<cl_uint>(count));
            kernel->setArg(11, static_cast<cl_uint>(begin));
            r_.runtime.queue().enqueueNDRangeKernel(*kernel, cl::NullRange,
                                                    cl::NDRange(r_.padded_global(count)),
                                                    r_.local_range());
        }
    }
};

}  // namespace

std::unique_ptr<LaunchStrategy> make_flat_node_launch(LaunchResources& r,
                                                      std::shared_ptr<NodeParallelCommon> c) {
    return std::make_unique<FlatNodeLaunch>(r, std::move(c));
}

std::unique_ptr<LaunchStrategy> make_split_node_launch(LaunchResources& r,
                                                       std::shared_ptr<NodeParallelCommon> c) {
    return std::make_unique<SplitNodeLaunch>(r, std::move(c));
}

}  // namespace brdftab::launch
