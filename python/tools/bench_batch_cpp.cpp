// bench_batch_cpp — the C++ side of python/tools/bench_batch.py: the same
// four batch calls of the lookup library (host/lookup/lookup.h) on the same
// points, one thread, points per CPU-second (best of three), so that the
// Python module's overhead per call is the ratio of the two rates.
//
//   cmake --build build --target bt_bench_batch_cpp
//   build/python/bt_bench_batch_cpp on.h5 brdf_direct [N]
//
// The points are Weyl sequences, computed as bench_batch.py computes them:
// coordinate j of point k is frac((k + 1) * a_j), a_j the fractional part
// of sqrt of the j-th prime, scaled to each range.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <string>
#include <vector>

#include "host/lookup/lookup.h"

using namespace brdftab;

namespace {

double weyl(std::size_t k, int j) {
    static const double primes[] = {2, 3, 5, 7, 11, 13, 17, 19};
    const double a = std::sqrt(primes[j]) - std::floor(std::sqrt(primes[j]));
    const double x = double(k + 1) * a;
    return x - std::floor(x);
}

double cpu_seconds() {
    timespec t;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

template <class F>
double rate(std::size_t n, const F& call) {
    double best = 1e300;
    for (int r = 0; r < 3; ++r) {
        const double c = cpu_seconds();
        call();
        best = std::min(best, cpu_seconds() - c);
    }
    return double(n) / best / 1e6;
}

Vec3 direction(double theta_deg, double phi_deg) {
    const double t = theta_deg * M_PI / 180, p = phi_deg * M_PI / 180;
    return {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 3) {
        std::fprintf(stderr, "usage: bt_bench_batch_cpp FILE TABLE [N]\n");
        return 2;
    }
    try {
        const std::size_t n = argc > 3 ? std::stoul(argv[3]) : 1000000;
        const LookupTable table = LookupTable::open(argv[1], argv[2]);
        const BoundTable bound = table.bind();
        const std::size_t dims = table.axes().size();
        std::vector<double> coords(n * dims), wi(3 * n), wo(3 * n), u(2 * n);
        for (std::size_t k = 0; k < n; ++k) {
            for (std::size_t d = 0; d < dims; ++d) {
                const Axis& a = table.axes()[d];
                coords[k * dims + d] = a.min + (a.max - a.min) * weyl(k, int(d));
            }
            const Vec3 i = direction(85 * weyl(k, 3), 0), o = direction(90 * weyl(k, 4), 360 * weyl(k, 5));
            wi[3 * k] = i.x, wi[3 * k + 1] = i.y, wi[3 * k + 2] = i.z;
            wo[3 * k] = o.x, wo[3 * k + 1] = o.y, wo[3 * k + 2] = o.z;
            u[2 * k] = weyl(k, 6), u[2 * k + 1] = weyl(k, 7);
        }
        std::vector<double> out(n), pdf(n), value(n), weight(n), wos(3 * n);
        std::printf("%s table %s, %zu points per call, 1 thread, C++ batch calls\n", argv[1], argv[2], n);
        std::printf("  %-28s %6.2f M/s per CPU-second\n", "LookupTable::eval_many",
                    rate(n, [&] { table.eval_many(coords.data(), n, out.data()); }));
        std::printf("  %-28s %6.2f M/s per CPU-second\n", "BoundTable::eval_many",
                    rate(n, [&] { bound.eval_many(wi.data(), wo.data(), n, out.data()); }));
        std::printf("  %-28s %6.2f M/s per CPU-second\n", "BoundTable::pdf_many",
                    rate(n, [&] { bound.pdf_many(wi.data(), wo.data(), n, out.data()); }));
        std::printf("  %-28s %6.2f M/s per CPU-second\n", "BoundTable::sample_many",
                    rate(n, [&] {
                        bound.sample_many(wi.data(), u.data(), n, wos.data(), pdf.data(), value.data(),
                                          weight.data());
                    }));
    } catch (const std::exception& e) {
        std::fprintf(stderr, "bt_bench_batch_cpp: error: %s\n", e.what());
        return 1;
    }
    return 0;
}
