// bindings.cpp — the Python extension `brdftab._brdftab`: the renderer-side
// library (host/lookup/lookup.h), the table reader (host/io/table_io.h) and
// adaptive tables (host/adaptive/adaptive_io.h, evaluation only) over numpy
// arrays.  The user-facing API (keyword coordinates, broadcasting,
// the file object) is in python/brdftab/__init__.py; this file only moves
// arrays in and out and loops over points with the GIL released (the lookup
// objects are immutable, lookup.h "Thread safety").
//
// Library errors keep their messages: brdftab::InputError becomes
// brdftab.InputError (a ValueError), every other brdftab::Error
// brdftab.Error (a RuntimeError), so Python sees the text the CLI prints
// after "brdftab: error: ".
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <exception>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "host/adaptive/adaptive_io.h"
#include "host/core/error.h"
#include "host/core/vocabulary.h"
#include "host/io/table_io.h"
#include "host/lookup/lookup.h"
#include "host/lookup/lookup_internal.h"

namespace py = pybind11;
using namespace brdftab;

namespace {

using DoubleArray = py::array_t<double, py::array::c_style | py::array::forcecast>;
using FloatArray = py::array_t<float, py::array::c_style | py::array::forcecast>;

// Worker threads of the batch loops (set_threads); 0 = one per hardware thread.
std::atomic<unsigned> g_threads{0};

unsigned thread_count() {
    const unsigned t = g_threads.load();
    return t ? t : std::max(1u, std::thread::hardware_concurrency());
}

// Clears the upper halves of the AVX registers (vzeroupper) where the CPU
// has AVX.  Code JIT-compiled by Dr.Jit (the Mitsuba plugin's caller) can
// return with them dirty; the scalar SSE code of the lookups then pays a
// state-transition penalty on its floating-point instructions (measured:
// the plugin's lookups 3-4x slower inside a render than outside).
inline void clean_vector_state() {
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
    static const bool has_avx = __builtin_cpu_supports("avx");
    if (has_avx) __asm__ volatile("vzeroupper" ::: "memory");
#endif
}

// Runs body(begin, end) over [0, n) in contiguous chunks on up to
// thread_count() threads (chunks of at least 8192 points; one thread below
// that).  Every point is computed by the same scalar code whatever the split,
// so results do not depend on the thread count.  The exception of the
// lowest chunk that threw is rethrown: the first bad point's, as in a serial
// loop.  Call with the GIL released.
template <class Body>
void parallel_for(std::size_t n, const Body& body) {
    const std::size_t min_chunk = 8192;
    const std::size_t t = std::min<std::size_t>(thread_count(), std::max<std::size_t>(1, n / min_chunk));
    clean_vector_state();
    if (t <= 1) {
        body(std::size_t(0), n);
        return;
    }
    std::vector<std::exception_ptr> errors(t);
    std::vector<std::thread> pool;
    pool.reserve(t - 1);
    auto run = [&](std::size_t c) {
        try {
            body(n * c / t, n * (c + 1) / t);
        } catch (...) {
            errors[c] = std::current_exception();
        }
    };
    for (std::size_t c = 1; c < t; ++c) pool.emplace_back(run, c);
    run(0);
    for (auto& th : pool) th.join();
    for (auto& e : errors)
        if (e) std::rethrow_exception(e);
}

py::object json_to_python(const nlohmann::json& j) {
    return py::module_::import("json").attr("loads")(j.dump());
}

Interpolation interpolation_of(const std::string& name) {
    if (name == "linear") return Interpolation::Linear;
    if (name == "cubic") return Interpolation::Cubic;
    throw InputError("interpolation must be 'linear' or 'cubic', got '" + name + "'");
}

OutOfRange out_of_range_of(const std::string& name) {
    if (name == "clamp") return OutOfRange::Clamp;
    if (name == "reject") return OutOfRange::Reject;
    throw InputError("out_of_range must be 'clamp' or 'reject', got '" + name + "'");
}

// The provenance attributes of a table as a dict.
py::dict provenance_of(const TableData& d) {
    py::dict p;
    p["method"] = method_attribute(d);
    p["samples_requested"] = d.samples_requested;
    p["tolerance_requested"] = d.tolerance_requested;
    p["abs_floor"] = d.abs_floor;
    p["tolerance_achieved"] = d.tolerance_achieved;
    p["seed"] = d.seed;
    p["precision"] = d.precision;
    p["device"] = d.device;
    p["version"] = d.version;
    p["elapsed_seconds"] = d.elapsed_seconds;
    p["total_samples"] = d.total_samples;
    return p;
}

// The stored certificate of a table as a dict, or None.
py::object certificate_of(const std::string& path, const std::string& name) {
    const auto c = read_stored_certificate(path, name);
    if (!c) return py::none();
    py::dict d;
    d["max_error"] = c->max_error;
    d["rms_error"] = c->rms_error;
    d["measure"] = c->absolute ? "absolute" : "relative";
    d["abs_floor"] = c->abs_floor;
    d["interpolation"] = c->interpolation;
    d["target"] = c->target;
    d["passed"] = c->passed;
    return std::move(d);
}

// A read-only numpy view of `data` (row-major, shape of the axes) that keeps
// `owner` alive.
py::array view(const std::vector<double>& data, const std::vector<Axis>& axes,
               py::handle owner) {
    std::vector<py::ssize_t> shape, strides(axes.size());
    for (const auto& a : axes) shape.push_back(py::ssize_t(a.count));
    py::ssize_t stride = sizeof(double);
    for (std::size_t d = axes.size(); d-- > 0;) {
        strides[d] = stride;
        stride *= shape[d];
    }
    py::array a(py::dtype::of<double>(), shape, strides, data.data(), owner);
    py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
    return a;
}

// An (n, width) float64 array, checked.
DoubleArray rows_of(const py::array& in, std::size_t width, const char* what) {
    DoubleArray a = DoubleArray::ensure(in);
    if (!a) throw InputError(std::string(what) + ": expected an array of numbers");
    if (a.ndim() != 2 || std::size_t(a.shape(1)) != width)
        throw InputError(std::string(what) + ": expected shape (n, " + std::to_string(width) +
                         ")");
    return a;
}

// The coordinates of a batch eval as columns: one float64 array per
// coordinate (in the library's order) of n values, or of one value that
// every point shares.  Python passes numpy's broadcast columns as they are,
// so no (n, width) array of rows is built there.
struct Columns {
    std::vector<DoubleArray> arrays;
    std::vector<const double*> data;
    std::vector<std::size_t> step;  // 1, or 0 for a shared value
    std::size_t n = 0;

    Columns(const std::vector<py::array>& in, std::size_t count, std::size_t width) : n(count) {
        if (in.size() != width)
            throw InputError("coordinates: expected " + std::to_string(width) + " columns, got " +
                             std::to_string(in.size()));
        for (const py::array& a : in) {
            arrays.push_back(DoubleArray::ensure(a));
            const DoubleArray& c = arrays.back();
            if (!c) throw InputError("coordinates: expected arrays of numbers");
            const std::size_t size = std::size_t(c.size());
            if (size != n && size != 1)
                throw InputError("coordinates: a column of " + std::to_string(size) + " values for " +
                                 std::to_string(n) + " points");
            data.push_back(c.data());
            step.push_back(size == 1 ? 0 : 1);
        }
    }
    double at(std::size_t d, std::size_t k) const { return data[d][k * step[d]]; }
};

// Per coordinate whose values the lookup clamps: how many points, and the
// first such value (Python's clamp warning).
struct ClampCount {
    std::size_t count = 0;
    double first = 0;
};

// Batch eval over columns: rows gathered in blocks of 256 into a buffer and
// handed to many(rows, count, out) (LookupTable::eval_many), threaded.  With
// `outside` (a function (coordinate, value) -> bool) the same pass counts the
// values outside their axes.  Returns the values and, per coordinate, the
// counts.
template <class Many, class Outside>
std::pair<py::array_t<double>, std::vector<ClampCount>>
eval_columns(const Columns& c, const Many& many, const Outside* outside) {
    const std::size_t width = c.data.size(), n = c.n;
    py::array_t<double> out(py::ssize_t(n), nullptr);
    double* dst = out.mutable_data();
    std::vector<std::vector<ClampCount>> chunk_counts;
    std::mutex lock;
    {
        py::gil_scoped_release release;
        parallel_for(n, [&](std::size_t a, std::size_t e) {
            constexpr std::size_t kBlock = 256;
            std::vector<double> rows(kBlock * std::max<std::size_t>(width, 1));
            std::vector<ClampCount> counts(width);
            for (std::size_t b = a; b < e; b += kBlock) {
                const std::size_t m = std::min(kBlock, e - b);
                for (std::size_t d = 0; d < width; ++d) {
                    const double* col = c.data[d] + b * c.step[d];
                    const std::size_t step = c.step[d];
                    for (std::size_t k = 0; k < m; ++k) rows[k * width + d] = col[k * step];
                }
                many(rows.data(), m, dst + b);
                if (outside)
                    for (std::size_t d = 0; d < width; ++d)
                        for (std::size_t k = 0; k < m; ++k) {
                            const double v = rows[k * width + d];
                            if ((*outside)(d, v) && counts[d].count++ == 0) counts[d].first = v;
                        }
            }
            std::lock_guard<std::mutex> g(lock);
            chunk_counts.emplace_back(std::move(counts));
            chunk_counts.back().push_back({a, 0});  // the chunk's start, for ordering
        });
    }
    // Merge in point order: the first value is the lowest chunk's.
    std::sort(chunk_counts.begin(), chunk_counts.end(),
              [](const auto& x, const auto& y) { return x.back().count < y.back().count; });
    std::vector<ClampCount> total(width);
    for (const auto& counts : chunk_counts)
        for (std::size_t d = 0; d < width; ++d) {
            if (counts[d].count && !total[d].count) total[d].first = counts[d].first;
            total[d].count += counts[d].count;
        }
    return {std::move(out), std::move(total)};
}

// A per-pair batch call (BoundTable::eval_many, pdf_many) over (n, 3)
// float64 rows of wi and wo: one value per row, threaded.
template <class Many>
py::array_t<double> pair_call(const py::array& wi_in, const py::array& wo_in, const Many& many) {
    const DoubleArray wi = rows_of(wi_in, 3, "wi"), wo = rows_of(wo_in, 3, "wo");
    const py::ssize_t n = wi.shape(0);
    if (wo.shape(0) != n) throw InputError("wi and wo: different numbers of rows");
    py::array_t<double> out(n);
    double* dst = out.mutable_data();
    const double *pi = wi.data(), *po = wo.data();
    {
        py::gil_scoped_release release;
        parallel_for(std::size_t(n), [&](std::size_t a, std::size_t e) {
            many(pi + 3 * a, po + 3 * a, e - a, dst + a);
        });
    }
    return out;
}

// The clamp warnings' data: (name, count, first value, min, max) per
// coordinate with values outside its range.
py::list clamp_list(const std::vector<ClampCount>& counts, const std::vector<Axis>& axes) {
    py::list out;
    for (std::size_t d = 0; d < counts.size() && d < axes.size(); ++d)
        if (counts[d].count)
            out.append(py::make_tuple(axes[d].name, counts[d].count, counts[d].first,
                                      std::min(axes[d].min, axes[d].max), std::max(axes[d].min, axes[d].max)));
    return out;
}

// The lookup table of one stored table, with its standard-error lookup.
struct PyTable {
    std::string path;
    std::shared_ptr<const LookupTable> lookup;
    std::shared_ptr<const LookupTable> stderr_table;  // null when none is stored

    PyTable(const std::string& file, const std::string& name)
        : path(file),
          lookup(std::make_shared<const LookupTable>(LookupTable::open(file, name))),
          stderr_table(stderr_lookup(*lookup)) {}

    // Values at n points given as columns (Columns), and the clamp
    // warnings' data (clamp mode only; phi_d folded or wrapped first, as
    // `brdftab query` warns; the recombination parameter is not an axis).
    py::tuple eval_columns_of(const std::vector<py::array>& cols, std::size_t n, const std::string& interp,
                              const std::string& mode, bool of_stderr) const {
        const LookupTable* lt = lookup.get();
        if (of_stderr) {
            lt = stderr_table.get();
            if (!lt)
                throw InputError("table '" + lookup->table().name +
                                 "' stores no standard errors (a closed form, a table "
                                 "written without them, or a recombined table)");
        }
        const Columns c(cols, n, lt->coordinate_names().size());
        const Interpolation ip = interpolation_of(interp);
        const OutOfRange om = out_of_range_of(mode);
        const std::vector<Axis>& axes = lt->axes();
        std::vector<double> tol;
        for (const Axis& a : axes) tol.push_back(1e-9 * (a.max - a.min));
        const auto outside = [&](std::size_t d, double v) {
            if (d >= axes.size() || (v >= axes[d].min - tol[d] && v <= axes[d].max + tol[d])) return false;
            // Only a value outside its axis can be folded (fold_periodic
            // returns one inside unchanged).
            const double x = lookup_internal::fold_periodic(axes[d], v);
            return !(x >= axes[d].min - tol[d] && x <= axes[d].max + tol[d]);
        };
        auto [values, counts] = eval_columns(
            c, [&](const double* rows, std::size_t m, double* out) { lt->eval_many(rows, m, out, ip, om); },
            om == OutOfRange::Clamp ? &outside : nullptr);
        return py::make_tuple(std::move(values), clamp_list(counts, axes));
    }
};

struct PyBound {
    std::shared_ptr<const BoundTable> bound;
};

// An adaptive table (docs/adaptive.md): linear interpolation in its patches,
// exactly as `brdftab query` evaluates it (each coordinate clamped to its
// axis' range, or rejected), through the lookup library's adaptive kernel
// (host/lookup/adaptive_lookup.cpp), which bind() also serves: eval, pdf and
// sampling on directions for a table over theta_i|mu_i, theta_o|mu_o and
// optionally phi_d.  No cubic interpolation.
struct PyAdaptive {
    std::string path;
    std::shared_ptr<const LookupTable> lookup;
    std::shared_ptr<const AdaptiveTable> table;  // lookup's own

    PyAdaptive(const std::string& file, const std::string& name)
        : path(file), lookup(std::make_shared<const LookupTable>(LookupTable::open(file, name))) {
        if (!lookup->is_adaptive())
            throw InputError("table '" + name + "' of '" + file + "' is not adaptive");
        table = std::shared_ptr<const AdaptiveTable>(lookup, lookup->adaptive());
    }

    const TableData& data() const { return table->data; }

    std::vector<std::string> names() const {
        std::vector<std::string> n;
        for (const Axis& a : data().axes) n.push_back(a.name);
        return n;
    }

    // Which given name goes to each axis; unknown or missing names raise
    // the message `brdftab query` prints.
    std::vector<std::size_t> order(const std::vector<std::string>& given) const {
        std::string all;
        for (const Axis& a : data().axes) all += (all.empty() ? "" : ", ") + a.name;
        for (const std::string& g : given)
            if (std::none_of(data().axes.begin(), data().axes.end(), [&](const Axis& a) { return a.name == g; }))
                throw InputError("arguments: '" + g + "' is not a coordinate of table '" + data().name +
                                 "' (coordinates: " + all + ")");
        std::vector<std::size_t> out;
        for (const Axis& a : data().axes) {
            const auto it = std::find(given.begin(), given.end(), a.name);
            if (it == given.end())
                throw InputError("arguments: missing coordinate '" + a.name + "' (table '" + data().name +
                                 "' needs " + all + ")");
            out.push_back(std::size_t(it - given.begin()));
        }
        return out;
    }

    // The stored standard errors at `count` rows, interpolated by the
    // table's patches as the values are (coordinates clamped or rejected).
    void stderr_many(const double* rows, std::size_t count, double* out, bool reject) const {
        const std::size_t dims = data().axes.size();
        double x[16], tt[16];
        for (std::size_t k = 0; k < count; ++k) {
            for (std::size_t d = 0; d < dims; ++d) {
                const Axis& ax = data().axes[d];
                const double lo = std::min(ax.min, ax.max), hi = std::max(ax.min, ax.max);
                double v = rows[k * dims + d];
                if (!(v >= lo && v <= hi)) {
                    if (reject || std::isnan(v))
                        throw InputError("coordinates: " + ax.name + " = " + std::to_string(v) + " outside [" +
                                         std::to_string(lo) + ", " + std::to_string(hi) + "]");
                    v = std::clamp(v, lo, hi);
                }
                x[d] = v;
            }
            table->to_t(x, tt);
            out[k] = table->layout.eval(tt, data().stderr_.data());
        }
    }

    py::tuple eval_columns_of(const std::vector<py::array>& cols, std::size_t n, const std::string& interp,
                              const std::string& mode, bool of_stderr) const {
        if (interp != "linear") {
            interpolation_of(interp);  // the message for an unknown name
            throw InputError("table '" + data().name + "' is adaptive: its patches interpolate linearly only");
        }
        const OutOfRange om = out_of_range_of(mode);
        if (of_stderr && data().stderr_.size() != data().value.size())
            throw InputError("table '" + data().name + "' stores no standard errors");
        const std::size_t dims = data().axes.size();
        if (dims > 16) throw InputError("table '" + data().name + "': more than 16 axes");
        const Columns c(cols, n, dims);
        const auto outside = [&](std::size_t d, double v) {
            const Axis& ax = data().axes[d];
            return v < std::min(ax.min, ax.max) || v > std::max(ax.min, ax.max);
        };
        const bool reject = om == OutOfRange::Reject;
        auto [values, counts] = eval_columns(
            c,
            [&](const double* rows, std::size_t m, double* out) {
                if (of_stderr)
                    stderr_many(rows, m, out, reject);
                else
                    lookup->eval_many(rows, m, out, Interpolation::Linear, om);
            },
            reject ? nullptr : &outside);
        return py::make_tuple(std::move(values), clamp_list(counts, data().axes));
    }
};


// The Mitsuba plugin's per-wavefront work (python/brdftab/mitsuba.py) in one
// call per BSDF method: Dr.Jit's single-precision arrays in (one array per
// component, each of length n or 1), f |cos theta_o|, pdf and samples out.
// An isotropic table only.  f is either one bound table (the same in the
// three channels) or, under a reflectance texture p, a factored table:
//     f_c = num(p_c) / den(p_c) * sum_k poly_k(p_c) T_k(wi, wo)
// with each term table T_k bound once.  A lane is invalid (f = pdf = 0)
// when a direction is zero or not finite, when wi is below the surface and
// the table is lit from above only, or when wo is below and the table does
// not transmit.
struct PluginKernel {
    std::shared_ptr<const BoundTable> single;               // no texture
    std::vector<std::shared_ptr<const BoundTable>> terms;   // factored
    std::vector<std::vector<double>> coeffs;
    std::vector<double> num{1.0}, den{1.0};
    std::shared_ptr<const BoundTable> sampler;
    bool lit_from_below = false, transmits = false;

    static double poly(const std::vector<double>& c, double p) {
        double v = 0;
        for (std::size_t k = c.size(); k-- > 0;) v = v * p + c[k];
        return v;
    }

    // f per channel at a valid pair.
    void f_rgb(const Vec3& wi, const Vec3& wo, const double p[3], double out[3]) const {
        if (single) {
            out[0] = out[1] = out[2] = single->eval(wi, wo);
            return;
        }
        double t[8];
        const std::size_t nt = std::min<std::size_t>(terms.size(), 8);
        for (std::size_t k = 0; k < nt; ++k) t[k] = terms[k]->eval(wi, wo);
        for (int c = 0; c < 3; ++c) {
            double sum = 0;
            for (std::size_t k = 0; k < nt; ++k) sum += poly(coeffs[k], p[c]) * t[k];
            out[c] = sum * poly(num, p[c]) / poly(den, p[c]);
        }
    }

    // eval_pdf at lane k (wi already read; ok: active with a valid wi):
    // out[0..2] f |cos theta_o| per channel and out[3] the pdf, each
    // skipped when null.
    template <class Lane3>
    void eval_lane(bool ok, const Vec3& wi, const Lane3& ox, const Lane3& oy, const Lane3& oz,
                   const double p[3], std::size_t k, float* const* out) const;

    // A sample at lane k: out[0..2] wo, out[3] pdf, out[4..6] weight.
    void sample_lane(bool ok, const Vec3& wi, double u1, double u2, const double p[3], std::size_t k,
                     float* const* out) const {
        ok = ok && (lit_from_below || wi.z > 0);
        SampleResult s;
        s.wo = {0, 0, 1};
        if (ok) {
            // u below 1: u = 1 in float32 stays in the last cell.
            s = sampler->sample(wi, std::min(u1, 1 - 1e-12), std::min(u2, 1 - 1e-12));
            ok = (transmits || s.wo.z > 0) && s.pdf > 0;
        }
        double v[3] = {0, 0, 0};
        if (ok) {
            if (single)
                v[0] = v[1] = v[2] = s.value;
            else
                f_rgb(wi, s.wo, p, v);
        }
        const double c = std::fabs(s.wo.z);
        out[0][k] = float(s.wo.x);
        out[1][k] = float(s.wo.y);
        out[2][k] = float(s.wo.z);
        out[3][k] = ok ? float(s.pdf) : 0.0f;
        for (int ch = 0; ch < 3; ++ch) out[4 + ch][k] = ok ? float(v[ch] * c / s.pdf) : 0.0f;
    }
};

// One component of a Dr.Jit array (float32 numbers, or the active mask as
// bools) as a numpy array of length n or 1.
template <class T>
struct Lane {
    py::array_t<T, py::array::c_style | py::array::forcecast> a;
    const T* p = nullptr;
    bool scalar = true;
    Lane(const py::array& in, const char* what) : a(decltype(a)::ensure(in)) {
        if (!a) throw InputError(std::string(what) + ": expected an array");
        if (a.ndim() > 1) throw InputError(std::string(what) + ": expected a 1-D array");
        if (a.size() == 0) throw InputError(std::string(what) + ": empty array");
        p = a.data();
        scalar = a.size() == 1;
    }
    std::size_t size() const { return std::size_t(a.size()); }
    T operator[](std::size_t k) const { return p[scalar ? 0 : k]; }
};
using FloatLane = Lane<float>;
using MaskLane = Lane<bool>;

template <class... L>
std::size_t common_size(const L&... lanes) {
    std::size_t n = 1;
    for (auto size_scalar : {std::make_pair(lanes.size(), lanes.scalar)...})
        if (!size_scalar.second) {
            const std::size_t size = size_scalar.first;
            if (n != 1 && size != n)
                throw InputError("plugin arrays: lengths " + std::to_string(n) + " and " +
                                 std::to_string(size) + " differ");
            n = size;
        }
    return n;
}

// Pointer to the float32 output array `h` (1-D, contiguous, writable, n
// values): the plugin passes views of Dr.Jit arrays so that the results land
// in Dr.Jit's own (reused) memory.
float* out_ptr(const py::handle& h, std::size_t n, const char* what) {
    py::array a = h.cast<py::array>();
    if (!a.dtype().is(py::dtype::of<float>()) || a.ndim() != 1 || std::size_t(a.shape(0)) != n ||
        !(a.flags() & py::array::c_style) || !a.writeable())
        throw InputError(std::string("plugin kernel: output '") + what +
                         "' must be a writable contiguous float32 array of " +
                         std::to_string(n) + " values");
    return static_cast<float*>(a.mutable_data());
}

// A direction from three lanes; false for a zero or non-finite vector
// (Dr.Jit's inactive lanes), which becomes +z.
bool direction_at(const FloatLane& x, const FloatLane& y, const FloatLane& z, std::size_t k,
                  Vec3& w) {
    w = {x[k], y[k], z[k]};
    const double n2 = w.x * w.x + w.y * w.y + w.z * w.z;
    if (n2 > 0 && std::isfinite(n2)) return true;
    w = {0, 0, 1};
    return false;
}

template <class Lane3>
void PluginKernel::eval_lane(bool ok, const Vec3& wi, const Lane3& ox, const Lane3& oy, const Lane3& oz,
                             const double p[3], std::size_t k, float* const* out) const {
    Vec3 wo;
    ok = ok && direction_at(ox, oy, oz, k, wo);
    ok = ok && (lit_from_below || wi.z > 0) && (transmits || wo.z > 0);
    if (out[0]) {
        double v[3] = {0, 0, 0};
        if (ok) f_rgb(wi, wo, p, v);
        const double c = std::fabs(wo.z);
        for (int ch = 0; ch < 3; ++ch) out[ch][k] = float(v[ch] * c);
    }
    if (out[3]) out[3][k] = ok ? float(sampler->pdf(wi, wo)) : 0.0f;
}

// The output arrays of a _PluginKernel call: the caller's (`out`, a tuple
// of float32 views of Dr.Jit arrays, None where a result is not wanted) or,
// when `out` is None, one new (slots, n) float32 array whose rows are
// returned.  ptr[i] is null for a result not wanted.
struct Outputs {
    bool given;
    py::array_t<float> own;
    std::vector<float*> ptr;
    std::vector<bool> want;

    Outputs(const py::object& out, std::size_t n, std::size_t slots, const bool* wants,
            std::initializer_list<const char*> names)
        : given(!out.is_none()), ptr(slots, nullptr), want(wants, wants + slots) {
        const std::vector<const char*> name(names);
        if (given) {
            const py::tuple o = out.cast<py::tuple>();
            if (o.size() != slots)
                throw InputError("plugin kernel: out needs " + std::to_string(slots) + " arrays");
            for (std::size_t i = 0; i < slots; ++i)
                if (want[i]) ptr[i] = out_ptr(o[i], n, name[i]);
            return;
        }
        own = py::array_t<float>({py::ssize_t(slots), py::ssize_t(n)});
        for (std::size_t i = 0; i < slots; ++i)
            if (want[i]) ptr[i] = own.mutable_data() + i * n;
    }

    // Rows first .. first + count - 1 of the own array ((count, n), or (n,)
    // for one row), or None when `out` was given or the result not wanted.
    py::object result(std::initializer_list<std::size_t> rows, std::size_t count) const {
        const std::size_t first = *rows.begin();
        if (given || !want[first]) return py::none();
        const py::ssize_t n = own.shape(1);
        const py::ssize_t item = py::ssize_t(sizeof(float));
        if (count == 1)
            return py::array(py::dtype::of<float>(), {n}, {item}, own.data() + first * n, own);
        return py::array(py::dtype::of<float>(), {py::ssize_t(count), n}, {n * item, item},
                         own.data() + first * n, own);
    }
};
}  // namespace

PYBIND11_MODULE(_brdftab, m) {
    m.doc() = "brdftab tables from Python: interpolation, direction-level evaluation and "
              "importance sampling (the renderer-side library, host/lookup/lookup.h)";

    // Exceptions: Error(RuntimeError) and InputError(Error, ValueError).
    static py::handle error_type = PyErr_NewException("brdftab.Error", PyExc_RuntimeError, nullptr);
    py::tuple input_bases = py::make_tuple(error_type, py::handle(PyExc_ValueError));
    static py::handle input_error_type =
        PyErr_NewException("brdftab.InputError", input_bases.ptr(), nullptr);
    m.attr("Error") = error_type;
    m.attr("InputError") = input_error_type;
    py::register_exception_translator([](std::exception_ptr p) {
        try {
            if (p) std::rethrow_exception(p);
        } catch (const InputError& e) {
            PyErr_SetString(input_error_type.ptr(), e.what());
        } catch (const Error& e) {
            PyErr_SetString(error_type.ptr(), e.what());
        }
    });

    m.def("table_names", &list_tables, py::arg("path"),
          "names of the tables (HDF5 groups) in a brdftab file, in name order");
    m.def("file_attributes",
          [](const std::string& path) { return json_to_python(read_file_attributes(path)); },
          py::arg("path"), "file-level attributes (version, spec, creation time) as a dict");


    m.def("set_threads", [](unsigned n) { g_threads = n; }, py::arg("n"),
          "threads of the batch calls (0: one per hardware thread, the default)");
    m.def("threads", &thread_count, "threads the batch calls use");


    // The plugin kernel's methods take Dr.Jit's arrays as numpy arrays (one
    // per component, length n or 1).  `out` is None (the results come back
    // as new float32 numpy arrays) or a tuple of writable float32 arrays of
    // n values, views of Dr.Jit arrays, which the results go into (None is
    // returned in their place):
    //   eval_pdf: (f_r, f_g, f_b, pdf), None where not wanted;
    //   sample: (wo_x, wo_y, wo_z, pdf, w_r, w_g, w_b).
    // f is f |cos theta_o|; a sample's weight is f |cos theta_o| / pdf.
    // Inactive and invalid lanes get f = pdf = weight = 0 (a sample's wo is
    // then +z), so pdf > 0 tells a valid sample.
    py::class_<PluginKernel>(m, "_PluginKernel")
        .def(py::init([](py::object single, py::list terms, std::vector<double> num,
                         std::vector<double> den, py::object sampler, bool lit_from_below,
                         bool transmits) {
                 PluginKernel k;
                 if (!single.is_none()) k.single = single.cast<const PyBound&>().bound;
                 for (auto item : terms) {
                     auto pair = item.cast<py::tuple>();
                     k.terms.push_back(pair[0].cast<const PyBound&>().bound);
                     k.coeffs.push_back(pair[1].cast<std::vector<double>>());
                 }
                 if (!k.single && (k.terms.empty() || k.terms.size() > 8))
                     throw InputError("plugin kernel: one bound table or 1 to 8 terms");
                 k.num = num;
                 k.den = den;
                 if (!sampler.is_none()) k.sampler = sampler.cast<const PyBound&>().bound;
                 k.lit_from_below = lit_from_below;
                 k.transmits = transmits;
                 return k;
             }),
             py::arg("single"), py::arg("terms"), py::arg("num"), py::arg("den"),
             py::arg("sampler"), py::arg("lit_from_below"), py::arg("transmits"))
        .def("eval_pdf",
             [](const PluginKernel& pk, const py::array& wix, const py::array& wiy,
                const py::array& wiz, const py::array& wox, const py::array& woy,
                const py::array& woz, const py::array& pr, const py::array& pg,
                const py::array& pb, const py::array& active_in, bool want_f, bool want_pdf,
                const py::object& out) -> py::tuple {
                 // Returns (f as a (3, n) array or None, pdf (n,) or None).
                 const FloatLane ix(wix, "wi.x"), iy(wiy, "wi.y"), iz(wiz, "wi.z"),
                     ox(wox, "wo.x"), oy(woy, "wo.y"), oz(woz, "wo.z"), r(pr, "p.r"),
                     g(pg, "p.g"), b(pb, "p.b");
                 const MaskLane active(active_in, "active");
                 const std::size_t n = common_size(ix, iy, iz, ox, oy, oz, r, g, b, active);
                 if (want_pdf && !pk.sampler) throw InputError("plugin kernel: no sampler");
                 const bool wants[4] = {want_f, want_f, want_f, want_pdf};
                 Outputs o(out, n, 4, wants, {"f_r", "f_g", "f_b", "pdf"});
                 {
                     py::gil_scoped_release release;
                     parallel_for(n, [&](std::size_t a, std::size_t e) {
                         for (std::size_t k = a; k < e; ++k) {
                             Vec3 wi;
                             const bool ok = active[k] && direction_at(ix, iy, iz, k, wi);
                             const double p[3] = {r[k], g[k], b[k]};
                             pk.eval_lane(ok, wi, ox, oy, oz, p, k, o.ptr.data());
                         }
                     });
                 }
                 return py::make_tuple(o.result({0, 1, 2}, 3), o.result({3}, 1));
             })
        .def("sample",
             [](const PluginKernel& pk, const py::array& wix, const py::array& wiy,
                const py::array& wiz, const py::array& u1_in, const py::array& u2_in,
                const py::array& pr, const py::array& pg, const py::array& pb,
                const py::array& active_in, const py::object& out) -> py::tuple {
                 // Returns (wo (3, n), pdf (n,), weight (3, n)) or Nones.
                 const FloatLane ix(wix, "wi.x"), iy(wiy, "wi.y"), iz(wiz, "wi.z"),
                     u1(u1_in, "u.x"), u2(u2_in, "u.y"), r(pr, "p.r"), g(pg, "p.g"),
                     b(pb, "p.b");
                 const MaskLane active(active_in, "active");
                 const std::size_t n = common_size(ix, iy, iz, u1, u2, r, g, b, active);
                 if (!pk.sampler) throw InputError("plugin kernel: no sampler");
                 const bool wants[7] = {true, true, true, true, true, true, true};
                 Outputs o(out, n, 7, wants, {"wo_x", "wo_y", "wo_z", "pdf", "w_r", "w_g", "w_b"});
                 {
                     py::gil_scoped_release release;
                     parallel_for(n, [&](std::size_t a, std::size_t e) {
                         for (std::size_t k = a; k < e; ++k) {
                             Vec3 wi;
                             const bool ok = active[k] && direction_at(ix, iy, iz, k, wi);
                             const double p[3] = {r[k], g[k], b[k]};
                             pk.sample_lane(ok, wi, u1[k], u2[k], p, k, o.ptr.data());
                         }
                     });
                 }
                 return py::make_tuple(o.result({0, 1, 2}, 3), o.result({3}, 1), o.result({4, 5, 6}, 3));
             });

    py::class_<Axis>(m, "Axis", "one table axis: node placement in user units")
        .def_readonly("name", &Axis::name)
        .def_readonly("unit", &Axis::unit)
        .def_readonly("min", &Axis::min)
        .def_readonly("max", &Axis::max)
        .def_readonly("count", &Axis::count)
        .def_property_readonly("spacing", [](const Axis& a) { return std::string(spacing_name(a.spacing)); })
        .def_property_readonly("values",
                               [](const Axis& a) {
                                   return py::array_t<double>(py::ssize_t(a.values.size()),
                                                              a.values.data());
                               })
        .def("warp", &Axis::warp, py::arg("t"), "x(t): node k sits at t = k/(count-1)")
        .def("unwarp", &Axis::unwarp, py::arg("x"), "t(x), the coordinate interpolation acts on")
        .def("__repr__", [](const Axis& a) {
            return "Axis('" + a.name + "', [" + std::to_string(a.min) + ", " +
                   std::to_string(a.max) + "] " + a.unit + ", " + std::to_string(a.count) +
                   " nodes, " + spacing_name(a.spacing) + ")";
        });

    py::class_<PyTable>(m, "_Table")
        .def(py::init<const std::string&, const std::string&>(), py::arg("path"), py::arg("name"))
        .def_readonly("path", &PyTable::path)
        .def_property_readonly("name", [](const PyTable& t) { return t.lookup->table().name; })
        .def_property_readonly("model", [](const PyTable& t) { return t.lookup->model(); })
        .def_property_readonly("quantity", [](const PyTable& t) { return t.lookup->quantity(); })
        .def_property_readonly("units", [](const PyTable& t) { return t.lookup->units(); })
        .def_property_readonly("description",
                               [](const PyTable& t) { return t.lookup->table().description; })
        .def_property_readonly("parameters",
                               [](const PyTable& t) { return json_to_python(t.lookup->parameters()); })
        .def_property_readonly("axes", [](const PyTable& t) { return t.lookup->axes(); })
        .def_property_readonly("coordinate_names",
                               [](const PyTable& t) { return t.lookup->coordinate_names(); })
        .def_property_readonly("has_recombination",
                               [](const PyTable& t) { return t.lookup->has_recombination(); })
        .def_property_readonly("has_stderr", [](const PyTable& t) { return bool(t.stderr_table); })
        .def_property_readonly(
            "values",
            [](py::object self) {
                const PyTable& t = self.cast<const PyTable&>();
                return view(t.lookup->table().value, t.lookup->axes(), self);
            })
        .def_property_readonly(
            "stderr",
            [](py::object self) -> py::object {
                const PyTable& t = self.cast<const PyTable&>();
                const TableData& d = t.lookup->table();
                if (d.stderr_.size() != d.value.size()) return py::none();
                return view(d.stderr_, d.axes, self);
            })
        .def_property_readonly("provenance",
                               [](const PyTable& t) { return provenance_of(t.lookup->table()); })
        .def("_eval_columns", &PyTable::eval_columns_of, py::arg("columns"), py::arg("n"), py::arg("interpolation"),
             py::arg("out_of_range"), py::arg("of_stderr"),
             "values at n points (one float64 column per coordinate, n values or 1) and the clamp "
             "warnings' data: [(name, count, first, min, max)]")
        .def("_order",
             [](const PyTable& t, const std::vector<std::string>& names) {
                 // Which given name goes to each coordinate; unknown or missing
                 // names raise the library's message (as `brdftab query`).
                 std::map<std::string, double> probe;
                 for (std::size_t k = 0; k < names.size(); ++k) probe[names[k]] = double(k);
                 std::vector<std::size_t> order;
                 for (double k : t.lookup->ordered_coordinates(probe, "arguments"))
                     order.push_back(std::size_t(k));
                 return order;
             })
        .def_property_readonly("certificate",
                               [](const PyTable& t) { return certificate_of(t.path, t.lookup->table().name); })
        .def("_bind",
             [](const PyTable& t, const std::map<std::string, double>& params,
                const std::string& interp, const std::string& mode) {
                 return PyBound{std::make_shared<const BoundTable>(
                     t.lookup->bind(params, interpolation_of(interp), out_of_range_of(mode)))};
             });

    m.def("_is_adaptive", [](const std::string& path, const std::string& name) { return is_adaptive_table(path, name); },
          py::arg("path"), py::arg("name"), "whether a table is adaptive (docs/adaptive.md)");
    py::class_<PyAdaptive>(m, "_AdaptiveTable")
        .def(py::init<const std::string&, const std::string&>(), py::arg("path"), py::arg("name"))
        .def_readonly("path", &PyAdaptive::path)
        .def_property_readonly("name", [](const PyAdaptive& t) { return t.data().name; })
        .def_property_readonly("model", [](const PyAdaptive& t) { return t.data().model; })
        .def_property_readonly("quantity", [](const PyAdaptive& t) { return t.data().quantity; })
        .def_property_readonly("units", [](const PyAdaptive& t) { return t.data().units; })
        .def_property_readonly("description", [](const PyAdaptive& t) { return t.data().description; })
        .def_property_readonly("parameters", [](const PyAdaptive& t) { return json_to_python(t.data().parameters); })
        .def_property_readonly("axes", [](const PyAdaptive& t) { return t.data().axes; })
        .def_property_readonly("coordinate_names", &PyAdaptive::names)
        .def_property_readonly("has_recombination", [](const PyAdaptive&) { return false; })
        .def_property_readonly("has_stderr", [](const PyAdaptive& t) {
            return !t.data().stderr_.empty() && t.data().stderr_.size() == t.data().value.size();
        })
        .def_property_readonly("leaf_count", [](const PyAdaptive& t) { return t.table->layout.leaf_count(); })
        .def_property_readonly("patch_nodes", [](const PyAdaptive& t) { return t.table->layout.patch_nodes; })
        .def_property_readonly(
            "values",
            [](py::object self) {
                // One value per stored node (no tensor shape), read-only.
                const PyAdaptive& t = self.cast<const PyAdaptive&>();
                const std::vector<double>& v = t.data().value;
                py::array a(py::dtype::of<double>(), {py::ssize_t(v.size())}, {py::ssize_t(sizeof(double))}, v.data(), self);
                py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
                return a;
            })
        .def_property_readonly(
            "stderr",
            [](py::object self) -> py::object {
                const PyAdaptive& t = self.cast<const PyAdaptive&>();
                const std::vector<double>& v = t.data().stderr_;
                if (v.empty() || v.size() != t.data().value.size()) return py::none();
                py::array a(py::dtype::of<double>(), {py::ssize_t(v.size())}, {py::ssize_t(sizeof(double))}, v.data(), self);
                py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
                return a;
            })
        .def_property_readonly("provenance", [](const PyAdaptive& t) { return provenance_of(t.data()); })
        .def_property_readonly("certificate", [](const PyAdaptive& t) { return certificate_of(t.path, t.data().name); })
        .def("_eval_columns", &PyAdaptive::eval_columns_of, py::arg("columns"), py::arg("n"),
             py::arg("interpolation"), py::arg("out_of_range"), py::arg("of_stderr"))
        .def("_order", &PyAdaptive::order)
        .def("_bind",
             [](const PyAdaptive& t, const std::map<std::string, double>& params, const std::string& interp,
                const std::string& mode) {
                 if (interp != "linear") {
                     interpolation_of(interp);
                     throw InputError("table '" + t.data().name +
                                      "' is adaptive: its patches interpolate linearly only");
                 }
                 return PyBound{std::make_shared<const BoundTable>(
                     t.lookup->bind(params, Interpolation::Linear, out_of_range_of(mode)))};
             });

    py::class_<PyBound>(m, "_Bound")
        .def_property_readonly("can_sample", [](const PyBound& b) { return b.bound->can_sample(); })
        .def_property_readonly("sampling_error",
                               [](const PyBound& b) { return b.bound->sampling_error(); })
        .def("_eval",
             [](const PyBound& b, const py::array& wi_in, const py::array& wo_in) {
                 return pair_call(wi_in, wo_in, [&](const double* wi, const double* wo, std::size_t n, double* out) {
                     b.bound->eval_many(wi, wo, n, out);
                 });
             })
        .def("_pdf",
             [](const PyBound& b, const py::array& wi_in, const py::array& wo_in) {
                 return pair_call(wi_in, wo_in, [&](const double* wi, const double* wo, std::size_t n, double* out) {
                     b.bound->pdf_many(wi, wo, n, out);
                 });
             })
        .def("_sample", [](const PyBound& b, const py::array& wi_in, const py::array& u_in) {
            const DoubleArray wi = rows_of(wi_in, 3, "wi"), u = rows_of(u_in, 2, "u");
            const py::ssize_t n = wi.shape(0);
            if (u.shape(0) != n) throw InputError("wi and u: different numbers of rows");
            py::array_t<double> wo({n, py::ssize_t(3)});
            py::array_t<double> weight(n), pdf(n), value(n);
            double *pw = wo.mutable_data(), *pweight = weight.mutable_data(),
                   *ppdf = pdf.mutable_data(), *pvalue = value.mutable_data();
            const double *pi = wi.data(), *pu = u.data();
            {
                py::gil_scoped_release release;
                parallel_for(std::size_t(n), [&](std::size_t a, std::size_t e) {
                    b.bound->sample_many(pi + 3 * a, pu + 2 * a, e - a, pw + 3 * a, ppdf + a, pvalue + a,
                                         pweight + a);
                });
            }
            return py::make_tuple(wo, weight, pdf, value);
        });
}
