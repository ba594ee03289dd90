// interpolate.cpp — values between the nodes of a table: range checks, the
// per-axis linear and Catmull-Rom weights in each axis' warped coordinate, and
// their tensor-product contraction (LookupTable::eval).  Direction-level
// evaluation builds on these in directions.cpp.
#include <algorithm>
#include <cmath>

#include "host/core/error.h"
#include "host/core/text.h"
#include "host/lookup/lookup.h"
#include "host/lookup/lookup_internal.h"

namespace brdftab {

namespace lookup_internal {

std::string fmt_num(double v) { return number_text(v, 10); }

std::string range_text(const Axis& a) {
    std::string r = "[" + fmt_num(a.min) + ", " + fmt_num(a.max) + "]";
    return r + unit_suffix(a.unit);
}

// Validate a coordinate against its axis and apply the out-of-range policy.
// A tolerance of 1e-9 of the span absorbs rounding (e.g. acos at 90 degrees).
double resolve(const Axis& a, double x, OutOfRange mode, const std::string& table) {
    if (std::isnan(x))
        throw InputError("table '" + table + "': axis '" + a.name + "' value is NaN");
    const double tol = 1e-9 * (a.max - a.min);
    x = fold_periodic(a, x);
    if (x < a.min || x > a.max) {
        if (mode == OutOfRange::Reject && (x < a.min - tol || x > a.max + tol))
            throw InputError("table '" + table + "': axis '" + a.name + "' value " +
                             fmt_num(x) + " is outside " + range_text(a));
        x = std::min(std::max(x, a.min), a.max);
    }
    return x;
}

namespace {

bool is_mirror_phi(const Axis& a) {
    return a.name == "phi_d" && a.spacing == Spacing::Linear &&
           std::fabs(a.min) < 1e-9 &&
           (a.unit == "rad" ? std::fabs(a.max - kPi) < 1e-9 : std::fabs(a.max - 180.0) < 1e-9);
}

}  // namespace

// Weights of the (already range-resolved) coordinate x on axis a, computed in
// the warped coordinate u = unwarp(x) * (count - 1) (node k at u = k).
void axis_weights(const Axis& a, double x, Interpolation interp, AxisWeights& out) {
    axis_weights_t(a, a.unwarp(x), interp, out);
}

void axis_weights_t(const Axis& a, double t, Interpolation interp, AxisWeights& out) {
    axis_weights_n(a.count, is_mirror_phi(a), t, interp, out);
}

void axis_weights_n(std::size_t n, bool mirror, double t, Interpolation interp,
                    AxisWeights& out) {
    out.n = 0;
    double u = t * double(n - 1);
    if (!(u >= 0)) u = 0;  // also catches NaN from a degenerate warp
    if (u > double(n - 1)) u = double(n - 1);
    std::size_t k = std::min<std::size_t>(std::size_t(u), n - 2);
    const double s = std::min(std::max(u - double(k), 0.0), 1.0);
    if (interp == Interpolation::Linear) {
        out.add(k, 1.0 - s);
        out.add(k + 1, s);
        return;
    }
    // Uniform Catmull-Rom in u: Hermite with central-difference slopes.
    const double s2 = s * s, s3 = s2 * s;
    const double wm = 0.5 * (-s3 + 2 * s2 - s);
    const double w0 = 0.5 * (3 * s3 - 5 * s2 + 2);
    const double w1 = 0.5 * (-3 * s3 + 4 * s2 + s);
    const double w2 = 0.5 * (s3 - s2);
    out.add(k, w0);
    out.add(k + 1, w1);
    // Ghost below node 0.
    if (k >= 1) {
        out.add(k - 1, wm);
    } else if (mirror) {
        out.add(1, wm);  // f(-h) = f(h): even about phi_d = 0
    } else if (n >= 3) {
        out.add(0, 3 * wm);  // quadratic extrapolation: p(-1) = 3p0 - 3p1 + p2
        out.add(1, -3 * wm);
        out.add(2, wm);
    } else {
        out.add(0, 2 * wm);  // linear: p(-1) = 2p0 - p1
        out.add(1, -wm);
    }
    // Ghost above node n-1.
    if (k + 2 <= n - 1) {
        out.add(k + 2, w2);
    } else if (mirror) {
        out.add(n - 2, w2);  // even about phi_d = 180
    } else if (n >= 3) {
        out.add(n - 1, 3 * w2);
        out.add(n - 2, -3 * w2);
        out.add(n - 3, w2);
    } else {
        out.add(n - 1, 2 * w2);
        out.add(n - 2, -w2);
    }
}

// Tensor-product contraction of per-axis weights with a row-major array.
double contract(const AxisWeights* ws, const std::size_t* strides, std::size_t dims,
                const double* values, std::size_t d, std::size_t offset) {
    if (d == dims) return values[offset];
    double sum = 0;
    for (int k = 0; k < ws[d].n; ++k) {
        if (ws[d].w[k] == 0) continue;
        sum += ws[d].w[k] *
               contract(ws, strides, dims, values, d + 1, offset + ws[d].idx[k] * strides[d]);
    }
    return sum;
}

}  // namespace lookup_internal

using namespace lookup_internal;

namespace {

// The per-axis weights of a lookup at `coords` (the table axes first; a
// recombination parameter after them is not read here), shared by the
// general path of eval() and by stencil_cells() so both see the same cells.
// ws: one entry per axis.
void point_weights(const std::vector<Axis>& ax, const FastAxis* fast,
                   const std::vector<int>& dependency, const double* coords,
                   Interpolation interp, OutOfRange mode, const std::string& table,
                   AxisWeights* ws, double* x) {
    const std::size_t dims = ax.size();
    for (std::size_t d = 0; d < dims; ++d)
        x[d] = resolve_fast(fast[d], ax[d], coords[d], mode, table);
    for (std::size_t d = 0; d < dims; ++d) {
        // An axis whose nodes depend on another (critical: mu_i on eta) is
        // unwarped at this point's value of that axis: the table is a tensor
        // product in (t, eta), not in (mu_i, eta).
        const double t = dependency[d] >= 0
                             ? ax[d].unwarp_at(x[d], x[std::size_t(dependency[d])])
                             : unwarp_fast(fast[d], ax[d], x[d]);
        axis_weights_n(fast[d].count, fast[d].mirror, t, interp, ws[d]);
    }
}

// The flat indices contract() reads (weights != 0), in its order.
void stencil_indices(const AxisWeights* ws, const std::size_t* strides, std::size_t dims,
                     std::vector<std::size_t>& out, std::size_t d = 0, std::size_t offset = 0) {
    if (d == dims) {
        out.push_back(offset);
        return;
    }
    for (int k = 0; k < ws[d].n; ++k) {
        if (ws[d].w[k] == 0) continue;
        stencil_indices(ws, strides, dims, out, d + 1, offset + ws[d].idx[k] * strides[d]);
    }
}

}  // namespace

void LookupTable::stencil_cells(const std::vector<double>& coords, Interpolation interp,
                                OutOfRange mode, std::vector<std::size_t>& cells) const {
    if (adaptive_) refuse_adaptive("it has no tensor stencil");
    const auto& ax = axes();
    if (coords.size() < ax.size())
        throw InputError("table '" + table().name + "': stencil_cells needs " +
                         std::to_string(ax.size()) + " coordinates, got " +
                         std::to_string(coords.size()));
    std::vector<AxisWeights> ws(ax.size());
    std::vector<double> x(ax.size());
    point_weights(ax, fast_.data(), dependency_, coords.data(), interp, mode, table().name,
                  ws.data(), x.data());
    stencil_indices(ws.data(), strides_.data(), ax.size(), cells);
}

double LookupTable::eval(const std::vector<double>& coords, Interpolation interp,
                         OutOfRange mode) const {
    const std::size_t want = axes().size() + (terms_.empty() ? 0 : 1);
    if (coords.size() != want)
        throw InputError("table '" + table().name + "': eval needs " + std::to_string(want) +
                         " coordinates, got " + std::to_string(coords.size()));
    return eval_point(coords.data(), interp, mode);
}

double LookupTable::eval(const double* coords, Interpolation interp, OutOfRange mode) const {
    return eval_point(coords, interp, mode);
}

// The value at checked coordinates.  Nothing is allocated for up to
// kMaxUnrolledDims axes and 8 pieces.  Linear lookups on independent axes
// take the unrolled kernel, the rest the general weights and contract(): the
// same arithmetic either way.
template <int D, bool Skip>
double LookupTable::linear_kernel(const LookupTable& lt, const double* coords, OutOfRange mode) {
    const FastAxis* fast = lt.fast_.data();
    const Axis* ax = lt.pieces_.front().axes.data();
    const std::size_t* strides = lt.strides_.data();
    double s[D];
    std::size_t offset = 0;
    if constexpr (D >= 4) {
        // Tables of 4 or more axes rarely fit the caches, and the inverse
        // warps (a log, divisions) delay the corner loads: start them from
        // the cells' node-index guesses (a prefetch, correct but for
        // rounding at a node), then compute the exact cell.
        std::size_t guess = 0;
#pragma GCC unroll 8
        for (int d = 0; d < D; ++d) {
            const FastAxis& f = fast[d];
            double x = coords[d];
            x = x > f.min ? (x < f.max ? x : f.max) : f.min;  // NaN: min
            guess += f.cells.cell(x) * strides[d];
        }
        const double* v = lt.pieces_.front().value.data() + guess;
        const std::size_t* lines = lt.corner_lines_.data();
        const std::size_t last = strides[D - 1];
#pragma GCC unroll 16
        for (std::size_t corner = 0; corner < (std::size_t(1) << (D - 1)); ++corner) {
            __builtin_prefetch(v + lines[corner]);
            __builtin_prefetch(v + lines[corner] + last);
        }
    }
#pragma GCC unroll 8
    for (int d = 0; d < D; ++d) {
        const double x = resolve_fast(fast[d], ax[d], coords[d], mode, lt.pieces_.front().name);
        offset += linear_cell(fast[d], unwarp_fast(fast[d], ax[d], x), s[d]) * strides[d];
    }
    if (lt.terms_.empty()) return multilinear<D, Skip>(lt.pieces_.front().value.data() + offset, strides, s);
    double p = coords[D];
    lt.resolve_param(p, mode);
    const std::size_t np = lt.pieces_.size();
    double pv_buf[8];
    std::vector<double> pv_heap;
    double* pv = np <= 8 ? pv_buf : (pv_heap.resize(np), pv_heap.data());
    for (std::size_t k = 0; k < np; ++k)
        pv[k] = multilinear<D, Skip>(lt.pieces_[k].value.data() + offset, strides, s);
    return lt.combine(pv, p);
}

// Linear lookups of tables with at most kMaxUnrolledDims axes, none
// depending on another, go to a kernel unrolled for their axis count (the
// unskipped form when every value of every piece is finite).
void LookupTable::choose_linear_kernel() {
    linear_ = nullptr;
    const std::size_t dims = axes().size();
    if (dims > kMaxUnrolledDims || has_dependent_) return;
    bool finite = true;
    for (const auto& p : pieces_) finite = finite && all_finite(p.value);
    using Fn = double (*)(const LookupTable&, const double*, OutOfRange);
    static const Fn skip[] = {&linear_kernel<1, true>, &linear_kernel<2, true>,
                              &linear_kernel<3, true>, &linear_kernel<4, true>,
                              &linear_kernel<5, true>, &linear_kernel<6, true>,
                              &linear_kernel<7, true>, &linear_kernel<8, true>};
    static const Fn plain[] = {&linear_kernel<1, false>, &linear_kernel<2, false>,
                               &linear_kernel<3, false>, &linear_kernel<4, false>,
                               &linear_kernel<5, false>, &linear_kernel<6, false>,
                               &linear_kernel<7, false>, &linear_kernel<8, false>};
    linear_ = finite ? plain[dims - 1] : skip[dims - 1];
    corner_lines_.assign(std::size_t(1) << (dims - 1), 0);
    for (std::size_t corner = 0; corner < corner_lines_.size(); ++corner)
        for (std::size_t d = 0; d + 1 < dims; ++d)
            if ((corner >> d) & 1) corner_lines_[corner] += strides_[d];
}

double LookupTable::eval_point(const double* coords, Interpolation interp,
                               OutOfRange mode) const {
    if (interp == Interpolation::Linear && linear_) return linear_(*this, coords, mode);
    return eval_general(coords, interp, mode);
}

// Cubic lookups, axes that depend on another, more than kMaxUnrolledDims
// axes: the per-axis weights and contract().
double LookupTable::eval_general(const double* coords, Interpolation interp,
                                 OutOfRange mode) const {
    if (adaptive_) refuse_adaptive("no cubic interpolation");
    const auto& ax = axes();
    const std::size_t dims = ax.size();
    const std::size_t np = pieces_.size();
    double pv_buf[8];
    std::vector<double> pv_heap;
    double* pv = np <= 8 ? pv_buf : (pv_heap.resize(np), pv_heap.data());
    double p = 0;
    AxisWeights ws_buf[kMaxUnrolledDims];
    double x_buf[kMaxUnrolledDims];
    std::vector<AxisWeights> ws_heap;
    std::vector<double> x_heap;
    AxisWeights* ws = ws_buf;
    double* x = x_buf;
    if (dims > kMaxUnrolledDims) {
        ws_heap.resize(dims);
        x_heap.resize(dims);
        ws = ws_heap.data();
        x = x_heap.data();
    }
    point_weights(ax, fast_.data(), dependency_, coords, interp, mode, table().name, ws, x);
    if (!terms_.empty()) {
        p = coords[dims];
        resolve_param(p, mode);
    }
    for (std::size_t k = 0; k < np; ++k)
        pv[k] = contract(ws, strides_.data(), dims, pieces_[k].value.data());
    return combine(pv, p);
}

std::vector<double> LookupTable::ordered_coordinates(
    const std::map<std::string, double>& values, const std::string& where) const {
    const auto names = coordinate_names();
    auto list = [](const std::vector<std::string>& v) {
        std::string s;
        for (const auto& n : v) s += (s.empty() ? "" : ", ") + n;
        return s;
    };
    for (const auto& kv : values)
        if (std::find(names.begin(), names.end(), kv.first) == names.end())
            throw InputError(where + ": '" + kv.first + "' is not a coordinate of table '" +
                             table().name + "' (coordinates: " + list(names) + ")");
    std::vector<double> out;
    std::vector<std::string> missing;
    for (const auto& n : names) {
        const auto it = values.find(n);
        if (it == values.end())
            missing.push_back(n);
        else
            out.push_back(it->second);
    }
    if (!missing.empty())
        throw InputError(where + ": missing " + list(missing) + " (table '" + table().name +
                         "' needs " + list(names) + ")");
    return out;
}

namespace {

// Batch linear lookups of a single table (no recombination) on D independent
// axes, in blocks: first every point of the block is located (range checks,
// inverse warps, cells) and the cache lines of its corners are prefetched,
// then the corners are contracted.  The loads of one point then overlap the
// work on the others, which pays on tables larger than the caches.  The
// same functions as the scalar kernel: the same bits.
struct ManyLinear {
    const FastAxis* fast;
    const Axis* axes;
    const std::size_t* strides;
    const double* values;
    const std::string* table;
};

template <int D, bool Skip>
void linear_many(const ManyLinear& m, const double* coords, std::size_t count, double* out,
                 OutOfRange mode) {
    constexpr std::size_t kBlock = 8;
    std::size_t offset[kBlock];
    double s[kBlock][D];
    for (std::size_t b = 0; b < count; b += kBlock) {
        const std::size_t n = std::min(kBlock, count - b);
        std::size_t located = 0;
        try {
            for (; located < n; ++located) {
                const double* c = coords + (b + located) * D;
                std::size_t off = 0;
#pragma GCC unroll 8
                for (int d = 0; d < D; ++d) {
                    const double x = resolve_fast(m.fast[d], m.axes[d], c[d], mode, *m.table);
                    off += linear_cell(m.fast[d], unwarp_fast(m.fast[d], m.axes[d], x),
                                       s[located][d]) *
                           m.strides[d];
                }
                offset[located] = off;
                // Corners differ on the last axis by one element: one line
                // (or two) per combination of the other axes.
                for (std::size_t corner = 0; corner < (std::size_t(1) << (D - 1)); ++corner) {
                    std::size_t o = off;
                    for (int d = 0; d + 1 < D; ++d)
                        if ((corner >> d) & 1) o += m.strides[d];
                    __builtin_prefetch(m.values + o);
                    __builtin_prefetch(m.values + o + m.strides[D - 1]);
                }
            }
        } catch (...) {
            // The points before the bad one are written, as the scalar loop does.
            for (std::size_t i = 0; i < located; ++i)
                out[b + i] = multilinear<D, Skip>(m.values + offset[i], m.strides, s[i]);
            throw;
        }
        for (std::size_t i = 0; i < n; ++i)
            out[b + i] = multilinear<D, Skip>(m.values + offset[i], m.strides, s[i]);
    }
}

template <bool Skip>
bool linear_many_dims(std::size_t dims, const ManyLinear& m, const double* coords,
                      std::size_t count, double* out, OutOfRange mode) {
    switch (dims) {
        case 1: linear_many<1, Skip>(m, coords, count, out, mode); return true;
        case 2: linear_many<2, Skip>(m, coords, count, out, mode); return true;
        case 3: linear_many<3, Skip>(m, coords, count, out, mode); return true;
        case 4: linear_many<4, Skip>(m, coords, count, out, mode); return true;
        case 5: linear_many<5, Skip>(m, coords, count, out, mode); return true;
        case 6: linear_many<6, Skip>(m, coords, count, out, mode); return true;
        default: return false;
    }
}

}  // namespace

void LookupTable::eval_many(const double* coords, std::size_t count, double* out,
                            Interpolation interp, OutOfRange mode) const {
    const std::size_t dims = axes().size();
    const std::size_t width = dims + (terms_.empty() ? 0 : 1);
    if (interp == Interpolation::Linear && linear_ && terms_.empty() && !adaptive_) {
        const ManyLinear m{fast_.data(), axes().data(), strides_.data(),
                           pieces_.front().value.data(), &table().name};
        // The choice of choose_linear_kernel(): the unskipped kernel when finite.
        using Fn = double (*)(const LookupTable&, const double*, OutOfRange);
        static const Fn plain[] = {&linear_kernel<1, false>, &linear_kernel<2, false>,
                                   &linear_kernel<3, false>, &linear_kernel<4, false>,
                                   &linear_kernel<5, false>, &linear_kernel<6, false>,
                                   &linear_kernel<7, false>, &linear_kernel<8, false>};
        const bool skip = linear_ != plain[dims - 1];
        if (skip ? linear_many_dims<true>(dims, m, coords, count, out, mode)
                 : linear_many_dims<false>(dims, m, coords, count, out, mode))
            return;
    }
    for (std::size_t k = 0; k < count; ++k) out[k] = eval_point(coords + k * width, interp, mode);
}

double LookupTable::eval(const std::map<std::string, double>& coords, Interpolation interp,
                         OutOfRange mode) const {
    const auto names = coordinate_names();
    std::vector<double> v;
    for (const auto& n : names) {
        auto it = coords.find(n);
        if (it == coords.end())
            throw InputError("table '" + table().name + "': coordinate '" + n + "' is missing");
        v.push_back(it->second);
    }
    for (const auto& kv : coords)
        if (std::find(names.begin(), names.end(), kv.first) == names.end())
            throw InputError("table '" + table().name + "': unknown coordinate '" + kv.first +
                             "'");
    return eval(v, interp, mode);
}

}  // namespace brdftab
