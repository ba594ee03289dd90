// bench_engine_closed_form — the engine's own cost on a closed form: one
// estimate() over N rough-dielectric bsdf cells on one backend, timed in wall
// and process CPU seconds, through the direct path (no checkpoint) and
// through the general per-cell-state path (a checkpoint whose save does
// nothing, as `brdftab generate` passes one).  docs/benchmarks.md, "Closed
// forms: the engine's host work".
//
//   build/bench/bench_engine_closed_form [cells=2000000] [repeats=5] [device] [paths=both]
//                                        [feed=span]
//
// paths: `direct`, `general` or `both` (e.g. `direct` alone under a profiler).
// feed: how estimate() gets the points, held in one array: `span` copies a
// span of cells per call (PointsFn, as `brdftab bench` does), `cell` one
// cell per call (PointFn).
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>
#include <vector>

#include "host/engine/engine.h"
#include "host/models/registry.h"

using namespace brdftab;

namespace {
double cpu_seconds() {
    timespec t{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}
}  // namespace

int main(int argc, char** argv) {
    const std::size_t cells = argc > 1 ? std::strtoull(argv[1], nullptr, 10) : 2000000;
    const int repeats = argc > 2 ? std::atoi(argv[2]) : 5;
    const std::string device = argc > 3 ? argv[3] : "";
    const std::string paths = argc > 4 ? argv[4] : "both";
    const std::string feed = argc > 5 ? argv[5] : "span";
    if (cells == 0 || repeats < 1 || (paths != "both" && paths != "direct" && paths != "general") ||
        (feed != "span" && feed != "cell")) {
        std::fprintf(stderr,
                     "usage: bench_engine_closed_form [cells >= 1] [repeats >= 1] [device] "
                     "[direct|general|both] [span|cell]\n");
        return 2;
    }
    const ModelInfo& model = find_model("rough-dielectric");
    const QuantityInfo& q = model.quantity("bsdf");
    const std::vector<int> options = resolve_options(model, nlohmann::json::object(), "");
    const std::size_t stride = model.point_stride();
    // Directions spread by additive recurrences (as `brdftab bench`), alpha
    // and eta fixed: theta_o over both hemispheres.
    std::vector<double> first(stride);
    PointBuilder(model, q).build(
        {{"theta_i", 10}, {"theta_o", 20}, {"phi_d", 30}, {"alpha", 0.3}, {"eta", 1.5}},
        first.data());
    std::vector<double> points(cells * stride);
    constexpr double kDegToRad = 3.14159265358979323846 / 180.0;
    for (std::size_t k = 0; k < cells; ++k) {
        auto frac = [&](double g) {
            const double x = static_cast<double>(k + 1) * g;
            return x - std::floor(x);
        };
        double* p = &points[k * stride];
        std::copy(first.begin(), first.end(), p);
        p[0] = 89.0 * frac(0.7548776662466927) * kDegToRad;
        p[2] = 179.0 * frac(0.5698402909980532) * kDegToRad;
        p[3] = p[1] + (360.0 * frac(0.6180339887498949) - 180.0) * kDegToRad;
    }
    auto backend = make_backend(device, Precision::Double);
    const IntegrationSettings settings;
    const PointFn point_of = [&](std::size_t c, double* out) {
        std::copy_n(&points[c * stride], stride, out);
    };
    const PointsFn points_of = [&](std::size_t first, std::size_t count, double* out) {
        std::copy_n(points.data() + first * stride, count * stride, out);
    };
    auto run = [&](std::size_t n, EstimateCheckpoint* checkpoint) {
        return feed == "span"
                   ? estimate(*backend, model, q, options, n, points_of, settings, nullptr, checkpoint)
                   : estimate(*backend, model, q, options, n, point_of, settings, nullptr, checkpoint);
    };
    run(std::min<std::size_t>(cells, 256), nullptr);
    std::printf("%s, %zu cells of rough-dielectric bsdf, points by %s\n",
                backend->device_name().c_str(), cells, feed.c_str());
    for (const bool with_checkpoint : {false, true}) {
        if (paths != "both" && with_checkpoint != (paths == "general")) continue;
        for (int r = 0; r < repeats; ++r) {
            EstimateCheckpoint checkpoint;
            checkpoint.save = [](const EstimateState&, bool) {};
            const double cpu0 = cpu_seconds();
            const auto t0 = std::chrono::steady_clock::now();
            const EstimateResult result = run(cells, with_checkpoint ? &checkpoint : nullptr);
            const double wall =
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            const double cpu = cpu_seconds() - cpu0;
            const double evals = static_cast<double>(result.total_samples);
            std::printf("%-26s wall %.3f s  cpu %.3f s  %6.2f M evals/s  %6.2f M evals/CPU-s\n",
                        with_checkpoint ? "general (checkpoint)" : "direct (no checkpoint)", wall,
                        cpu, evals / wall / 1e6, evals / cpu / 1e6);
        }
    }
    return 0;
}
