// opencl_backend.cpp — the OpenCL device backend (opencl_backend.h).
#include "host/engine/opencl_backend.h"

#include <algorithm>
#include <deque>

#include "kernels/common/estimator.h"
#include "host/core/error.h"
#include "host/engine/launch/resources.h"

namespace brdftab {

namespace {

// Work items per launch the backend suggests (Backend::preferred_slab), the
// cap of estimate()'s growing launches: 2^17.  An albedo table of 64 x 64
// cells x 4096 MC samples measured the same time with the growing launches
// as with every launch at this size (docs/benchmarks.md, "Launch sizes and
// progress"); its buffers stay a few MB.
constexpr std::size_t kOpenCLPreferredSlab = std::size_t{1} << 17;

class OpenCLBackend final : public Backend {
public:
    OpenCLBackend(const DeviceInfo& device, Precision precision, std::string kernel_dir,
                  const EngineTuning& tuning)
        : r_(device, precision, std::move(kernel_dir), tuning),
          strategies_(launch::make_launch_strategies(r_)) {
        if (precision == Precision::Double && !device.has_fp64)
            throw InputError("device '" + device.name +
                             "' does not support double precision (cl_khr_fp64); use "
                             "--precision float");
    }
    std::string device_name() const override { return r_.runtime.device_info().name; }
    Precision precision() const override { return r_.precision; }
    std::size_t preferred_slab() const override { return kOpenCLPreferredSlab; }
    void set_tuning(const EngineTuning& tuning) override {
        r_.tuning = tuning;
        for (auto& s : strategies_) s->tuning_changed();
    }
    EngineTuning tuning() const override { return r_.tuning; }

    void run(const BatchLaunch& l, std::vector<double>& mean, std::vector<double>& m2) override {
        // A launch staged while another was unfinished is in the other
        // set's memory, which only start() switches to.
        if (l.staged && !unfinished_.empty())
            throw Error("OpenCL backend: run() of a launch staged for start()");
        while (!unfinished_.empty()) finish();
        enqueue_launch(l, mean, m2, nullptr);
    }

    // Overlapped launches (Backend::start): the writes, the kernel and the
    // reads of a launch are enqueued without blocking, on the buffer set the
    // unfinished launch (if any) does not use; finish() waits for the
    // oldest launch's last read.  Launches that stage data on the host
    // (float points, float accumulators) or whose strategy does not overlap
    // (LaunchStrategy::overlaps) run synchronously inside start() instead.
    void start(const BatchLaunch& l, std::vector<double>& mean, std::vector<double>& m2) override {
        if (unfinished_.size() >= 2)
            throw Error("OpenCL backend: start() with two launches unfinished");
        if (!overlaps(l)) {
            if (l.staged) throw Error("OpenCL backend: a staged launch that does not overlap");
            run(l, mean, m2);
            unfinished_.push_back(cl::Event());  // already complete
            return;
        }
        if (!unfinished_.empty()) r_.swap_buffer_sets();
        cl::Event done;
        enqueue_launch(l, mean, m2, &done);
        unfinished_.push_back(done);
    }

    void finish() override {
        if (unfinished_.empty()) return;
        cl::Event done = unfinished_.front();
        unfinished_.pop_front();
        if (!done()) return;
        try {
            done.wait();
        } catch (const cl::Error& e) {
            abandon();
            throw OpenCLError(e.what(), e.err(), "while waiting for a kernel launch");
        }
    }

    void abandon() noexcept override {
        try {
            r_.runtime.queue().finish();
        } catch (...) {
        }
        unfinished_.clear();
    }

    // The staged inputs live in host memory of the buffer set the launch
    // will use (start(): the active set when nothing is unfinished, else the
    // idle one), wrapped by CL_MEM_USE_HOST_PTR buffers.  On PoCL's CPU
    // device such a buffer's storage is that memory, and the write that
    // hands it over (enqueue_launch) is no copy: the caller's one copy of a
    // point into its work item's slot is the only one (a write from other
    // memory would be a second copy, PoCL's, of the whole launch).  The
    // memory is kept from launch to launch: no page faults after the first.
    bool stage(const BatchLaunch& l, std::size_t items, LaunchStaging& staging) override {
        if (items == 0 || unfinished_.size() >= 2 || !overlaps(l)) return false;
        launch::StagedInputs& target = unfinished_.empty() ? r_.staged : r_.idle_staged();
        try {
            // Never while a launch uses this set (start() alternates the sets).
            r_.reserve_staged(target, items, items * l.stride);
        } catch (const cl::Error& e) {
            throw OpenCLError(e.what(), e.err(), "while creating the launch's input buffers");
        }
        staging.points = static_cast<double*>(target.points_host.get());
        staging.cells = static_cast<std::uint32_t*>(target.cells_host.get());
        staging.batches = static_cast<std::uint32_t*>(target.batches_host.get());
        return true;
    }

private:
    // The first strategy that applies to `l` (the usual launch applies to all).
    launch::LaunchStrategy& first_applying(const BatchLaunch& l) const {
        for (const auto& s : strategies_)
            if (s->applies(l)) return *s;
        throw Error("OpenCL backend: no launch strategy applies");
    }

    // Whether start() enqueues this launch without blocking (and stage()
    // lends memory for it): double on a device with fp64, and a strategy
    // that overlaps.
    bool overlaps(const BatchLaunch& l) const {
        return r_.precision == Precision::Double && r_.runtime.device_info().has_fp64 &&
               first_applying(l).overlaps();
    }

    // The strategy that runs `l`: the first that applies and prepares.
    launch::LaunchStrategy& prepared_strategy(const BatchLaunch& l) {
        for (const auto& s : strategies_)
            if (s->applies(l) && s->prepare(l)) return *s;
        throw Error("OpenCL backend: no launch strategy runs this launch");
    }

    void write_inputs(const BatchLaunch& l, std::size_t n);
    void read_results(const BatchLaunch& l, std::size_t n, double* mean_out,
                      std::vector<double>& m2, cl::Event* done);

    // One launch's writes, kernels and reads on the active buffer set.  With
    // `done` null every call blocks until the results are in `mean`/`m2`;
    // otherwise nothing blocks and `done` is the event of the last read.
    void enqueue_launch(const BatchLaunch& l, std::vector<double>& mean, std::vector<double>& m2,
                        cl::Event* done) {
        const std::size_t n = l.work_items();
        // Every entry is overwritten by the read below: no zero-fill.
        if (!l.mean_out) mean.resize(n);
        if (l.need_m2 || !r_.accum_double()) m2.resize(n);  // else left as it is: never read
        if (n == 0) return;
        double* const mean_out = l.mean_out ? l.mean_out : mean.data();
        launch::LaunchStrategy& strategy = prepared_strategy(l);
        try {
            write_inputs(l, n);
            strategy.enqueue(l);
            read_results(l, n, mean_out, m2, done);
        } catch (const cl::Error& e) {
            // Writes may still be pending from the launch's memory, which the
            // caller frees after the throw: let them finish first.
            try {
                r_.runtime.queue().finish();
            } catch (const cl::Error&) {
            }
            unfinished_.clear();
            r_.options_known = false;
            throw OpenCLError(e.what(), e.err(),
                              "while running the kernel of model '" + l.model->name + "'");
        }
    }

    launch::LaunchResources r_;
    std::vector<std::unique_ptr<launch::LaunchStrategy>> strategies_;
    std::deque<cl::Event> unfinished_;       // start()ed launches, oldest first
    std::vector<float> points_f_, accum_f_;  // float precision staging
};

// The writes need not block: the in-order queue runs them before the
// kernels, and their sources (the launch, points_f_) are not touched before
// the blocking read at the end.
void OpenCLBackend::write_inputs(const BatchLaunch& l, std::size_t n) {
    cl::CommandQueue& queue = r_.runtime.queue();
    r_.reserve_buffers(n, l.points.size() * r_.real_size(), r_.accum_size());
    if (l.staged) {
        // From the buffers' own host memory (stage()): what the
        // specification asks before a kernel reads memory the host wrote,
        // and no copy on PoCL's CPU device.
        if (!overlaps(l) || n > r_.staged.items || n * l.stride > r_.staged.point_doubles)
            throw Error("OpenCL backend: staged launch does not fit its buffers");
        queue.enqueueWriteBuffer(r_.staged.points, CL_FALSE, 0, n * l.stride * sizeof(double),
                                 r_.staged.points_host.get());
        queue.enqueueWriteBuffer(r_.staged.cells, CL_FALSE, 0, n * sizeof(std::uint32_t),
                                 r_.staged.cells_host.get());
        queue.enqueueWriteBuffer(r_.staged.batches, CL_FALSE, 0, n * sizeof(std::uint32_t),
                                 r_.staged.batches_host.get());
    } else if (r_.real_float()) {
        points_f_.assign(l.points.begin(), l.points.end());
        queue.enqueueWriteBuffer(r_.points, CL_FALSE, 0, points_f_.size() * sizeof(float),
                                 points_f_.data());
    } else {
        queue.enqueueWriteBuffer(r_.points, CL_FALSE, 0, l.points.size() * sizeof(double),
                                 l.points.data());
    }
    if (!r_.options_known || l.options != r_.options_written) {
        int opts[BT_MAX_OPTIONS];
        launch::options_array(l, opts);
        queue.enqueueWriteBuffer(r_.options, CL_TRUE, 0, sizeof(opts), opts);
        r_.options_written = l.options;
        r_.options_known = true;
    }
    if (!l.staged) {
        queue.enqueueWriteBuffer(r_.cells, CL_FALSE, 0, n * sizeof(std::uint32_t), l.cells.data());
        queue.enqueueWriteBuffer(r_.batches, CL_FALSE, 0, n * sizeof(std::uint32_t), l.batches.data());
    }
}

void OpenCLBackend::read_results(const BatchLaunch& l, std::size_t n, double* mean_out,
                                 std::vector<double>& m2, cl::Event* done) {
    cl::CommandQueue& queue = r_.runtime.queue();
    if (r_.accum_double()) {
        const cl_bool block = done ? CL_FALSE : CL_TRUE;
        if (l.need_m2) {
            queue.enqueueReadBuffer(r_.out_mean, CL_FALSE, 0, n * sizeof(double), mean_out);
            queue.enqueueReadBuffer(r_.out_m2, block, 0, n * sizeof(double), m2.data(), nullptr, done);
        } else {
            queue.enqueueReadBuffer(r_.out_mean, block, 0, n * sizeof(double), mean_out, nullptr, done);
        }
    } else {
        std::vector<float>& tmp = accum_f_;
        tmp.resize(2 * n);
        queue.enqueueReadBuffer(r_.out_mean, CL_FALSE, 0, n * sizeof(float), tmp.data());
        queue.enqueueReadBuffer(r_.out_m2, CL_TRUE, 0, n * sizeof(float), tmp.data() + n);
        std::copy_n(tmp.begin(), n, mean_out);
        std::copy_n(tmp.begin() + static_cast<std::ptrdiff_t>(n), n, m2.begin());
    }
}

}  // namespace

std::unique_ptr<Backend> make_opencl_backend(const DeviceInfo& device, Precision precision,
                                             const std::string& kernel_dir,
                                             const EngineTuning& tuning) {
    return std::make_unique<OpenCLBackend>(device, precision, kernel_dir, tuning);
}

}  // namespace brdftab
