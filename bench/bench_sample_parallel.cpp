// bench_sample_parallel — the usual Monte Carlo kernel (one work item loops
// over a batch's samples) against the sample-parallel pair (one work item per
// sample, then a reduce kernel), same cells, same samples, on the OpenCL
// device (docs/benchmarks.md, "Sample-parallel launches").
//
//   build/bench/bench_sample_parallel [MODEL QUANTITY METHOD [CELLS SAMPLES]]...
//
// Without arguments it runs the sampled quantities of `brdftab bench` by MC and RQMC.  For each case it
// alternates the two paths (EngineTuning::sample_parallel Off / On) three times after a
// warm-up that builds both programs, and prints the median samples per
// second of wall time and per CPU-second of the process, the load average,
// and whether both paths gave the same bits (they must).
// BENCH_KERNEL_DIR=DIR: kernel sources from DIR (a copy of kernels/ with
// edits) instead of the embedded ones.
// BENCH_OPTIONS='{"distribution": "beckmann"}': the models' options (JSON,
// default: every option at its default).
// BENCH_PARAMETERS='{"alpha": 0.5}': parameter values for every cell (JSON;
// default: the model's defaults, parameters without one mid-range).
// BENCH_SAMPLE_PARALLEL_ONLY=1: run each case once, sample-parallel only, no
// timings (to read PoCL's vectoriser remarks of that program alone).
#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <string>
#include <vector>
#include <time.h>

#include "host/engine/engine.h"
#include "host/models/registry.h"

using namespace brdftab;

namespace {

struct Case {
    std::string model, quantity;
    Method method;
    std::size_t cells;
    std::uint64_t samples;
};

double cpu_seconds() {
    timespec t{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

double load_average() {
    std::ifstream in("/proc/loadavg");
    double l = -1;
    in >> l;
    return l;
}

double median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v.empty() ? 0 : v[v.size() / 2];
}

Method method_from_text(const std::string& s) {
    if (s == "mc") return Method::MonteCarlo;
    if (s == "rqmc") return Method::Rqmc;
    std::fprintf(stderr, "method '%s': use mc or rqmc\n", s.c_str());
    std::exit(2);
}

}  // namespace

int main(int argc, char** argv) {
    std::vector<Case> cases;
    for (int a = 1; a + 2 < argc;) {
        Case c{argv[a], argv[a + 1], method_from_text(argv[a + 2]), 1024, 1024};
        a += 3;
        if (a + 1 < argc && std::isdigit(static_cast<unsigned char>(argv[a][0]))) {
            c.cells = std::strtoul(argv[a], nullptr, 10);
            c.samples = std::strtoull(argv[a + 1], nullptr, 10);
            a += 2;
        }
        cases.push_back(c);
    }
    if (cases.empty())
        cases = {{"rough-dielectric", "albedo_r", Method::Rqmc, 1024, 1024},
                 {"rough-dielectric", "albedo_r", Method::MonteCarlo, 1024, 1024},
                 {"rough-dielectric", "albedo_t", Method::Rqmc, 1024, 1024},
                 {"rough-dielectric", "albedo_t", Method::MonteCarlo, 1024, 1024},
                 {"interfaced-lambertian", "body", Method::Rqmc, 512, 256},
                 {"interfaced-lambertian", "body", Method::MonteCarlo, 512, 256},
                 {"interfaced-lambertian", "vcavity", Method::Rqmc, 512, 256},
                 {"interfaced-lambertian", "vcavity", Method::MonteCarlo, 512, 256},
                 {"lambert-sphere", "brdf_mc", Method::MonteCarlo, 256, 128},
                 {"lambert-sphere", "brdf_mc", Method::Rqmc, 256, 128},
                 {"micrograin", "brdf", Method::Rqmc, 512, 512},
                 {"micrograin", "brdf", Method::MonteCarlo, 512, 512}};
    // BENCH_KERNEL_DIR: kernels read from that directory instead of the
    // embedded ones (experiments with edited kernel headers).
    const char* kernel_dir = std::getenv("BENCH_KERNEL_DIR");
    auto device = make_backend("", Precision::Double, kernel_dir ? kernel_dir : "");
    std::printf("device: %s; load average %.2f\n", device->device_name().c_str(), load_average());
    std::printf("%-22s %-9s %-5s %6s %6s | %-12s %-12s | %-12s %-12s | %6s %s\n", "model",
                "quantity", "meth", "cells", "smpl", "usual /s", "usual /CPU-s", "sp /s",
                "sp /CPU-s", "ratio", "bits");
    for (const Case& c : cases) {
        const ModelInfo& m = find_model(c.model);
        const QuantityInfo& q = m.quantity(c.quantity);
        const char* options_text = std::getenv("BENCH_OPTIONS");
        const std::vector<int> options = resolve_options(
            m, options_text ? nlohmann::json::parse(options_text) : nlohmann::json::object(),
            "BENCH_OPTIONS");
        PointBuilder builder(m, q);
        std::vector<std::vector<double>> points(c.cells, std::vector<double>(m.point_stride()));
        for (std::size_t k = 0; k < c.cells; ++k) {
            std::map<std::string, double> v;
            auto frac = [&](double g) {
                const double x = static_cast<double>(k + 1) * g;
                return x - static_cast<double>(static_cast<long long>(x));
            };
            for (const auto& d : q.directions) {
                if (d == "theta_i") v["theta_i"] = 89.0 * frac(0.7548776662466927);
                if (d == "theta_o") v["theta_o"] = 89.0 * frac(0.5698402909980532);
                if (d == "phi_o") v["phi_d"] = 360.0 * frac(0.6180339887498949) - 180.0;
            }
            for (const auto& p : m.parameters)
                if (!p.default_value) v[p.name] = 0.5 * (p.min + std::min(p.max, p.min + 2.0));
            if (const char* params = std::getenv("BENCH_PARAMETERS")) {
                const nlohmann::json given = nlohmann::json::parse(params);
                for (auto it = given.begin(); it != given.end(); ++it) v[it.key()] = it->get<double>();
            }
            builder.build(v, points[k].data());
        }
        IntegrationSettings s;
        s.method = c.method;
        s.samples = c.samples;
        auto run = [&](bool sp, std::size_t cells, double& wall, double& cpu) {
            EngineTuning tuning = device->tuning();
            tuning.sample_parallel = sp ? LaunchChoice::On : LaunchChoice::Off;
            device->set_tuning(tuning);
            const double c0 = cpu_seconds();
            const auto t0 = std::chrono::steady_clock::now();
            EstimateResult r = estimate(
                *device, m, q, options, cells,
                [&](std::size_t cell, double* out) {
                    std::copy(points[cell].begin(), points[cell].end(), out);
                },
                s);
            wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            cpu = cpu_seconds() - c0;
            return r;
        };
        double w, u;
        if (std::getenv("BENCH_SAMPLE_PARALLEL_ONLY")) {
            // One small sample-parallel run and nothing else: for
            // POCL_VECTORIZER_REMARKS=1, whose remarks name no kernel.
            run(true, c.cells, w, u);
            continue;
        }
        run(false, 64, w, u);  // warm-up: builds both programs
        run(true, 64, w, u);
        std::vector<double> wall[2], cpu[2];
        EstimateResult result[2];
        for (int rep = 0; rep < 3; ++rep)
            for (int sp = 0; sp < 2; ++sp) {
                result[sp] = run(sp == 1, c.cells, w, u);
                const double n = static_cast<double>(result[sp].total_samples);
                wall[sp].push_back(n / w);
                cpu[sp].push_back(n / u);
            }
        const bool same = result[0].value == result[1].value &&
                          result[0].stderr_ == result[1].stderr_ &&
                          result[0].samples == result[1].samples;
        std::printf("%-22s %-9s %-5s %6zu %6llu | %-12.4g %-12.4g | %-12.4g %-12.4g | %6.2f %s\n",
                    c.model.c_str(), c.quantity.c_str(), to_string(c.method).c_str(), c.cells,
                    static_cast<unsigned long long>(c.samples), median(wall[0]), median(cpu[0]),
                    median(wall[1]), median(cpu[1]), median(cpu[1]) / median(cpu[0]),
                    same ? "identical" : "DIFFERENT");
        std::fflush(stdout);
    }
    std::printf("load average at the end %.2f\n", load_average());
    return 0;
}
