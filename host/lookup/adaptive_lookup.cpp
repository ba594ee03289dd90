// adaptive_lookup.cpp — lookups in adaptive tables (docs/adaptive.md): the
// table's axes prepared once, each coordinate resolved as for a tensor table,
// then the tree descent and the leaf interpolant of host/adaptive (its public
// AdaptiveLayout::eval).  The kernel for the axis count is chosen once when
// the table is loaded; a lookup allocates nothing.
#include <algorithm>
#include <cmath>
#include <memory>

#include "host/adaptive/adaptive_table.h"
#include "host/core/error.h"
#include "host/lookup/lookup.h"
#include "host/lookup/lookup_internal.h"

namespace brdftab {

using namespace lookup_internal;
using lookup_detail::AdaptiveKernel;
using lookup_detail::TreeNode;

namespace {

constexpr std::size_t kMaxAdaptiveDims = 8;

// The value at resolved coordinates x (each inside its axis): t as
// AdaptiveTable::to_t forms it (the inverse warp, unwarp_at on a dependent
// axis, clamped to [0, 1]), then the layout's eval: AdaptiveTable::eval's
// result bit for bit.
// The leaf holding t (every t_a in [0, 1]): AdaptiveLayout::leaf_of's
// descent (whose clamp is then the identity) over the packed nodes.
BT_LOOKUP_INLINE std::size_t leaf_at(const lookup_detail::TreeNode* tree, const double* t,
                                     std::uint32_t from = 0) {
    const lookup_detail::TreeNode* n = tree + from;
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

// t of resolved coordinates x (each inside its axis), as AdaptiveTable::to_t
// forms it: the inverse warp (unwarp_at on a dependent axis) clamped to [0, 1].
template <int D>
BT_LOOKUP_INLINE void t_of(const AdaptiveTable& at, const FastAxis* fast, const int* dependency,
                           const double* x, double* t) {
    const Axis* axes = at.data.axes.data();
#pragma GCC unroll 8
    for (int d = 0; d < D; ++d) {
        const double u = dependency[d] >= 0 ? axes[d].unwarp_at(x[d], x[dependency[d]])
                                            : unwarp_fast(fast[d], axes[d], x[d]);
        t[d] = std::clamp(u, 0.0, 1.0);
    }
}

// AdaptiveLayout::eval_leaf's multilinear interpolant unrolled for D axes,
// in its order of operations (the same bits): the cell of each axis in the
// leaf's box, then the 2^D corners, zero weights skipped.
template <int D>
BT_LOOKUP_INLINE double leaf_multilinear(const AdaptiveLayout& L, const AdaptiveKernel& k,
                                         std::size_t leaf, const double* t, const double* values) {
    const std::size_t n = L.patch_nodes;
    const double* b = L.box.data() + leaf * D * 2;
    const std::uint32_t* nodes = L.leaf_nodes.data() + leaf * k.nodes_per_leaf;
    std::size_t base = 0;
    double frac[D];
#pragma GCC unroll 8
    for (int a = 0; a < D; ++a) {
        const double lo = b[2 * a], hi = b[2 * a + 1];
        double u = (std::clamp(t[a], lo, hi) - lo) / (hi - lo) * double(n - 1);
        u = std::clamp(u, 0.0, double(n - 1));
        const std::size_t i = std::min(static_cast<std::size_t>(u), n - 2);
        frac[a] = u - double(i);
        base += i * k.stride[a];
    }
    double sum = 0;
#pragma GCC unroll 256
    for (std::size_t corner = 0; corner < (std::size_t{1} << D); ++corner) {
        double w = 1;
        std::size_t idx = base;
#pragma GCC unroll 8
        for (int a = 0; a < D; ++a) {
            if (corner >> a & 1) {
                w *= frac[a];
                idx += k.stride[a];
            } else {
                w *= 1 - frac[a];
            }
        }
        if (w != 0) sum += w * values[nodes[idx]];
    }
    return sum;
}

// The kernels: Unrolled: leaf_multilinear; otherwise the layout's own
// eval_leaf (whatever its patches are).
template <int D, bool Unrolled>
double adaptive_value(const AdaptiveTable& at, const AdaptiveKernel& k, const TreeNode* tree,
                      const FastAxis* fast, const int* dependency, const double* x) {
    double t[D];
    t_of<D>(at, fast, dependency, x, t);
    // The grid cell of t: floor(t 2^bits) is exact (a power of two).
    const double g = double(std::size_t{1} << k.grid_bits);
    const std::size_t last = (std::size_t{1} << k.grid_bits) - 1;
    std::size_t cell = 0;
#pragma GCC unroll 8
    for (int d = 0; d < D; ++d)
        cell = (cell << k.grid_bits) | std::min(static_cast<std::size_t>(t[d] * g), last);
    const std::size_t leaf = leaf_at(tree, t, k.start[cell]);
    if constexpr (Unrolled)
        return leaf_multilinear<D>(at.layout, k, leaf, t, at.data.value.data());
    else
        return at.layout.eval_leaf(leaf, t, at.data.value.data());
}

// The kernel for the table's axis count.  The unrolled interpolant is taken
// only when it gives eval_leaf's bits at the centre and at two off-centre
// points of every leaf, so a patch that is not multilinear keeps the
// layout's own interpolation.
AdaptiveKernel choose_kernel(const AdaptiveTable& at) {
    const AdaptiveLayout& L = at.layout;
    const std::size_t dims = L.dims;
    AdaptiveKernel k;
    k.nodes_per_leaf = L.nodes_per_leaf();
    std::size_t s = 1;
    for (std::size_t a = dims; a-- > 0;) {
        k.stride[a] = s;
        s *= L.patch_nodes;
    }
    using Fn = decltype(k.value);
    static const Fn unrolled[] = {&adaptive_value<1, true>, &adaptive_value<2, true>,
                                  &adaptive_value<3, true>, &adaptive_value<4, true>,
                                  &adaptive_value<5, true>, &adaptive_value<6, true>,
                                  &adaptive_value<7, true>, &adaptive_value<8, true>};
    static const Fn general[] = {&adaptive_value<1, false>, &adaptive_value<2, false>,
                                 &adaptive_value<3, false>, &adaptive_value<4, false>,
                                 &adaptive_value<5, false>, &adaptive_value<6, false>,
                                 &adaptive_value<7, false>, &adaptive_value<8, false>};
    using Leaf = double (*)(const AdaptiveLayout&, const AdaptiveKernel&, std::size_t, const double*,
                            const double*);
    static const Leaf leaf_fns[] = {&leaf_multilinear<1>, &leaf_multilinear<2>, &leaf_multilinear<3>,
                                    &leaf_multilinear<4>, &leaf_multilinear<5>, &leaf_multilinear<6>,
                                    &leaf_multilinear<7>, &leaf_multilinear<8>};
    bool same = true;
    const double* v = at.data.value.data();
    for (std::size_t l = 0; same && l < L.leaf_count(); ++l) {
        const double* b = L.box.data() + l * dims * 2;
        for (double f : {0.5, 0.3, 0.8125}) {
            double t[8];
            for (std::size_t a = 0; a < dims; ++a)
                t[a] = b[2 * a] + (a % 2 ? 1 - f : f) * (b[2 * a + 1] - b[2 * a]);
            const double x = leaf_fns[dims - 1](L, k, l, t, v), y = L.eval_leaf(l, t, v);
            same = same && (x == y || (std::isnan(x) && std::isnan(y)));
        }
    }
    k.value = same ? unrolled[dims - 1] : general[dims - 1];
    // The start grid: at most 2^15 cells, at most 2^6 per axis.
    k.grid_bits = unsigned(std::min<std::size_t>(6, 15 / dims));
    const std::size_t per = std::size_t{1} << k.grid_bits, cells = std::size_t{1} << (k.grid_bits * dims);
    k.start.assign(cells, 0);
    for (std::size_t c = 0; c < cells; ++c) {
        double lo[8], hi[8];  // the cell's closed box [lo, hi] in t
        for (std::size_t a = 0; a < dims; ++a) {
            const std::size_t i = (c >> (k.grid_bits * (dims - 1 - a))) & (per - 1);
            lo[a] = double(i) / double(per);
            hi[a] = double(i + 1) / double(per);
        }
        std::uint32_t node = 0;
        while (L.split_axis[node] >= 0) {
            const std::size_t a = std::size_t(L.split_axis[node]);
            if (hi[a] < L.split_t[node])
                node = L.lower[node];
            else if (lo[a] >= L.split_t[node])
                node = L.upper[node];
            else
                break;  // the cut crosses the cell
        }
        k.start[c] = node;
    }
    return k;
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
    return lt.akernel_.value(*lt.adaptive_, lt.akernel_, lt.tree_.data(), fast, lt.dependency_.data(), x);
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
    akernel_ = choose_kernel(*adaptive_);
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
    akernel_ = lt.akernel_;
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
    (void)dims;
    return akernel_.value(*adaptive_, akernel_, adaptive_tree_.data(), adaptive_fast_.data(),
                          adaptive_dependency_.data(), c);
}

}  // namespace brdftab
