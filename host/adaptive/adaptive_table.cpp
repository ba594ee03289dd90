// adaptive_table.cpp — evaluation, refinement and continuity of adaptive
// tables (adaptive_table.h; the design in docs/adaptive.md).
#include "host/adaptive/adaptive_table.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>
#include <unordered_map>

#include "host/core/error.h"

namespace brdftab {

// ------------------------------------------------------------------ layout --

std::size_t AdaptiveLayout::nodes_per_leaf() const {
    std::size_t m = 1;
    for (std::size_t a = 0; a < dims; ++a) m *= patch_nodes;
    return m;
}

std::size_t AdaptiveLayout::leaf_of(const double* t) const {
    std::uint32_t k = 0;
    while (split_axis[k] >= 0) {
        const double x = std::clamp(t[split_axis[k]], 0.0, 1.0);
        k = x < split_t[k] ? lower[k] : upper[k];
    }
    return lower[k];
}

std::size_t adaptive_stencil(double u, std::size_t n, int order, double* w) {
    if (order == 2) {
        const std::size_t pairs = (n - 1) / 2;
        const std::size_t i = 2 * std::min(static_cast<std::size_t>(u / 2), pairs - 1);
        const double s = u - double(i);
        w[0] = 0.5 * (s - 1) * (s - 2);
        w[1] = s * (2 - s);
        w[2] = 0.5 * s * (s - 1);
        return i;
    }
    const std::size_t i = std::min(static_cast<std::size_t>(u), n - 2);
    w[1] = u - double(i);
    w[0] = 1 - w[1];
    return i;
}

namespace {

// Piecewise-quadratic interpolant of a leaf: per axis a stencil of 3 nodes,
// the tensor product of the axes' weights over the 3^d nodes.
double eval_leaf_quadratic(const AdaptiveLayout& L, std::size_t leaf, const double* t, const double* values) {
    const std::size_t n = L.patch_nodes, d = L.dims;
    const double* b = L.box.data() + leaf * d * 2;
    const std::uint32_t* nodes = L.leaf_nodes.data() + leaf * L.nodes_per_leaf();
    std::size_t base = 0, stride[8];
    double w[8][3];
    std::size_t s = 1;
    for (std::size_t a = d; a-- > 0;) {
        stride[a] = s;
        s *= n;
    }
    for (std::size_t a = 0; a < d; ++a) {
        const double lo = b[2 * a], hi = b[2 * a + 1];
        double u = (std::clamp(t[a], lo, hi) - lo) * (double(n - 1) / (hi - lo));
        u = std::clamp(u, 0.0, double(n - 1));
        base += adaptive_stencil(u, n, 2, w[a]) * stride[a];
    }
    std::size_t digit[8] = {0, 0, 0, 0, 0, 0, 0, 0};
    double sum = 0;
    for (;;) {
        double wt = 1;
        std::size_t idx = base;
        for (std::size_t a = 0; a < d; ++a) {
            wt *= w[a][digit[a]];
            idx += digit[a] * stride[a];
        }
        if (wt != 0) sum += wt * values[nodes[idx]];
        std::size_t a = 0;
        while (a < d && ++digit[a] == 3) digit[a++] = 0;
        if (a == d) break;
    }
    return sum;
}

}  // namespace

double AdaptiveLayout::eval_leaf(std::size_t leaf, const double* t, const double* values) const {
    if (patch_order == 2) return eval_leaf_quadratic(*this, leaf, t, values);
    const std::size_t n = patch_nodes;
    const double* b = box.data() + leaf * dims * 2;
    const std::uint32_t* nodes = leaf_nodes.data() + leaf * nodes_per_leaf();
    // Per axis the cell's first node and the weight of its second.
    std::size_t base = 0, stride[8];
    double frac[8];
    std::size_t s = 1;
    for (std::size_t a = dims; a-- > 0;) {
        stride[a] = s;
        s *= n;
    }
    for (std::size_t a = 0; a < dims; ++a) {
        const double lo = b[2 * a], hi = b[2 * a + 1];
        double u = (std::clamp(t[a], lo, hi) - lo) * (double(n - 1) / (hi - lo));
        u = std::clamp(u, 0.0, double(n - 1));
        std::size_t i = std::min(static_cast<std::size_t>(u), n - 2);
        frac[a] = u - double(i);
        base += i * stride[a];
    }
    double sum = 0;
    for (std::size_t corner = 0; corner < (std::size_t{1} << dims); ++corner) {
        double w = 1;
        std::size_t idx = base;
        for (std::size_t a = 0; a < dims; ++a) {
            if (corner >> a & 1) {
                w *= frac[a];
                idx += stride[a];
            } else {
                w *= 1 - frac[a];
            }
        }
        if (w != 0) sum += w * values[nodes[idx]];
    }
    return sum;
}

void AdaptiveLayout::check(std::size_t value_count, const std::string& where) const {
    auto fail = [&](const std::string& m) { throw InputError(where + m); };
    if (dims < 1 || dims > 8) fail("an adaptive table has 1 to 8 axes, not " + std::to_string(dims));
    if (patch_nodes != 2 && patch_nodes != 3 && patch_nodes != 5 && patch_nodes != 9)
        fail("patch_nodes is " + std::to_string(patch_nodes) + "; allowed: 2, 3, 5, 9");
    if (patch_order != 1 && patch_order != 2)
        fail("patch_order is " + std::to_string(patch_order) + "; allowed: 1, 2");
    if (patch_order == 2 && patch_nodes == 2) fail("patch_order 2 needs patch_nodes 3, 5 or 9, not 2");
    const std::size_t tn = split_axis.size();
    if (tn == 0 || split_t.size() != tn || lower.size() != tn || upper.size() != tn)
        fail("the tree datasets (tree_axis, tree_split, tree_child) differ in length or are empty");
    const std::size_t leaves = leaf_count();
    if (box.size() != leaves * dims * 2 || leaves == 0)
        fail("leaf_box does not hold 2 bounds per axis and leaf");
    if (leaf_nodes.size() != leaves * nodes_per_leaf())
        fail("leaf_nodes does not hold patch_nodes^axes entries per leaf");
    for (std::uint32_t v : leaf_nodes)
        if (v >= value_count) fail("leaf_nodes refers to value " + std::to_string(v) + " of " +
                                   std::to_string(value_count));
    for (std::size_t l = 0; l < leaves; ++l)
        for (std::size_t a = 0; a < dims; ++a) {
            const double lo = box[(l * dims + a) * 2], hi = box[(l * dims + a) * 2 + 1];
            if (!(lo >= 0 && hi <= 1 && lo < hi))
                fail("leaf " + std::to_string(l) + " has the box [" + std::to_string(lo) + ", " +
                     std::to_string(hi) + "] on axis " + std::to_string(a) + "; needs 0 <= lo < hi <= 1");
        }
    // Every tree node reached once from the root, every leaf once: a tree,
    // so the descent ends.
    std::vector<char> seen_node(tn, 0), seen_leaf(leaves, 0);
    std::vector<std::uint32_t> stack{0};
    while (!stack.empty()) {
        const std::uint32_t k = stack.back();
        stack.pop_back();
        if (k >= tn || seen_node[k]) fail("tree_child does not form a tree from node 0");
        seen_node[k] = 1;
        if (split_axis[k] < 0) {
            if (lower[k] >= leaves || seen_leaf[lower[k]]) fail("a tree leaf names a missing or repeated leaf");
            seen_leaf[lower[k]] = 1;
        } else {
            if (std::size_t(split_axis[k]) >= dims) fail("tree_axis names an axis beyond the table's");
            if (!(split_t[k] > 0 && split_t[k] < 1)) fail("tree_split outside (0, 1)");
            stack.push_back(lower[k]);
            stack.push_back(upper[k]);
        }
    }
    if (std::find(seen_leaf.begin(), seen_leaf.end(), 0) != seen_leaf.end())
        fail("a leaf is not reached by the tree");
    if (hanging_leaf.size() > value_count)
        fail("hanging_leaf has " + std::to_string(hanging_leaf.size()) + " entries for " +
             std::to_string(value_count) + " nodes");
    for (std::uint32_t c : hanging_leaf)
        if (c >= leaves) fail("hanging_leaf names leaf " + std::to_string(c) + " of " + std::to_string(leaves));
}

void AdaptiveLayout::resolve_hanging(double* values, std::size_t value_count, const std::string& where) const {
    const std::size_t h = hanging_leaf.size(), first = value_count - h, per = nodes_per_leaf(), n = patch_nodes;
    if (h == 0) return;
    auto fail = [&](std::size_t j, const std::string& m) {
        throw InputError(where + "hanging node " + std::to_string(first + j) + " (hanging_leaf[" +
                         std::to_string(j) + "]): " + m);
    };
    // Each hanging node's first entry in leaf_nodes: its position.
    constexpr std::size_t kNone = ~std::size_t{0};
    std::vector<std::size_t> entry(h, kNone);
    for (std::size_t e = 0; e < leaf_nodes.size(); ++e) {
        const std::uint32_t v = leaf_nodes[e];
        if (v >= first && v < value_count && entry[v - first] == kNone) entry[v - first] = e;
    }
    const double grid = 4294967296.0;  // 2^32
    std::size_t stride[8], base_digit[8];
    double w[8][3];
    for (std::size_t a = dims, s = 1; a-- > 0; s *= n) stride[a] = s;
    for (std::size_t j = 0; j < h; ++j) {
        if (entry[j] == kNone) fail(j, "no leaf lists it");
        const std::size_t l = entry[j] / per, c = hanging_leaf[j];
        const double* bl = box.data() + l * dims * 2;
        const double* bc = box.data() + c * dims * 2;
        std::size_t base = 0;
        for (std::size_t a = 0; a < dims; ++a) {
            const std::size_t i = entry[j] % per / stride[a] % n;
            const double t = bl[2 * a] + double(i) * ((bl[2 * a + 1] - bl[2 * a]) / double(n - 1));
            double u = (t - bc[2 * a]) * (double(n - 1) / (bc[2 * a + 1] - bc[2 * a]));
            if (!(u >= -1e-9 && u <= double(n - 1) + 1e-9)) fail(j, "it lies outside its leaf " + std::to_string(c));
            u = std::clamp(std::nearbyint(u * grid) / grid, 0.0, double(n - 1));
            base_digit[a] = adaptive_stencil(u, n, patch_order, w[a]);
            base += base_digit[a] * stride[a];
        }
        const std::uint32_t* nodes = leaf_nodes.data() + c * per;
        const std::size_t m = std::size_t(patch_order) + 1;
        std::size_t digit[8] = {0, 0, 0, 0, 0, 0, 0, 0};
        double sum = 0;
        for (;;) {
            double wt = 1;
            std::size_t idx = base;
            for (std::size_t a = 0; a < dims; ++a) {
                wt *= w[a][digit[a]];
                idx += digit[a] * stride[a];
            }
            if (wt != 0) {
                if (nodes[idx] >= first + j) fail(j, "its leaf's interpolant needs node " +
                                                         std::to_string(nodes[idx]) + ", not yet known");
                sum += wt * values[nodes[idx]];
            }
            std::size_t a = 0;
            while (a < dims && ++digit[a] == m) digit[a++] = 0;
            if (a == dims) break;
        }
        values[first + j] = sum;
    }
}

// ------------------------------------------------------------------ table --

void AdaptiveTable::to_t(const double* x, double* t) const {
    const auto& axes = data.axes;
    for (std::size_t a = 0; a < axes.size(); ++a) {
        const Axis& ax = axes[a];
        double dep = 0;
        if (ax.dependent())
            for (std::size_t b = 0; b < axes.size(); ++b)
                if (axes[b].name == ax.depends_on) dep = std::clamp(x[b], axes[b].min, axes[b].max);
        const double xc = std::clamp(x[a], ax.min, ax.max);
        t[a] = std::clamp(ax.dependent() ? ax.unwarp_at(xc, dep) : ax.unwarp(xc), 0.0, 1.0);
    }
}

void AdaptiveTable::to_x(const double* t, double* x) const {
    const auto& axes = data.axes;
    for (std::size_t a = 0; a < axes.size(); ++a)
        if (!axes[a].dependent()) x[a] = std::clamp(axes[a].warp(t[a]), axes[a].min, axes[a].max);
    for (std::size_t a = 0; a < axes.size(); ++a) {
        const Axis& ax = axes[a];
        if (!ax.dependent()) continue;
        double dep = 0;
        for (std::size_t b = 0; b < axes.size(); ++b)
            if (axes[b].name == ax.depends_on) dep = x[b];
        x[a] = std::clamp(ax.warp_at(t[a], dep), ax.min, ax.max);
    }
}

double AdaptiveTable::eval(const double* x) const {
    double t[8];
    to_t(x, t);
    return layout.eval(t, data.value.data());
}

// ------------------------------------------------------------- refinement --

namespace {

constexpr int kBits = 30;  // dyadic resolution of one breakpoint interval
constexpr std::uint64_t kSpan = std::uint64_t{1} << kBits;
constexpr std::size_t kMaxDims = 8;
using Key = std::array<std::uint64_t, kMaxDims>;

struct KeyHash {
    std::size_t operator()(const Key& k) const {
        std::uint64_t h = 0x9E3779B97F4A7C15ull;
        for (std::uint64_t v : k) {
            h ^= v + 0x9E3779B97F4A7C15ull + (h << 6) + (h >> 2);
            h *= 0xBF58476D1CE4E5B9ull;
        }
        return static_cast<std::size_t>(h ^ (h >> 31));
    }
};

// One axis' integer coordinate G: interval k covers [off[k], off[k] + kSpan];
// a continuous breakpoint shares its G with the next interval, a jump is one
// unit apart, so the two sides of a jump are different nodes.
struct AxisMap {
    std::vector<double> b;           // interval bounds in t: 0, breakpoints..., 1
    std::vector<std::uint64_t> off;  // first G of each interval
    std::vector<bool> jump;          // per inner breakpoint
    std::size_t interval(std::uint64_t g) const {
        std::size_t k = std::upper_bound(off.begin(), off.end(), g) - off.begin();
        return k == 0 ? 0 : k - 1;
    }
    double t(std::uint64_t g) const {
        const std::size_t k = interval(g);
        const std::uint64_t q = g - off[k];
        if (q == 0) return b[k];
        if (q >= kSpan) return b[k + 1];
        return b[k] + (b[k + 1] - b[k]) * (double(q) / double(kSpan));
    }
    // Where the function is evaluated for node g: the lower side of a jump
    // is moved inside its interval.
    double eval_t(std::uint64_t g) const {
        const std::size_t k = interval(g);
        const std::uint64_t q = g - off[k];
        if (q >= kSpan && k < jump.size() && jump[k])
            return b[k + 1] - 1e-9 * (b[k + 1] - b[k]);
        return t(g);
    }
    std::uint64_t end() const { return off.back() + kSpan; }
};

struct BuildNode {
    int axis = -1;
    std::uint64_t lower_hi = 0, upper_lo = 0;  // G bounds of the children on `axis`
    double split_t = 0;
    std::uint32_t lower = 0, upper = 0;  // tree nodes; leaf: lower = leaf index
};

struct BuildLeaf {
    std::array<std::uint64_t, kMaxDims> lo{}, hi{};
    std::array<int, kMaxDims> level{};
    std::uint32_t tree = 0;
    bool checked = false;
    double err = 0;
    std::array<double, kMaxDims> axis_err{};
};

struct Known {
    double value = 0, stderr_ = 0;
};

class Builder {
public:
    Builder(std::size_t dims, const AdaptiveBuildOptions& o) : d_(dims), o_(o), n_(o.patch_nodes) {
        maps_.resize(d_);
        for (std::size_t a = 0; a < d_; ++a) {
            AxisMap& m = maps_[a];
            m.b = {0.0};
            const auto* bp = a < o.breakpoints.size() ? &o.breakpoints[a] : nullptr;
            if (bp)
                for (const AdaptiveBreakpoint& p : *bp) {
                    m.b.push_back(p.t);
                    m.jump.push_back(p.jump);
                }
            m.b.push_back(1.0);
            m.off = {0};
            for (std::size_t k = 0; k + 2 < m.b.size(); ++k)
                m.off.push_back(m.off.back() + kSpan + (m.jump[k] ? 1 : 0));
        }
        max_level_ = std::min(o.max_level, kBits - 1 - int(std::log2(double(n_ - 1)) + 0.5));
    }

    void initial_tree() {
        BuildLeaf root;
        for (std::size_t a = 0; a < d_; ++a) {
            root.lo[a] = 0;
            root.hi[a] = maps_[a].end();
        }
        nodes_.push_back(BuildNode{});
        root.tree = 0;
        // Pre-split at the breakpoints, axis by axis, a balanced cascade.
        std::vector<BuildLeaf> boxes{root};
        for (std::size_t a = 0; a < d_; ++a) {
            std::vector<BuildLeaf> next;
            for (const BuildLeaf& box : boxes) cascade(box, a, 0, maps_[a].off.size(), next);
            boxes = std::move(next);
        }
        for (BuildLeaf& l : boxes) {
            nodes_[l.tree].lower = std::uint32_t(leaves_.size());
            leaves_.push_back(l);
        }
        for (std::size_t a = 0; a < d_; ++a) {
            const int lv = a < o_.initial_level.size() ? o_.initial_level[a] : 0;
            for (int r = 0; r < std::min(lv, max_level_); ++r)
                for (std::size_t l = 0, e = leaves_.size(); l < e; ++l) split(l, a);
        }
        for (std::size_t l = 0; l < leaves_.size(); ++l) add_leaf_nodes(l);
        if (o_.continuity) {
            std::vector<std::size_t> all(leaves_.size());
            std::iota(all.begin(), all.end(), std::size_t{0});
            initial_balance_splits_ = balance(std::move(all));
        }
    }

    AdaptiveBuildReport run(const AdaptiveBatchFn& batch, bool with_stderr, const AdaptiveRoundFn& round) {
        AdaptiveBuildReport rep;
        rep.balance_splits = initial_balance_splits_;
        for (;;) {
            ++rep.rounds;
            evaluate_round(batch, with_stderr, rep);
            for (std::size_t l = 0; l < leaves_.size(); ++l)
                if (!leaves_[l].checked) estimate(l);
            // Split the failing leaves, worst first, within the budget.  Only
            // those within one split's gain of the worst splittable one (a
            // split divides a smooth leaf's error by 2^(order + 1)) are split
            // this round, the others in later rounds.  When the budget ends
            // the refinement, it has then gone to the worst leaves rather
            // than to every leaf above the target, so the largest error left
            // is smaller.  Without a budget the same leaves are split (each
            // leaf's decision depends on its own probes only), in more rounds.
            std::vector<std::size_t> fail;
            rep.estimated_max = 0;
            rep.leaves_over_target = 0;
            for (std::size_t l = 0; l < leaves_.size(); ++l) {
                rep.estimated_max = std::max(rep.estimated_max, leaves_[l].err);
                if (leaves_[l].err > o_.target) ++rep.leaves_over_target;
            }
            const double gain = o_.patch_order == 2 ? 8.0 : 4.0;
            double worst = 0;  // of the leaves that fail and can be split
            for (std::size_t l = 0; l < leaves_.size(); ++l)
                if (leaves_[l].err > o_.safety * o_.target && split_axis(l) >= 0)
                    worst = std::max(worst, leaves_[l].err);
            const double threshold = std::max(o_.safety * o_.target, worst / gain);
            for (std::size_t l = 0; l < leaves_.size(); ++l)
                if (leaves_[l].err > o_.safety * o_.target && leaves_[l].err >= threshold && split_axis(l) >= 0)
                    fail.push_back(l);
            rep.leaves = leaves_.size();
            rep.values = node_order_.size();
            if (round) round(rep);
            if (fail.empty()) break;
            std::stable_sort(fail.begin(), fail.end(),
                             [&](std::size_t x, std::size_t y) { return leaves_[x].err > leaves_[y].err; });
            std::size_t done = 0;
            for (std::size_t l : fail) {
                if (!leaves_[l].checked) continue;  // already halved by the balance
                const int a = split_axis(l);
                if (node_order_.size() + new_nodes_of_split(l, std::size_t(a)) > o_.max_values) {
                    rep.budget_hit = true;
                    break;
                }
                // The split and the halvings the balance rule needs after it,
                // undone together when they pass the budget.
                begin_journal();
                const std::size_t upper = split(l, std::size_t(a));
                add_leaf_nodes(l);
                add_leaf_nodes(upper);
                const std::size_t extra = o_.continuity ? balance({l, upper}) : 0;
                if (node_order_.size() > o_.max_values) {
                    roll_back();
                    rep.budget_hit = true;
                    break;
                }
                journal_.on = false;
                rep.balance_splits += extra;
                ++done;
            }
            if (done == 0) break;
        }
        rep.leaves = leaves_.size();
        rep.values = node_order_.size();
        return rep;
    }

    bool is_node_of(const BuildLeaf& l, const Key& k) const {
        for (std::size_t a = 0; a < d_; ++a)
            if ((k[a] - l.lo[a]) % spacing(l, a) != 0) return false;
        return true;
    }

    void finish(bool with_stderr, AdaptiveLayout& layout, std::vector<double>& values,
                std::vector<double>& stderr_, AdaptiveBuildReport& rep) {
        layout = AdaptiveLayout{};
        layout.dims = d_;
        layout.patch_nodes = n_;
        layout.patch_order = o_.patch_order;
        for (const BuildNode& b : nodes_) {
            layout.split_axis.push_back(b.axis);
            layout.split_t.push_back(b.axis >= 0 ? b.split_t : 0.0);
            layout.lower.push_back(b.lower);
            layout.upper.push_back(b.axis >= 0 ? b.upper : b.lower);
        }
        for (const BuildLeaf& l : leaves_)
            for (std::size_t a = 0; a < d_; ++a) {
                layout.box.push_back(maps_[a].t(l.lo[a]));
                layout.box.push_back(maps_[a].t(l.hi[a]));
            }
        // The hanging nodes (with continuity) and their constraining leaves:
        // the largest leaf that holds the node without having it as a node
        // (any of them gives the same value in a balanced tree).  Stored
        // nodes first in the order of creation, then the hanging ones,
        // coarsest position first: every value a constraint needs comes
        // before it (its stencil nodes are coarser along the axes where they
        // differ from it, and equal along the others).
        const std::size_t total = node_order_.size();
        std::vector<std::uint32_t> constraint(total, kFree);
        std::vector<std::uint32_t> hold;
        if (o_.continuity)
            for (std::uint32_t i = 0; i < total; ++i) {
                hold.clear();
                containing(node_order_[i], 0, hold);
                for (std::uint32_t m : hold)
                    if (!is_node_of(leaves_[m], node_order_[i]) &&
                        (constraint[i] == kFree || level_sum(m) < level_sum(constraint[i])))
                        constraint[i] = m;
            }
        std::vector<std::uint32_t> order;  // new position -> creation index
        std::vector<std::uint32_t> hanging;
        for (std::uint32_t i = 0; i < total; ++i) (constraint[i] == kFree ? order : hanging).push_back(i);
        std::stable_sort(hanging.begin(), hanging.end(), [&](std::uint32_t x, std::uint32_t y) {
            return coarseness(node_order_[x]) > coarseness(node_order_[y]);
        });
        order.insert(order.end(), hanging.begin(), hanging.end());
        std::vector<std::uint32_t> position(total);
        for (std::uint32_t p = 0; p < total; ++p) position[order[p]] = p;
        for (std::uint32_t i : hanging) layout.hanging_leaf.push_back(constraint[i]);
        const std::size_t per = layout.nodes_per_leaf();
        layout.leaf_nodes.reserve(leaves_.size() * per);
        for (const BuildLeaf& l : leaves_)
            for_each_node(l, [&](const Key& k) { layout.leaf_nodes.push_back(position[node_index_.at(k)]); });
        values.assign(total, std::numeric_limits<double>::quiet_NaN());
        if (with_stderr) stderr_.assign(total, std::numeric_limits<double>::quiet_NaN());
        const std::size_t stored = total - hanging.size();
        for (std::size_t p = 0; p < stored; ++p) {
            const Known& k = known_.at(node_order_[order[p]]);
            values[p] = k.value;
            if (with_stderr) stderr_[p] = k.stderr_;
        }
        layout.resolve_hanging(values.data(), total, "adaptive refinement: ");
        if (with_stderr) layout.resolve_hanging(stderr_.data(), total, "adaptive refinement: ");
        // Every leaf that holds a hanging node agrees with its value.
        rep.hanging_nodes = hanging.size();
        rep.continuity_residual = 0;
        std::array<double, kMaxDims> t{};
        for (std::uint32_t i : hanging) {
            const Key& k = node_order_[i];
            for (std::size_t a = 0; a < d_; ++a) t[a] = maps_[a].t(k[a]);
            hold.clear();
            containing(k, 0, hold);
            for (std::uint32_t m : hold)
                if (!is_node_of(leaves_[m], k)) {
                    const double e = std::fabs(layout.eval_leaf(m, t.data(), values.data()) - values[position[i]]);
                    rep.continuity_residual = std::max(rep.continuity_residual, std::isnan(e) ? HUGE_VAL : e);
                }
        }
        rep.leaves = leaves_.size();
        rep.values = total;
    }

private:
    std::uint64_t spacing(const BuildLeaf& l, std::size_t a) const { return (l.hi[a] - l.lo[a]) / (n_ - 1); }

    // Splits leaf-box `box` at the middle breakpoint of intervals [k0, k1) of axis a.
    void cascade(BuildLeaf box, std::size_t a, std::size_t k0, std::size_t k1, std::vector<BuildLeaf>& out) {
        if (k1 - k0 <= 1) {
            out.push_back(box);
            return;
        }
        const AxisMap& m = maps_[a];
        const std::size_t km = (k0 + k1) / 2;
        BuildLeaf lo = box, hi = box;
        lo.hi[a] = m.off[km - 1] + kSpan;
        hi.lo[a] = m.off[km];
        BuildNode& node = nodes_[box.tree];
        node.axis = int(a);
        node.lower_hi = lo.hi[a];
        node.upper_lo = hi.lo[a];
        node.split_t = m.b[km];
        lo.tree = std::uint32_t(nodes_.size());
        hi.tree = lo.tree + 1;
        nodes_[box.tree].lower = lo.tree;
        nodes_[box.tree].upper = hi.tree;
        nodes_.push_back(BuildNode{});
        nodes_.push_back(BuildNode{});
        cascade(lo, a, k0, km, out);
        cascade(hi, a, km, k1, out);
    }

    // Halves leaf l along axis a: l becomes the lower half; returns the upper's index.
    std::size_t split(std::size_t l, std::size_t a) {
        BuildLeaf up = leaves_[l];
        const std::uint64_t mid = leaves_[l].lo[a] + (leaves_[l].hi[a] - leaves_[l].lo[a]) / 2;
        const std::uint32_t t = leaves_[l].tree;
        if (journal_.on) {
            journal_.leaves.emplace_back(l, leaves_[l]);
            journal_.nodes.emplace_back(t, nodes_[t]);
        }
        BuildLeaf& low = leaves_[l];
        low.hi[a] = mid;
        up.lo[a] = mid;
        ++low.level[a];
        ++up.level[a];
        low.checked = up.checked = false;
        BuildNode inner;
        inner.axis = int(a);
        inner.lower_hi = inner.upper_lo = mid;
        inner.split_t = maps_[a].t(mid);
        inner.lower = std::uint32_t(nodes_.size());
        inner.upper = inner.lower + 1;
        BuildNode lo_node, hi_node;
        lo_node.lower = std::uint32_t(l);
        hi_node.lower = std::uint32_t(leaves_.size());
        low.tree = inner.lower;
        up.tree = inner.upper;
        nodes_[t] = inner;
        nodes_.push_back(lo_node);
        nodes_.push_back(hi_node);
        leaves_.push_back(up);
        return leaves_.size() - 1;
    }

    // The axis leaf l would be split along (its worst whose level allows), or -1.
    int split_axis(std::size_t l) const {
        const BuildLeaf& lf = leaves_[l];
        int best = -1;
        for (std::size_t a = 0; a < d_; ++a) {
            if (lf.level[a] >= max_level_) continue;
            if (best < 0 || lf.axis_err[a] > lf.axis_err[std::size_t(best)]) best = int(a);
        }
        return best;
    }

    template <class F>
    void for_each_node(const BuildLeaf& l, F&& f) const {
        Key k{};
        std::array<std::size_t, kMaxDims> i{};
        const std::size_t total = [&] {
            std::size_t m = 1;
            for (std::size_t a = 0; a < d_; ++a) m *= n_;
            return m;
        }();
        for (std::size_t c = 0; c < total; ++c) {
            std::size_t r = c;
            for (std::size_t a = d_; a-- > 0;) {
                i[a] = r % n_;
                r /= n_;
            }
            for (std::size_t a = 0; a < d_; ++a) k[a] = l.lo[a] + i[a] * spacing(l, a);
            f(k);
        }
    }

    std::size_t new_nodes_of_split(std::size_t l, std::size_t a) const {
        BuildLeaf lo = leaves_[l], hi = leaves_[l];
        const std::uint64_t mid = lo.lo[a] + (lo.hi[a] - lo.lo[a]) / 2;
        lo.hi[a] = mid;
        hi.lo[a] = mid;
        std::size_t added = 0;
        std::unordered_map<Key, char, KeyHash> fresh;
        for (const BuildLeaf* c : {&lo, &hi})
            for_each_node(*c, [&](const Key& k) {
                if (!node_index_.count(k) && fresh.emplace(k, 1).second) ++added;
            });
        return added;
    }

    void add_leaf_nodes(std::size_t l) {
        for_each_node(leaves_[l], [&](const Key& k) {
            if (node_index_.emplace(k, std::uint32_t(node_order_.size())).second) node_order_.push_back(k);
        });
    }

    void want(const Key& k) {
        if (!known_.count(k) && pending_set_.emplace(k, 1).second) pending_.push_back(k);
    }

    // The probes of leaf l: along each axis a, the midpoints of its cells with
    // the other coordinates at nodes (a split along a makes them nodes), and
    // the cell centres (cross terms, a feature inside a cell).  f(k, axis,
    // odd_mask): axis >= 0 for a probe odd along that axis only, else -1;
    // odd_mask has bit a set where coordinate a is at a cell midpoint.
    template <class F>
    void for_each_probe(const BuildLeaf& l, F&& f) const {
        const std::size_t total = std::size_t(std::pow(double(2 * n_ - 1), double(d_)) + 0.5);
        std::array<std::size_t, kMaxDims> i{};
        Key k{};
        for (std::size_t c = 0; c < total; ++c) {
            std::size_t r = c, odd = 0;
            unsigned mask = 0;
            int odd_axis = -1;
            for (std::size_t a = d_; a-- > 0;) {
                i[a] = r % (2 * n_ - 1);
                r /= 2 * n_ - 1;
                if (i[a] & 1) {
                    ++odd;
                    odd_axis = int(a);
                    mask |= 1u << a;
                }
            }
            if (odd != 1 && odd != d_) continue;  // nodes, and mixed points, are not probes
            for (std::size_t a = 0; a < d_; ++a) k[a] = l.lo[a] + i[a] * (spacing(l, a) / 2);
            f(k, odd == 1 ? odd_axis : -1, mask);
        }
    }

    void evaluate_round(const AdaptiveBatchFn& batch, bool with_stderr, AdaptiveBuildReport& rep) {
        pending_.clear();
        pending_set_.clear();
        for (const Key& k : node_order_) want(k);
        for (const BuildLeaf& l : leaves_)
            if (!l.checked) for_each_probe(l, [&](const Key& k, int, unsigned) { want(k); });
        if (pending_.empty()) return;
        std::vector<double> t(pending_.size() * d_), v(pending_.size()), s(with_stderr ? pending_.size() : 0);
        for (std::size_t p = 0; p < pending_.size(); ++p)
            for (std::size_t a = 0; a < d_; ++a) t[p * d_ + a] = maps_[a].eval_t(pending_[p][a]);
        batch(pending_.size(), t.data(), v.data(), with_stderr ? s.data() : nullptr);
        for (std::size_t p = 0; p < pending_.size(); ++p) {
            known_[pending_[p]] = Known{v[p], with_stderr ? s[p] : 0.0};
            if (std::isfinite(v[p])) max_abs_ = std::max(max_abs_, std::fabs(v[p]));
        }
        rep.evaluations += pending_.size();
    }

    // Calls f(q, w) for each node q of leaf l's interpolation stencil at
    // integer point k and its weight w != 0 (adaptive_stencil's, with the
    // fractions exact in integers).
    template <class F>
    void for_each_weight(const BuildLeaf& l, const Key& k, F&& f) const {
        const std::size_t m = std::size_t(o_.patch_order) + 1;
        std::array<std::uint64_t, kMaxDims> c0{};
        std::array<std::array<double, 3>, kMaxDims> w{};
        for (std::size_t a = 0; a < d_; ++a) {
            const std::uint64_t sp = spacing(l, a);
            if (o_.patch_order == 2) {
                std::uint64_t j = (k[a] - l.lo[a]) / (2 * sp);
                if (j >= (n_ - 1) / 2) j = (n_ - 1) / 2 - 1;
                c0[a] = l.lo[a] + 2 * j * sp;
                const double u = double(k[a] - c0[a]) / double(sp);
                w[a] = {0.5 * (u - 1) * (u - 2), u * (2 - u), 0.5 * u * (u - 1)};
            } else {
                std::uint64_t i = (k[a] - l.lo[a]) / sp;
                if (i >= n_ - 1) i = n_ - 2;
                c0[a] = l.lo[a] + i * sp;
                const double u = double(k[a] - c0[a]) / double(sp);
                w[a] = {1 - u, u, 0.0};
            }
        }
        std::array<std::size_t, kMaxDims> digit{};
        for (;;) {
            double wt = 1;
            Key q{};
            for (std::size_t a = 0; a < d_; ++a) {
                wt *= w[a][digit[a]];
                q[a] = c0[a] + digit[a] * spacing(l, a);
            }
            if (wt != 0) f(q, wt);
            std::size_t a = 0;
            while (a < d_ && ++digit[a] == m) digit[a++] = 0;
            if (a == d_) break;
        }
    }

    // Leaf l's interpolant of its raw node values at integer point k.
    double interp_raw(const BuildLeaf& l, const Key& k) const {
        double sum = 0;
        for_each_weight(l, k, [&](const Key& q, double w) { sum += w * known_.at(q).value; });
        return sum;
    }

    double measure(double approx, double exact) const {
        double e = std::fabs(approx - exact);
        if (!o_.absolute) {
            const double floor = o_.floor > 0 ? o_.floor : std::max(o_.rel_floor_factor * max_abs_, 1e-300);
            e /= std::max(std::fabs(exact), floor);
        }
        return std::isfinite(e) ? e : std::numeric_limits<double>::infinity();
    }

    void estimate(std::size_t l) {
        BuildLeaf& lf = leaves_[l];
        lf.axis_err.fill(0);
        double centre = 0;  // the largest error of a probe odd along several axes
        unsigned centre_mask = 0;
        for_each_probe(lf, [&](const Key& k, int axis, unsigned mask) {
            const double e = measure(interp_raw(lf, k), known_.at(k).value);
            if (axis >= 0) {
                lf.axis_err[std::size_t(axis)] = std::max(lf.axis_err[std::size_t(axis)], e);
            } else if (e > centre) {
                centre = e;
                centre_mask = mask;
            }
        });
        lf.err = centre;
        for (std::size_t a = 0; a < d_; ++a) lf.err = std::max(lf.err, lf.axis_err[a]);
        // An error no single axis shows: split the axis, among those the worst
        // such probe lies at midpoints of, whose own error is largest (the
        // coarsest when none has any).
        if (centre > o_.safety * o_.target) {
            double worst = 0;
            for (std::size_t a = 0; a < d_; ++a) worst = std::max(worst, lf.axis_err[a]);
            if (worst <= o_.safety * o_.target) {
                int pick = -1;
                for (std::size_t a = 0; a < d_; ++a) {
                    if (!(centre_mask >> a & 1)) continue;
                    if (pick < 0 || lf.axis_err[a] > lf.axis_err[std::size_t(pick)] ||
                        (lf.axis_err[a] == lf.axis_err[std::size_t(pick)] && lf.level[a] < lf.level[std::size_t(pick)]))
                        pick = int(a);
                }
                lf.axis_err[std::size_t(pick)] = centre;
            }
        }
        lf.checked = true;
    }

    // The leaves whose closed boxes hold k (a continuous face: both sides).
    void containing(const Key& k, std::uint32_t node, std::vector<std::uint32_t>& out) const {
        const BuildNode& b = nodes_[node];
        if (b.axis < 0) {
            out.push_back(b.lower);
            return;
        }
        const std::uint64_t x = k[std::size_t(b.axis)];
        if (x <= b.lower_hi) containing(k, b.lower, out);
        if (x >= b.upper_lo) containing(k, b.upper, out);
    }

    static constexpr std::uint32_t kFree = ~std::uint32_t{0};

    int level_sum(std::size_t l) const {
        int s = 0;
        for (std::size_t a = 0; a < d_; ++a) s += leaves_[l].level[a];
        return s;
    }

    // How coarse a node's position is: the sum over axes of the trailing
    // zero bits of its offset in its breakpoint interval (64 at the
    // interval's start).  A leaf's nodes sit on multiples of its spacing, so
    // the stencil nodes of a hanging node have more trailing zeros along the
    // axes where it is not on the leaf's grid, and the same along the others.
    int coarseness(const Key& k) const {
        int s = 0;
        for (std::size_t a = 0; a < d_; ++a) {
            const std::uint64_t q = k[a] - maps_[a].off[maps_[a].interval(k[a])];
            s += q == 0 ? 64 : __builtin_ctzll(q);
        }
        return s;
    }

    // The leaves whose closed boxes meet leaf box `box`.
    void touching(const BuildLeaf& box, std::uint32_t node, std::vector<std::uint32_t>& out) const {
        const BuildNode& b = nodes_[node];
        if (b.axis < 0) {
            out.push_back(b.lower);
            return;
        }
        const std::size_t a = std::size_t(b.axis);
        if (box.lo[a] <= b.lower_hi) touching(box, b.lower, out);
        if (box.hi[a] >= b.upper_lo) touching(box, b.upper, out);
    }

    // The balance rule: leaves x and y whose closed boxes meet in a set of
    // two or more dimensions are nested there, one at least as fine as the
    // other along every axis of the set.  When they are not, returns the
    // halving that mends it in `leaf`, `axis`: of the two, the leaf that
    // needs fewer halvings (a tie: the coarser in all), along its axis that
    // is coarsest against the other.
    bool unbalanced(std::size_t x, std::size_t y, std::size_t& leaf, std::size_t& axis) const {
        const BuildLeaf &X = leaves_[x], &Y = leaves_[y];
        int shared = 0, cost_x = 0, cost_y = 0, gap_x = 0, gap_y = 0;
        std::size_t axis_x = 0, axis_y = 0;
        for (std::size_t a = 0; a < d_; ++a) {
            const std::uint64_t lo = std::max(X.lo[a], Y.lo[a]), hi = std::min(X.hi[a], Y.hi[a]);
            if (lo >= hi) continue;  // they only touch along a
            ++shared;
            const int g = X.level[a] - Y.level[a];  // > 0: x finer along a
            if (g < 0 && -g > gap_x) gap_x = -g, axis_x = a;
            if (g > 0 && g > gap_y) gap_y = g, axis_y = a;
            (g < 0 ? cost_x : cost_y) += std::abs(g);
        }
        if (shared < 2 || gap_x == 0 || gap_y == 0) return false;
        const bool pick_x = cost_x != cost_y ? cost_x < cost_y : level_sum(x) <= level_sum(y);
        leaf = pick_x ? x : y;
        axis = pick_x ? axis_x : axis_y;
        return true;
    }

    // Halves leaves until the balance rule holds between `work` and every
    // leaf they meet (and between the new halves and theirs); returns the
    // halvings.  Ends: each halving refines, and a leaf coarser than another
    // along an axis can always be halved along it.
    std::size_t balance(std::vector<std::size_t> work) {
        std::size_t splits = 0;
        std::vector<std::uint32_t> near;
        while (!work.empty()) {
            const std::size_t l = work.back();
            work.pop_back();
            near.clear();
            touching(leaves_[l], 0, near);
            for (std::uint32_t m : near) {
                std::size_t leaf = 0, axis = 0;
                if (m == l || !unbalanced(l, m, leaf, axis)) continue;
                const std::size_t upper = split(leaf, axis);
                add_leaf_nodes(leaf);
                add_leaf_nodes(upper);
                ++splits;
                work.push_back(upper);
                work.push_back(leaf);
                if (leaf != l) work.push_back(l);
                break;
            }
        }
        return splits;
    }

    // Undo of a split with its balance halvings.
    struct JournalLog {
        bool on = false;
        std::size_t leaf_count = 0, node_count = 0, order_count = 0;
        std::vector<std::pair<std::size_t, BuildLeaf>> leaves;
        std::vector<std::pair<std::size_t, BuildNode>> nodes;
    };
    void begin_journal() {
        journal_.on = true;
        journal_.leaf_count = leaves_.size();
        journal_.node_count = nodes_.size();
        journal_.order_count = node_order_.size();
        journal_.leaves.clear();
        journal_.nodes.clear();
    }
    void roll_back() {
        for (std::size_t k = journal_.leaves.size(); k-- > 0;) leaves_[journal_.leaves[k].first] = journal_.leaves[k].second;
        for (std::size_t k = journal_.nodes.size(); k-- > 0;) nodes_[journal_.nodes[k].first] = journal_.nodes[k].second;
        leaves_.resize(journal_.leaf_count);
        nodes_.resize(journal_.node_count);
        for (std::size_t i = journal_.order_count; i < node_order_.size(); ++i) node_index_.erase(node_order_[i]);
        node_order_.resize(journal_.order_count);
        journal_.on = false;
    }

    std::size_t d_;
    AdaptiveBuildOptions o_;
    std::size_t n_;
    int max_level_ = 0;
    std::vector<AxisMap> maps_;
    std::vector<BuildNode> nodes_;
    std::vector<BuildLeaf> leaves_;
    std::unordered_map<Key, std::uint32_t, KeyHash> node_index_;  // stored nodes
    std::vector<Key> node_order_;                                 // in order of creation
    std::unordered_map<Key, Known, KeyHash> known_;               // every evaluated point
    std::vector<Key> pending_;
    std::unordered_map<Key, char, KeyHash> pending_set_;
    double max_abs_ = 0;
    JournalLog journal_;
    std::size_t initial_balance_splits_ = 0;
};

void check_build_options(std::size_t dims, const AdaptiveBuildOptions& o) {
    if (dims < 1 || dims > kMaxDims)
        throw InputError("an adaptive table has 1 to " + std::to_string(kMaxDims) + " axes, not " +
                         std::to_string(dims));
    if (o.patch_nodes != 3 && o.patch_nodes != 5 && o.patch_nodes != 9)
        throw InputError("adaptive patch_nodes " + std::to_string(o.patch_nodes) + "; allowed: 3, 5, 9");
    if (o.patch_order != 1 && o.patch_order != 2)
        throw InputError("adaptive patch_order " + std::to_string(o.patch_order) + "; allowed: 1, 2");
    if (!(o.target > 0) || !std::isfinite(o.target))
        throw InputError("adaptive target must be a positive number");
    if (!(o.safety > 0 && o.safety <= 1)) throw InputError("adaptive safety must lie in (0, 1]");
    if (o.max_values < 2) throw InputError("adaptive max_values must be at least 2");
    if (o.breakpoints.size() > dims) throw InputError("adaptive breakpoints for more axes than the table has");
    for (const auto& list : o.breakpoints)
        for (std::size_t k = 0; k < list.size(); ++k)
            if (!(list[k].t > 0 && list[k].t < 1) || (k > 0 && !(list[k].t > list[k - 1].t)))
                throw InputError("adaptive breakpoints must increase strictly within the axis' open range");
}

}  // namespace

AdaptiveBuildReport build_adaptive(std::size_t dims, const AdaptiveBuildOptions& options,
                                   const AdaptiveBatchFn& batch, bool with_stderr,
                                   AdaptiveLayout& layout, std::vector<double>& values,
                                   std::vector<double>& stderr_, const AdaptiveRoundFn& round) {
    check_build_options(dims, options);
    Builder b(dims, options);
    b.initial_tree();
    AdaptiveBuildReport rep = b.run(batch, with_stderr, round);
    b.finish(with_stderr, layout, values, stderr_, rep);
    return rep;
}

}  // namespace brdftab
