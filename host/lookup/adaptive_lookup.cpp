// adaptive_lookup.cpp — lookups in adaptive tables (docs/adaptive.md): the
// table's axes prepared once, each coordinate resolved as for a tensor table,
// then the tree descent and the leaf interpolant of host/adaptive (its public
// AdaptiveLayout::eval).  The kernel for the axis count is chosen once when
// the table is loaded; a lookup allocates nothing.
#include <algorithm>
#include <memory>

#include "host/adaptive/adaptive_table.h"
#include "host/core/error.h"
#include "host/lookup/lookup.h"
#include "host/lookup/lookup_internal.h"

namespace brdftab {

using namespace lookup_internal;

namespace {

constexpr std::size_t kMaxAdaptiveDims = 8;

// The value at resolved coordinates x (each inside its axis): t as
// AdaptiveTable::to_t forms it (the inverse warp, unwarp_at on a dependent
// axis, clamped to [0, 1]), then the layout's eval: AdaptiveTable::eval's
// result bit for bit.
// The leaf holding t (every t_a in [0, 1]): AdaptiveLayout::leaf_of's
// descent (whose clamp is then the identity) over the packed nodes.
BT_LOOKUP_INLINE std::size_t leaf_at(const lookup_detail::TreeNode* tree, const double* t) {
    const lookup_detail::TreeNode* n = tree;
    // The child indexed by the comparison: no branch to mispredict per level.
    while (n->axis >= 0) n = tree + n->child[!(t[n->axis] < n->split)];
    return n->child[0];
}

std::vector<lookup_detail::TreeNode> pack_tree(const AdaptiveLayout& L) {
    std::vector<lookup_detail::TreeNode> tree(L.split_axis.size());
    for (std::size_t k = 0; k < tree.size(); ++k)
        tree[k] = {L.split_t[k], L.split_axis[k], {L.lower[k], L.upper[k]}};
    return tree;
}

template <int D>
BT_LOOKUP_INLINE double adaptive_value(const AdaptiveTable& at, const lookup_detail::TreeNode* tree,
                                       const FastAxis* fast, const int* dependency, const double* x,
                                       std::size_t dims) {
    double t[kMaxAdaptiveDims];
    const Axis* axes = at.data.axes.data();
    auto one = [&](std::size_t d) {
        const double u = dependency[d] >= 0 ? axes[d].unwarp_at(x[d], x[dependency[d]])
                                            : unwarp_fast(fast[d], axes[d], x[d]);
        t[d] = std::clamp(u, 0.0, 1.0);
    };
    if constexpr (D > 0) {
#pragma GCC unroll 8
        for (int d = 0; d < D; ++d) one(std::size_t(d));
    } else {
        for (std::size_t d = 0; d < dims && d < kMaxAdaptiveDims; ++d) one(d);
    }
    return at.layout.eval_leaf(leaf_at(tree, t), t, at.data.value.data());
}

}  // namespace

LookupTable::LookupTable(AdaptiveTable table) {
    auto at = std::make_shared<AdaptiveTable>(std::move(table));
    const std::string where = "table '" + at->data.name + "'";
    // The axes serve their warps only; their node lists (explicit warps)
    // are formed as a tensor table's would be.
    for (auto& a : at->data.axes)
        if (a.values.empty() && a.count >= 2)
            for (std::size_t k = 0; k < a.count; ++k)
                a.values.push_back(a.dependent() ? double(k) / double(a.count - 1)
                                                 : a.warp(double(k) / double(a.count - 1)));
    if (at->data.axes.empty() || at->data.axes.size() > kMaxAdaptiveDims)
        throw InputError(where + ": an adaptive table needs 1 to 8 axes, it has " +
                         std::to_string(at->data.axes.size()));
    if (at->layout.dims != at->data.axes.size())
        throw InputError(where + ": its layout has " + std::to_string(at->layout.dims) +
                         " axes, the table " + std::to_string(at->data.axes.size()));
    at->layout.check(at->data.value.size(), where + ": ");
    pieces_.push_back(at->data);
    adaptive_ = std::move(at);
    init_adaptive();
}

template <int D>
double LookupTable::adaptive_kernel(const LookupTable& lt, const double* coords, OutOfRange mode) {
    const FastAxis* fast = lt.fast_.data();
    const Axis* ax = lt.pieces_.front().axes.data();
    double x[D];
#pragma GCC unroll 8
    for (int d = 0; d < D; ++d)
        x[d] = resolve_fast(fast[d], ax[d], coords[d], mode, lt.pieces_.front().name);
    return adaptive_value<D>(*lt.adaptive_, lt.tree_.data(), fast, lt.dependency_.data(), x, D);
}

void LookupTable::init_adaptive() {
    const TableData& head = pieces_.front();
    const std::string where = "table '" + head.name + "'";
    if (head.parameters.is_object()) {
        if (head.parameters.contains("recombine"))
            throw InputError(where + ": an adaptive table cannot carry parameters.recombine");
        const auto rh = head.parameters.find("reciprocal_half");
        if (rh != head.parameters.end() && !(rh->is_boolean() && !rh->get<bool>()))
            throw InputError(where + ": an adaptive table cannot be a reciprocal half table");
    }
    init_axes();
    strides_.clear();
    tree_ = pack_tree(adaptive_->layout);
    init_angles();
    using Fn = double (*)(const LookupTable&, const double*, OutOfRange);
    static const Fn kernels[] = {&adaptive_kernel<1>, &adaptive_kernel<2>, &adaptive_kernel<3>,
                                 &adaptive_kernel<4>, &adaptive_kernel<5>, &adaptive_kernel<6>,
                                 &adaptive_kernel<7>, &adaptive_kernel<8>};
    linear_ = kernels[head.axes.size() - 1];
}

void LookupTable::refuse_adaptive(const char* what) const {
    throw InputError("table '" + table().name + "' is adaptive: " + what +
                     " (its patches interpolate linearly; docs/adaptive.md)");
}

void BoundTable::bind_adaptive(const LookupTable& lt, const std::vector<double>& coords) {
    adaptive_ = lt.adaptive_;
    adaptive_fast_ = lt.fast_;
    adaptive_coords_ = coords;
    adaptive_dependency_ = lt.dependency_;
    adaptive_tree_ = lt.tree_;
    kernel_ = Kernel::Adaptive;
    // The sampling densities' corners: the table at the angle axes' nodes.
    const std::size_t ni = axes_[0].count, no = axes_[1].count, np = axes_[2].count;
    values_.resize(ni * no * np);
    for (std::size_t i = 0; i < ni; ++i)
        for (std::size_t o = 0; o < no; ++o)
            for (std::size_t f = 0; f < np; ++f) {
                const double x[3] = {axes_[0].values[i], axes_[1].values[o], axes_[2].values[f]};
                values_[(i * no + o) * np + f] = eval_adaptive(x);
            }
}

double BoundTable::eval_adaptive(const double* x) const {
    double c[kMaxAdaptiveDims];
    const std::size_t dims = adaptive_coords_.size();
    std::copy(adaptive_coords_.begin(), adaptive_coords_.end(), c);
    c[layout_.axis_i] = x[0];
    c[layout_.axis_o] = x[1];
    if (has_phi_) c[layout_.axis_phi] = x[2];
    return adaptive_value<0>(*adaptive_, adaptive_tree_.data(), adaptive_fast_.data(),
                             adaptive_dependency_.data(), c, dims);
}

}  // namespace brdftab
