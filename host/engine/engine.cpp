// engine.cpp — the host backends (serial reference and threaded), backend
// selection.  The estimation pipelines: estimate.cpp; the OpenCL backend:
// opencl_backend.cpp and host/engine/launch/.
#include "host/engine/engine.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <cmath>
#include <map>
#include <memory>
#include <mutex>
#include <new>
#include <thread>
#include <tuple>

#if defined(__linux__)
#include <sys/mman.h>
#endif

#include "kernels/common/estimator.h"
#include "host/core/error.h"
#include "host/core/text.h"
#include "host/engine/opencl_backend.h"

namespace brdftab {

const char* precision_name(Precision p) { return p == Precision::Double ? "double" : "float"; }

Precision parse_precision(const std::string& s) {
    if (s == "double") return Precision::Double;
    if (s == "float") return Precision::Float;
    throw InputError("precision '" + s + "' is not valid; allowed: double, float");
}

void check_settings(const IntegrationSettings& s) {
    auto out_of_range = [](const char* name, const std::string& value, const std::string& range) {
        throw InputError(std::string(name) + " " + value + " is out of range; allowed: " + range);
    };
    if (s.samples > kMaxSampleCount)
        out_of_range("samples", std::to_string(s.samples), sample_count_range_text());
    if (s.max_samples < 1 || s.max_samples > kMaxSampleCount)
        out_of_range("max_samples", std::to_string(s.max_samples), sample_count_range_text());
    if (!(s.tolerance == 0 || (s.tolerance > 0 && s.tolerance < 1)))
        out_of_range("tolerance", number_text(s.tolerance), "(0, 1)");
    if (!(s.abs_floor > 0) || !std::isfinite(s.abs_floor))
        out_of_range("abs_floor", number_text(s.abs_floor), "> 0");
}

namespace {

// ------------------------------------------------------------ host backend

// Work items [begin, end) of a launch on the host: the very same kernel math,
// compiled as C++, one work item after another.
void run_host_items(const BatchLaunch& l, std::size_t begin, std::size_t end, double* mean,
                    double* m2) {
    int opts[BT_MAX_OPTIONS] = {0};
    for (std::size_t k = 0; k < l.options.size() && k < BT_MAX_OPTIONS; ++k)
        opts[k] = l.options[k];
    REAL point[BT_MAX_POINT] = {0};
    for (std::size_t w = begin; w < end; ++w) {
        std::copy_n(&l.points[w * l.stride], l.stride, point);
        bt_estimate_batch(l.model->host_fn, point, opts, l.quantity, l.method, l.key0, l.key1,
                          l.cells[w], l.batches[w], l.batch_size, &mean[w], &m2[w]);
    }
}

// Work items per launch of the host backends (per thread for the threaded
// one): launches only pace the progress reports there (a launch has no
// overhead to amortise), and results do not depend on it; not tuned.
constexpr std::size_t kHostPreferredSlab = std::size_t{1} << 14;

// Serial C++ evaluation of the very same kernel math: the reference path.
class HostBackend final : public Backend {
public:
    std::string device_name() const override { return "host"; }
    Precision precision() const override { return Precision::Double; }
    std::size_t preferred_slab() const override { return kHostPreferredSlab; }

    void run(const BatchLaunch& l, std::vector<double>& mean,
             std::vector<double>& m2) override {
        const std::size_t n = l.cells.size();
        if (!l.mean_out) mean.resize(n);  // every entry is written
        m2.resize(n);
        run_host_items(l, 0, n, l.mean_out ? l.mean_out : mean.data(), m2.data());
    }
};

// The host path on every core: the launch's work items split into one
// contiguous range per thread.  Each work item is computed exactly as by the
// serial backend (same function, same inputs, its own accumulators), so the
// results are bit-identical to --device host whatever the thread count.
class ThreadedHostBackend final : public Backend {
public:
    explicit ThreadedHostBackend(unsigned threads) : threads_(std::max(1u, threads)) {}
    std::string device_name() const override {
        return "host-threads (" + std::to_string(threads_) + " threads)";
    }
    Precision precision() const override { return Precision::Double; }
    std::size_t preferred_slab() const override { return kHostPreferredSlab * threads_; }

    void run(const BatchLaunch& l, std::vector<double>& mean,
             std::vector<double>& m2) override {
        const std::size_t n = l.cells.size();
        if (!l.mean_out) mean.assign(n, 0.0);
        m2.assign(n, 0.0);
        double* const mean_out = l.mean_out ? l.mean_out : mean.data();
        const std::size_t parts = std::min<std::size_t>(threads_, n);
        if (parts <= 1) {
            run_host_items(l, 0, n, mean_out, m2.data());
            return;
        }
        std::vector<std::thread> pool;
        std::vector<std::exception_ptr> errors(parts);
        for (std::size_t t = 0; t < parts; ++t) {
            const std::size_t begin = n * t / parts, end = n * (t + 1) / parts;
            pool.emplace_back([&, t, begin, end] {
                try {
                    run_host_items(l, begin, end, mean_out, m2.data());
                } catch (...) {
                    errors[t] = std::current_exception();
                }
            });
        }
        for (auto& th : pool) th.join();
        for (auto& e : errors)
            if (e) std::rethrow_exception(e);
    }

private:
    unsigned threads_;
};

}  // namespace

std::unique_ptr<Backend> make_backend(const std::string& device_selector, Precision precision,
                                      const std::string& kernel_dir, const EngineTuning& tuning) {
    if (device_selector == "host") {
        if (precision != Precision::Double)
            throw InputError("--device host computes in double only; drop --precision float");
        return std::make_unique<HostBackend>();
    }
    const std::string threaded = "host-threads";
    if (device_selector.compare(0, threaded.size(), threaded) == 0) {
        const std::string rest = device_selector.substr(threaded.size());
        unsigned threads = std::max(1u, std::thread::hardware_concurrency());
        if (!rest.empty()) {
            const bool digits = rest.size() >= 2 && rest.size() <= 5 && rest[0] == ':' &&
                                rest.find_first_not_of("0123456789", 1) == std::string::npos;
            const long n = digits ? std::stol(rest.substr(1)) : 0;
            if (n < 1 || n > 1024)
                throw InputError("device '" + device_selector +
                                 "' is not valid; use host-threads or host-threads:N with N in "
                                 "[1, 1024]");
            threads = static_cast<unsigned>(n);
        }
        if (precision != Precision::Double)
            throw InputError("--device " + device_selector +
                             " computes in double only; drop --precision float");
        return std::make_unique<ThreadedHostBackend>(threads);
    }
    return make_opencl_backend(select_device(device_selector), precision, kernel_dir, tuning);
}

}  // namespace brdftab
