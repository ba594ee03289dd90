// bench_lookup — throughput of the renderer-side lookup library.
//
// Builds in-memory tables of an analytic GGX reflection BRDF (written here,
// independent of the model kernels) and measures, per core (one thread, per
// second of its CPU time) and with all hardware threads (wall clock):
//   - LookupTable::eval at random coordinates, linear and cubic,
//   - BoundTable::eval(wi, wo) (direction-level, what a renderer calls),
//   - BoundTable::sample(wi, u1, u2) and BoundTable::pdf,
//   - the batch forms of the four (eval_many, BoundTable::eval_many,
//     sample_many, pdf_many) on blocks of 256 points,
// for a 3-D table (theta_i, theta_o, phi_d), an adaptive 3-D table of the
// same function with at most as many stored values (docs/adaptive.md; linear
// only) and a 5-D table (+ alpha, eta).  The last lines compare the adaptive
// table's linear rates with the tensor table's.
// Usage: bench_lookup [seconds per measurement, default 0.4]
#include <atomic>
#include <ctime>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <thread>
#include <vector>

#include "host/adaptive/adaptive_table.h"
#include "host/core/grid.h"
#include "host/lookup/lookup.h"
#include "host/core/table.h"

using namespace brdftab;

namespace {

constexpr double kPi = 3.14159265358979323846;

// GGX microfacet reflection (Walter et al. 2007, eqs. 20, 33-34) with the
// exact unpolarised dielectric Fresnel term and separable Smith G1.
double fresnel(double cos_i, double eta) {
    const double s2 = 1 - cos_i * cos_i;
    const double t2 = 1 - s2 / (eta * eta);
    if (t2 <= 0) return 1;
    const double ct = std::sqrt(t2);
    const double rs = (cos_i - eta * ct) / (cos_i + eta * ct);
    const double rp = (eta * cos_i - ct) / (eta * cos_i + ct);
    return 0.5 * (rs * rs + rp * rp);
}
double g1(double cos_v, double a2) {
    const double c2 = cos_v * cos_v;
    return 2 / (1 + std::sqrt(1 + a2 * (1 - c2) / c2));
}
double ggx_brdf(double ti, double to, double pd, double alpha, double eta) {
    const double d = kPi / 180;
    // Grazing directions: keep the 1/cos factors finite.
    const double ci = std::max(std::cos(ti * d), 1e-3), co = std::max(std::cos(to * d), 1e-3);
    const double si = std::sin(ti * d), so = std::sin(to * d);
    const double ix = si, iz = ci, ox = so * std::cos(pd * d), oy = so * std::sin(pd * d), oz = co;
    double hx = ix + ox, hy = oy, hz = iz + oz;
    const double hl = std::sqrt(hx * hx + hy * hy + hz * hz);
    hx /= hl, hy /= hl, hz /= hl;
    const double a2 = alpha * alpha;
    const double dd = 1 + (a2 - 1) * hz * hz;
    const double D = a2 / (kPi * dd * dd);
    const double cih = ix * hx + iz * hz;
    return fresnel(cih, eta) * D * g1(ci, a2) * g1(co, a2) / (4 * ci * co);
}

TableData make_table(bool five_d) {
    TableData t;
    t.name = "brdf";
    t.model = "bench-ggx";
    t.quantity = "brdf";
    t.units = "1/sr";
    t.axes.push_back(make_axis("theta_i", "deg", 0, 90, 31, Spacing::Linear));
    t.axes.push_back(make_axis("theta_o", "deg", 0, 90, 31, Spacing::Linear));
    t.axes.push_back(make_axis("phi_d", "deg", 0, 180, 37, Spacing::Linear));
    if (five_d) {
        t.axes.push_back(make_axis("alpha", "1", 0.1, 1.0, 8, Spacing::Log));
        t.axes.push_back(make_axis("eta", "1", 1.25, 2.5, 6, Spacing::Linear));
    }
    Grid grid(t.axes);
    t.value.resize(grid.cell_count());
    for (std::size_t c = 0; c < grid.cell_count(); ++c) {
        const auto x = grid.coordinates(c);
        t.value[c] = ggx_brdf(x[0], x[1], x[2], five_d ? x[3] : 0.3, five_d ? x[4] : 1.5);
    }
    t.method = Method::ClosedForm;
    return t;
}

// The 3-D function as an adaptive table: refined to 1e-3 absolute (or until
// it holds as many values as the tensor table has cells).
AdaptiveTable make_adaptive(std::size_t max_values) {
    const TableData grid = make_table(false);
    AdaptiveTable t;
    t.data = grid;
    t.data.value.clear();
    AdaptiveBuildOptions o;
    o.target = 1e-3;
    o.max_values = max_values;
    std::vector<double> stderrs;
    build_adaptive(
        3, o,
        [&](std::size_t count, const double* tp, double* v, double*) {
            for (std::size_t k = 0; k < count; ++k) {
                double x[3];
                t.to_x(tp + 3 * k, x);
                v[k] = ggx_brdf(x[0], x[1], x[2], 0.3, 1.5);
            }
        },
        false, t.layout, t.data.value, stderrs);
    return t;
}

struct Rng {  // splitmix64
    std::uint64_t s;
    double uniform() {
        std::uint64_t z = (s += 0x9E3779B97F4A7C15ull);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
        return ((z ^ (z >> 31)) >> 11) * (1.0 / 9007199254740992.0);
    }
};

double thread_cpu_seconds() {
    timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

// Runs body(thread, i) for i = 0, 1, ... on `threads` threads for about
// `seconds` of wall-clock time.  Returns calls per second of CPU time of
// the threads (summed over them: per core), and in `wall_rate` calls per
// second of wall-clock time (all threads together).  CPU time does not
// count the time the threads wait for a core on a loaded machine, so the
// per-core figure stays comparable under load; the wall-clock one does not.
double rate(int threads, double seconds, const std::function<double(int, std::size_t)>& body,
            double* wall_rate = nullptr) {
    std::atomic<bool> stop{false};
    std::vector<std::size_t> counts(threads, 0);
    std::vector<double> sinks(threads, 0), cpu(threads, 0);
    const auto t0 = std::chrono::steady_clock::now();
    std::vector<std::thread> pool;
    for (int t = 0; t < threads; ++t)
        pool.emplace_back([&, t] {
            std::size_t i = 0;
            double sink = 0;
            const double c0 = thread_cpu_seconds();
            while (!stop.load(std::memory_order_relaxed)) {
                for (int k = 0; k < 256; ++k, ++i) sink += body(t, i);
            }
            cpu[t] = thread_cpu_seconds() - c0;
            counts[t] = i;
            sinks[t] = sink;
        });
    std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
    stop = true;
    for (auto& th : pool) th.join();
    const double el = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::size_t total = 0;
    double s = 0, cpu_total = 0;
    for (int t = 0; t < threads; ++t) total += counts[t], s += sinks[t], cpu_total += cpu[t];
    if (s == 12345.678) std::printf(" ");  // keep the work observable
    if (wall_rate) *wall_rate = total / el;
    return total / cpu_total;
}

Vec3 dir(double theta_deg, double phi_deg) {
    const double d = kPi / 180;
    return {std::sin(theta_deg * d) * std::cos(phi_deg * d),
            std::sin(theta_deg * d) * std::sin(phi_deg * d), std::cos(theta_deg * d)};
}

// Per-core linear rates of eval(coords) and eval(wi, wo), for the summary.
struct Rates {
    double eval = 0, dirs = 0;
};

Rates bench(const char* label, const std::function<LookupTable()>& make, bool five_d, int threads,
            double seconds) {
    const auto tb0 = std::chrono::steady_clock::now();
    const LookupTable lt = make();
    const std::size_t dims = lt.axes().size();
    std::printf("\n%s table: ", label);
    for (const auto& a : lt.axes()) std::printf("%s(%zu) ", a.name.c_str(), a.count);
    if (lt.is_adaptive())
        std::printf("axes; adaptive, %zu leaves, %zu stored values", lt.adaptive()->layout.leaf_count(),
                    lt.table().value.size());
    else
        std::printf("= %zu cells", lt.table().value.size());
    std::printf(", built in %.2f s\n",
                std::chrono::duration<double>(std::chrono::steady_clock::now() - tb0).count());
    Rates rates;

    // Pre-drawn random inputs (the RNG is not part of the measurement).
    const std::size_t n = 1 << 16;
    Rng rng{five_d ? 11u : 7u};
    std::vector<double> coords(n * dims);
    std::vector<Vec3> wi(n), wo(n);
    std::vector<double> u(2 * n);
    for (std::size_t k = 0; k < n; ++k) {
        for (std::size_t a = 0; a < dims; ++a) {
            const Axis& ax = lt.axes()[a];
            coords[k * dims + a] = ax.min + (ax.max - ax.min) * rng.uniform();
        }
        wi[k] = dir(89 * rng.uniform(), 360 * rng.uniform());
        wo[k] = dir(89 * rng.uniform(), 360 * rng.uniform());
        u[2 * k] = rng.uniform();
        u[2 * k + 1] = rng.uniform();
    }
    std::vector<double> wi_rows(3 * n), wo_rows(3 * n);
    for (std::size_t k = 0; k < n; ++k) {
        const double a[3] = {wi[k].x, wi[k].y, wi[k].z}, b[3] = {wo[k].x, wo[k].y, wo[k].z};
        std::copy(a, a + 3, &wi_rows[3 * k]);
        std::copy(b, b + 3, &wo_rows[3 * k]);
    }
    const std::map<std::string, double> params =
        five_d ? std::map<std::string, double>{{"alpha", 0.3}, {"eta", 1.5}}
               : std::map<std::string, double>{};

    for (Interpolation interp : {Interpolation::Linear, Interpolation::Cubic}) {
        if (lt.is_adaptive() && interp == Interpolation::Cubic) continue;  // linear patches
        const char* name = interp == Interpolation::Linear ? "linear" : "cubic";
        // Each thread keeps its own coordinate vector (eval takes a vector).
        std::vector<std::vector<double>> scratch(threads, std::vector<double>(dims));
        auto eval_body = [&](int t, std::size_t i) {
            const double* c = &coords[(i & (n - 1)) * dims];
            std::copy(c, c + dims, scratch[t].begin());
            return lt.eval(scratch[t], interp);
        };
        const auto tb = std::chrono::steady_clock::now();
        const BoundTable bt = lt.bind(params, interp);
        const double bind_s =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - tb).count();
        auto dir_body = [&](int, std::size_t i) { return bt.eval(wi[i & (n - 1)], wo[i & (n - 1)]); };
        auto sample_body = [&](int, std::size_t i) {
            const std::size_t k = i & (n - 1);
            return bt.sample(wi[k], u[2 * k], u[2 * k + 1]).weight;
        };
        auto pdf_body = [&](int, std::size_t i) { return bt.pdf(wi[i & (n - 1)], wo[i & (n - 1)]); };

        // Batch calls: blocks of kBlock points, per-thread output buffers.
        constexpr std::size_t kBlock = 256;
        std::vector<std::vector<double>> outs(threads, std::vector<double>(3 * kBlock));
        auto block = [&](std::size_t i) { return (i * kBlock) & (n - 1); };
        auto eval_many_body = [&](int t, std::size_t i) {
            lt.eval_many(&coords[block(i) * dims], kBlock, outs[t].data(), interp);
            return outs[t][0];
        };
        auto dir_many_body = [&](int t, std::size_t i) {
            bt.eval_many(&wi_rows[3 * block(i)], &wo_rows[3 * block(i)], kBlock, outs[t].data());
            return outs[t][0];
        };
        auto sample_many_body = [&](int t, std::size_t i) {
            double* o = outs[t].data();
            bt.sample_many(&wi_rows[3 * block(i)], &u[2 * block(i)], kBlock, o, nullptr, nullptr,
                           o);
            return o[0];
        };
        auto pdf_many_body = [&](int t, std::size_t i) {
            bt.pdf_many(&wi_rows[3 * block(i)], &wo_rows[3 * block(i)], kBlock, outs[t].data());
            return outs[t][0];
        };

        std::printf("  %-6s bind %.3f s\n", name, bind_s);
        struct Item {
            const char* what;
            std::function<double(int, std::size_t)> body;
            std::size_t points;  // lookups per call of body
        } items[] = {{"eval(coords)", eval_body, 1},
                     {"eval(wi, wo)", dir_body, 1},
                     {"sample", sample_body, 1},
                     {"pdf", pdf_body, 1},
                     {"eval_many", eval_many_body, kBlock},
                     {"eval_many(w)", dir_many_body, kBlock},
                     {"sample_many", sample_many_body, kBlock},
                     {"pdf_many", pdf_many_body, kBlock}};
        for (const auto& it : items) {
            // Batch bodies do kBlock lookups per call: fewer calls per second.
            const double secs = seconds;
            double wall1 = 0, wall_all = 0;
            const double one = rate(1, secs, it.body, &wall1) * double(it.points);
            if (threads > 1) rate(threads, secs, it.body, &wall_all);
            else wall_all = wall1;
            std::printf("  %-6s %-13s %8.2f M/s per core (CPU time)  %8.2f M/s wall, %d threads\n",
                        name, it.what, one / 1e6, wall_all * double(it.points) / 1e6, threads);
            if (interp == Interpolation::Linear && it.body.target<decltype(eval_body)>()) rates.eval = one;
            if (interp == Interpolation::Linear && it.body.target<decltype(dir_body)>()) rates.dirs = one;
        }
        // Sanity: the mean sample weight estimates the directional albedo
        // (integral of f cos) averaged over the drawn wi.
        double mean_w = 0, mean_q = 0;
        const std::size_t m = 1 << 15;
        for (std::size_t k = 0; k < m; ++k) mean_w += bt.sample(wi[k], u[2 * k], u[2 * k + 1]).weight;
        // Independent estimate: uniform hemisphere sampling of f cos / (1/2pi).
        Rng r2{99};
        for (std::size_t k = 0; k < m; ++k) {
            const double mu = r2.uniform(), ph = 2 * kPi * r2.uniform();
            const double s = std::sqrt(1 - mu * mu);
            mean_q += bt.eval(wi[k], {s * std::cos(ph), s * std::sin(ph), mu}) * mu * 2 * kPi;
        }
        std::printf("  %-6s mean sample weight %.4f (uniform-hemisphere estimate %.4f)\n", name,
                    mean_w / m, mean_q / m);
    }
    return rates;
}

}  // namespace

int main(int argc, char** argv) {
    const double seconds = argc > 1 ? std::atof(argv[1]) : 0.4;
    const int threads = std::max(1u, std::thread::hardware_concurrency());
    std::printf("bench_lookup: GGX reflection tables (alpha = 0.3, eta = 1.5 for bind/sample), "
                "%.2f s per figure, %d hardware threads\n", seconds, threads);
    const std::size_t cells3 = make_table(false).value.size();
    const Rates tensor = bench("3-D", [] { return LookupTable(make_table(false)); }, false, threads, seconds);
    const Rates adaptive = bench(
        "3-D adaptive", [&] { return LookupTable(make_adaptive(cells3)); }, false, threads, seconds);
    bench("5-D", [] { return LookupTable(make_table(true)); }, true, threads, seconds);
    std::printf("\n3-D adaptive / tensor, linear, per core: eval(coords) %.2f M/s vs %.2f M/s (%.0f %%), "
                "eval(wi, wo) %.2f M/s vs %.2f M/s (%.0f %%)\n",
                adaptive.eval / 1e6, tensor.eval / 1e6, 100 * adaptive.eval / tensor.eval,
                adaptive.dirs / 1e6, tensor.dirs / 1e6, 100 * adaptive.dirs / tensor.dirs);
    return 0;
}
