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

// AdaptiveLayout::eval_leaf unrolled for D axes and patch order `Order`, on
// the leaf's packed block: in its order of operations (the same bits).
// Order 1: per axis the cell in the leaf's box and the weight of its second
// node, then the 2^D corners; order 2: per axis the node triple and its
// three Lagrange weights, then the 3^D terms (first axis fastest).  Zero
// weights are skipped, as there.
template <int D, int Order>
BT_LOOKUP_INLINE double leaf_packed(const AdaptiveKernel& k, std::size_t leaf, const double* t) {
    const double* p = k.leaves + leaf * k.leaf_stride;
    const double* v = p + 3 * D;
    const std::size_t n = k.patch_nodes;
    std::size_t base = 0;
    if constexpr (Order == 1) {
        double frac[D];
#pragma GCC unroll 8
        for (int a = 0; a < D; ++a) {
            const double lo = p[3 * a], hi = p[3 * a + 1];
            double u = (std::clamp(t[a], lo, hi) - lo) * p[3 * a + 2];
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
            if (w != 0) sum += w * v[idx];
        }
        return sum;
    } else {
        double w[D][3];
        const std::size_t pairs = (n - 1) / 2;
#pragma GCC unroll 8
        for (int a = 0; a < D; ++a) {
            const double lo = p[3 * a], hi = p[3 * a + 1];
            double u = (std::clamp(t[a], lo, hi) - lo) * p[3 * a + 2];
            u = std::clamp(u, 0.0, double(n - 1));
            const std::size_t i = 2 * std::min(static_cast<std::size_t>(u / 2), pairs - 1);
            const double s = u - double(i);
            w[a][0] = 0.5 * (s - 1) * (s - 2);
            w[a][1] = s * (2 - s);
            w[a][2] = 0.5 * s * (s - 1);
            base += i * k.stride[a];
        }
        constexpr std::size_t terms = [] {
            std::size_t m = 1;
            for (int a = 0; a < D; ++a) m *= 3;
            return m;
        }();
        double sum = 0;
#pragma GCC unroll 81
        for (std::size_t c = 0; c < terms; ++c) {
            double wt = 1;
            std::size_t idx = base, r = c;
#pragma GCC unroll 8
            for (int a = 0; a < D; ++a) {
                const std::size_t j = r % 3;
                r /= 3;
                wt *= w[a][j];
                idx += j * k.stride[a];
            }
            if (wt != 0) sum += wt * v[idx];
        }
        return sum;
    }
}

// The kernels: Order 1 or 2: leaf_packed; 0: the layout's own eval_leaf.
template <int D, int Order>
double adaptive_value(const AdaptiveTable& at, const AdaptiveKernel& k, const TreeNode* tree,
                      const FastAxis* fast, const int* dependency, const double* x) {
    double t[D];
    t_of<D>(at, fast, dependency, x, t);
    // The grid cell of t: floor(t 2^bits) is exact (a power of two).
    std::size_t cell = 0;
#pragma GCC unroll 8
    for (int d = 0; d < D; ++d) {
        const std::size_t per = std::size_t{1} << k.grid_bits[d];
        cell = (cell << k.grid_bits[d]) | std::min(static_cast<std::size_t>(t[d] * double(per)), per - 1);
    }
    const std::uint32_t s = k.start[cell];
    const std::size_t leaf =
        s & AdaptiveKernel::kStartLeaf ? std::size_t(s & ~AdaptiveKernel::kStartLeaf) : leaf_at(tree, t, s);
    if constexpr (Order > 0)
        return leaf_packed<D, Order>(k, leaf, t);
    else
        return at.layout.eval_leaf(leaf, t, at.data.value.data());
}

template <int Order>
using KernelFn = double (*)(const AdaptiveTable&, const AdaptiveKernel&, const TreeNode*, const FastAxis*,
                            const int*, const double*);

template <int Order>
KernelFn<Order> kernel_for(std::size_t dims) {
    static const KernelFn<Order> fns[] = {&adaptive_value<1, Order>, &adaptive_value<2, Order>,
                                          &adaptive_value<3, Order>, &adaptive_value<4, Order>,
                                          &adaptive_value<5, Order>, &adaptive_value<6, Order>,
                                          &adaptive_value<7, Order>, &adaptive_value<8, Order>};
    return fns[dims - 1];
}

template <int Order>
double packed_leaf_value(const AdaptiveKernel& k, std::size_t dims, std::size_t leaf, const double* t) {
    using Fn = double (*)(const AdaptiveKernel&, std::size_t, const double*);
    static const Fn fns[] = {&leaf_packed<1, Order>, &leaf_packed<2, Order>, &leaf_packed<3, Order>,
                             &leaf_packed<4, Order>, &leaf_packed<5, Order>, &leaf_packed<6, Order>,
                             &leaf_packed<7, Order>, &leaf_packed<8, Order>};
    return fns[dims - 1](k, leaf, t);
}

// The kernel for the table's axis count and patch order, its leaves packed.
// The unrolled interpolant is taken only when it gives eval_leaf's bits at
// the centre and at two off-centre points of every leaf; otherwise the
// layout's own interpolation serves.
AdaptiveKernel choose_kernel(const AdaptiveTable& at) {
    const AdaptiveLayout& L = at.layout;
    const std::size_t dims = L.dims, leaves = L.leaf_count();
    AdaptiveKernel k;
    k.nodes_per_leaf = L.nodes_per_leaf();
    k.patch_nodes = L.patch_nodes;
    std::size_t s = 1;
    for (std::size_t a = dims; a-- > 0;) {
        k.stride[a] = s;
        s *= L.patch_nodes;
    }
    k.leaf_stride = 3 * dims + k.nodes_per_leaf;
    auto blocks = std::make_shared<std::vector<double>>(leaves * k.leaf_stride);
    const double* v = at.data.value.data();
    for (std::size_t l = 0; l < leaves; ++l) {
        double* p = blocks->data() + l * k.leaf_stride;
        const double* b = L.box.data() + l * dims * 2;
        for (std::size_t a = 0; a < dims; ++a) {
            p[3 * a] = b[2 * a];
            p[3 * a + 1] = b[2 * a + 1];
            p[3 * a + 2] = double(L.patch_nodes - 1) / (b[2 * a + 1] - b[2 * a]);  // as eval_leaf forms it
        }
        const std::uint32_t* nodes = L.leaf_nodes.data() + l * k.nodes_per_leaf;
        for (std::size_t i = 0; i < k.nodes_per_leaf; ++i) p[3 * dims + i] = v[nodes[i]];
    }
    k.leaf_blocks = blocks;
    k.leaves = blocks->data();
    const int order = L.patch_order;
    bool same = true;
    for (std::size_t l = 0; same && l < leaves; ++l) {
        const double* b = L.box.data() + l * dims * 2;
        for (double f : {0.5, 0.3, 0.8125}) {
            double t[8];
            for (std::size_t a = 0; a < dims; ++a)
                t[a] = b[2 * a] + (a % 2 ? 1 - f : f) * (b[2 * a + 1] - b[2 * a]);
            const double x = order == 2 ? packed_leaf_value<2>(k, dims, l, t) : packed_leaf_value<1>(k, dims, l, t);
            const double y = L.eval_leaf(l, t, v);
            same = same && (x == y || (std::isnan(x) && std::isnan(y)));
        }
    }
    k.value = !same ? kernel_for<0>(dims) : order == 2 ? kernel_for<2>(dims) : kernel_for<1>(dims);
    // The start grid: 2^16 cells (256 KiB; more cost more in cache misses
    // than they save in descent on bench/bench_lookup's table), the bits
    // shared out among the axes by the leaves' mean depth along each
    // (weighted by volume: where a uniform query lands), at most 10 per axis.
    std::vector<double> depth(dims, 0.0);
    for (std::size_t l = 0; l < leaves; ++l) {
        const double* b = L.box.data() + l * dims * 2;
        double vol = 1;
        for (std::size_t a = 0; a < dims; ++a) vol *= b[2 * a + 1] - b[2 * a];
        for (std::size_t a = 0; a < dims; ++a) depth[a] += vol * -std::log2(b[2 * a + 1] - b[2 * a]);
    }
    unsigned total = 0;
    for (std::size_t a = 0; a < dims; ++a) {
        k.grid_bits[a] = unsigned(std::clamp(std::ceil(depth[a]) + 1, 0.0, 10.0));
        total += k.grid_bits[a];
    }
    const unsigned budget = 16;
    while (total > budget) {
        std::size_t m = 0;
        for (std::size_t a = 1; a < dims; ++a)
            if (k.grid_bits[a] > k.grid_bits[m]) m = a;
        --k.grid_bits[m];
        --total;
    }
    // Bits left over go to the axes deepest against the bits they have.
    while (total < budget) {
        std::size_t m = dims;
        for (std::size_t a = 0; a < dims; ++a)
            if (k.grid_bits[a] < 10 && (m == dims || depth[a] - k.grid_bits[a] > depth[m] - k.grid_bits[m])) m = a;
        if (m == dims) break;
        ++k.grid_bits[m];
        ++total;
    }
    const std::size_t cells = std::size_t{1} << total;
    k.start.assign(cells, 0);
    for (std::size_t c = 0; c < cells; ++c) {
        double lo[8], hi[8];  // the cell's closed box [lo, hi] in t
        std::size_t r = c;
        for (std::size_t a = dims; a-- > 0;) {
            const std::size_t per = std::size_t{1} << k.grid_bits[a], i = r & (per - 1);
            r >>= k.grid_bits[a];
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
        k.start[c] = L.split_axis[node] < 0 && L.lower[node] < AdaptiveKernel::kStartLeaf
                         ? AdaptiveKernel::kStartLeaf | L.lower[node]
                         : node;
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
