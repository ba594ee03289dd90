// distributed.cpp — chunks of cells shared among MPI ranks (distributed.h).
#include "host/generate/distributed.h"

#include <mpi.h>
#include <signal.h>
#include <time.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iostream>

#include "host/core/error.h"
#include "host/engine/evaluate.h"
#include "host/engine/engine_tuning.h"
#include "host/generate/checkpoint.h"

namespace brdftab {

namespace {

constexpr int kReady = 1, kAssign = 2, kResult = 3;

// Waiting ranks sleep between probes instead of spinning: on a node with
// fewer cores than ranks, a spinning rank takes a core from one computing.
// The sleep grows from 20 us to 1 ms, so a reply that comes quickly is seen
// quickly (the per-chunk latency measured in docs/benchmarks.md).
class Backoff {
public:
    void pause() {
        timespec ts{0, static_cast<long>(ns_)};
        nanosleep(&ts, nullptr);
        ns_ = std::min(ns_ * 2, 1000000.0);
    }
    void reset() { ns_ = 20000; }

private:
    double ns_ = 20000;
};

double seconds_since(std::chrono::steady_clock::time_point start) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

template <class T>
void put(std::vector<char>& out, const T& v) {
    const char* p = reinterpret_cast<const char*>(&v);
    out.insert(out.end(), p, p + sizeof v);
}
template <class T>
void put_array(std::vector<char>& out, const std::vector<T>& v) {
    const char* p = reinterpret_cast<const char*>(v.data());
    out.insert(out.end(), p, p + v.size() * sizeof(T));
}

std::vector<char> pack(std::uint64_t index, const ChunkResult& r, double waited) {
    std::vector<char> out;
    out.reserve(72 + r.value.size() * 20);
    put(out, index);
    put(out, waited);
    put(out, r.total_samples);
    put(out, r.cells_unconverged);
    put(out, r.tolerance_achieved);
    put(out, r.elapsed_seconds);
    put(out, static_cast<std::uint64_t>(r.samples.empty() ? 0 : 1));
    put_array(out, r.value);
    put_array(out, r.stderr_);
    put_array(out, r.samples);
    return out;
}

ChunkResult unpack(const std::vector<char>& in, const std::vector<CellChunk>& plan, int from,
                   double& waited) {
    std::size_t pos = 0;
    auto bad = [&] {
        throw Error("rank " + std::to_string(from) + " sent a malformed result (" +
                    std::to_string(in.size()) + " bytes)");
    };
    auto get = [&](void* to, std::size_t n) {
        if (in.size() - pos < n) bad();
        std::memcpy(to, in.data() + pos, n);
        pos += n;
    };
    std::uint64_t index = 0, has_samples = 0;
    ChunkResult r;
    get(&index, 8);
    if (index >= plan.size()) bad();
    get(&waited, 8);
    r.chunk = plan[index];
    get(&r.total_samples, 8);
    get(&r.cells_unconverged, 8);
    get(&r.tolerance_achieved, 8);
    get(&r.elapsed_seconds, 8);
    get(&has_samples, 8);
    const std::size_t n = r.chunk.count;
    r.value.resize(n);
    r.stderr_.resize(n);
    get(r.value.data(), n * sizeof(double));
    get(r.stderr_.data(), n * sizeof(double));
    if (has_samples) {
        r.samples.resize(n);
        get(r.samples.data(), n * sizeof(std::uint32_t));
    }
    if (pos != in.size()) bad();
    return r;
}

// The test hook of run_chunk_worker: results after which this rank aborts,
// or -1.
long abort_after_results(int rank) {
    const char* hook = environment_setting("BRDFTAB_TEST_RANK_ABORT");
    if (!hook) return -1;
    int r = -1;
    long k = -1;
    if (std::sscanf(hook, "%d:%ld", &r, &k) != 2 || r != rank) return -1;
    return k;
}

}  // namespace

// ------------------------------------------------------------- MpiSession --

bool MpiSession::launched() {
    // The variables an MPI launcher sets in every rank (not brdftab's own).
    for (const char* v : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_RANK", "PMI_SIZE"})
        if (std::getenv(v)) return true;
    return false;
}

MpiSession::MpiSession() {
    int provided = 0;
    // On rank 0 a second thread answers the other ranks while the main
    // thread computes; they never call MPI at the same time.
    MPI_Init_thread(nullptr, nullptr, MPI_THREAD_SERIALIZED, &provided);
    if (provided < MPI_THREAD_SERIALIZED)
        throw Error("this MPI library does not support MPI_THREAD_SERIALIZED");
    MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
    MPI_Comm_size(MPI_COMM_WORLD, &size_);
    MPI_Comm node;
    MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, rank_, MPI_INFO_NULL, &node);
    MPI_Comm_rank(node, &local_rank_);
    MPI_Comm_free(&node);
}

MpiSession::~MpiSession() { finalize(); }

void MpiSession::finalize() {
    if (finalized_) return;
    finalized_ = true;
    MPI_Finalize();
}

void MpiSession::barrier() const { MPI_Barrier(MPI_COMM_WORLD); }

void MpiSession::broadcast(std::string& text) const {
    std::uint64_t n = text.size();
    MPI_Bcast(&n, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD);
    text.resize(n);
    if (n) MPI_Bcast(text.data(), static_cast<int>(n), MPI_CHAR, 0, MPI_COMM_WORLD);
}

std::vector<std::string> MpiSession::gather(const std::string& text) const {
    const int n = static_cast<int>(text.size());
    std::vector<int> sizes(rank_ == 0 ? size_ : 0), offsets;
    MPI_Gather(&n, 1, MPI_INT, sizes.data(), 1, MPI_INT, 0, MPI_COMM_WORLD);
    std::vector<char> all;
    if (rank_ == 0) {
        int total = 0;
        for (int s : sizes) offsets.push_back(total), total += s;
        all.resize(static_cast<std::size_t>(total) + 1);
    }
    MPI_Gatherv(text.data(), n, MPI_CHAR, all.data(), sizes.data(), offsets.data(), MPI_CHAR, 0,
                MPI_COMM_WORLD);
    std::vector<std::string> out;
    for (int r = 0; rank_ == 0 && r < size_; ++r)
        out.emplace_back(all.data() + offsets[r], static_cast<std::size_t>(sizes[r]));
    return out;
}

int MpiSession::broadcast(int value) const {
    MPI_Bcast(&value, 1, MPI_INT, 0, MPI_COMM_WORLD);
    return value;
}

int MpiSession::max(int value) const {
    int out = 0;
    MPI_Allreduce(&value, &out, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
    return out;
}

void MpiSession::abort(int code) const {
    MPI_Abort(MPI_COMM_WORLD, code);
    std::_Exit(code);  // not reached
}

// -------------------------------------------------------- MpiChunkSharing --

std::string MpiChunkSharing::statistics() const {
    char buf[256];
    std::snprintf(buf, sizeof buf,
                  "rank 0 received and wrote %zu results from the other ranks in %.3f s "
                  "(%.2f ms each); they waited %.3f s in all for chunks",
                  results_, handling_, results_ ? 1e3 * handling_ / results_ : 0.0, waited_);
    return buf;
}

MpiChunkSharing::MpiChunkSharing(const MpiSession& session, const std::vector<CellChunk>& plan)
    : session_(session),
      plan_(plan),
      cells_(static_cast<std::size_t>(session.size()), 0),
      stopped_(static_cast<std::size_t>(session.size()), false) {
    stopped_[0] = true;  // rank 0 asks nobody
}

MpiChunkSharing::~MpiChunkSharing() { abandon(); }

void MpiChunkSharing::abandon() {
    // The thread never blocks for long (it probes, then receives only what
    // has arrived), so it sees the flag soon.
    abandoned_ = true;
    if (thread_.joinable()) thread_.join();
}

void MpiChunkSharing::start(const std::function<bool(std::size_t&)>& take,
                            const std::function<void(ChunkResult&&)>& accept) {
    take_ = take;
    accept_ = accept;
    thread_ = std::thread([this] {
        try {
            serve();
        } catch (...) {
            std::lock_guard<std::mutex> hold(failure_lock_);
            failure_ = std::current_exception();
        }
    });
}

void MpiChunkSharing::finish() {
    if (thread_.joinable()) thread_.join();
    check();
}

void MpiChunkSharing::check() {
    std::lock_guard<std::mutex> hold(failure_lock_);
    if (failure_) std::rethrow_exception(failure_);
}

// Until every rank is told to stop and every chunk handed out is back.
void MpiChunkSharing::serve() {
    auto everyone_stopped = [&] {
        for (bool s : stopped_)
            if (!s) return false;
        return true;
    };
    Backoff backoff;
    while ((outstanding_ > 0 || !everyone_stopped()) && !abandoned_) {
        MPI_Status status;
        int flag = 0;
        MPI_Iprobe(MPI_ANY_SOURCE, MPI_ANY_TAG, MPI_COMM_WORLD, &flag, &status);
        if (!flag) {
            backoff.pause();
            continue;
        }
        backoff.reset();
        handle(status.MPI_TAG, status.MPI_SOURCE);
    }
}

void MpiChunkSharing::handle(int tag, int from) {
    if (tag == kReady) {
        int dummy = 0;
        MPI_Recv(&dummy, 1, MPI_INT, from, kReady, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
        std::size_t index = 0;
        long long reply = -1;
        if (take_(index)) {
            reply = static_cast<long long>(index);
            ++outstanding_;
        } else {
            stopped_[static_cast<std::size_t>(from)] = true;
        }
        MPI_Send(&reply, 1, MPI_LONG_LONG, from, kAssign, MPI_COMM_WORLD);
    } else if (tag == kResult) {
        const auto start = std::chrono::steady_clock::now();
        MPI_Status status;
        MPI_Probe(from, kResult, MPI_COMM_WORLD, &status);
        int bytes = 0;
        MPI_Get_count(&status, MPI_BYTE, &bytes);
        std::vector<char> buffer(static_cast<std::size_t>(bytes));
        MPI_Recv(buffer.data(), bytes, MPI_BYTE, from, kResult, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
        double waited = 0;
        ChunkResult r = unpack(buffer, plan_, from, waited);
        cells_[static_cast<std::size_t>(from)] += r.chunk.count;
        --outstanding_;
        accept_(std::move(r));
        ++results_;
        waited_ += waited;
        handling_ += seconds_since(start);
    } else {
        throw Error("unexpected MPI message (tag " + std::to_string(tag) + ") from rank " +
                    std::to_string(from));
    }
}

// ---------------------------------------------------------------- workers --

std::uint64_t run_chunk_worker(const MpiSession& session, ChunkComputer& computer,
                               const std::vector<CellChunk>& plan, Checkpoint* checkpoint) {
    const long abort_after = abort_after_results(session.rank());
    std::uint64_t cells = 0;
    long computed = 0;
    int ready = 0;
    // Results on their way to rank 0 (it receives them between launches).
    std::vector<std::vector<char>> buffers;
    std::vector<MPI_Request> requests;
    auto ask = [&] { MPI_Send(&ready, 1, MPI_INT, 0, kReady, MPI_COMM_WORLD); };
    auto release_sent = [&] {
        for (std::size_t k = 0; k < requests.size();) {
            int done = 0;
            MPI_Test(&requests[k], &done, MPI_STATUS_IGNORE);
            if (done) {
                requests.erase(requests.begin() + static_cast<long>(k));
                buffers.erase(buffers.begin() + static_cast<long>(k));
            } else {
                ++k;
            }
        }
    };
    ask();
    double waited = 0;  // since the last result sent
    for (;;) {
        long long index = -1;
        int flag = 0;
        Backoff backoff;
        const auto wait_start = std::chrono::steady_clock::now();
        for (;;) {
            MPI_Iprobe(0, kAssign, MPI_COMM_WORLD, &flag, MPI_STATUS_IGNORE);
            if (flag) break;
            release_sent();
            backoff.pause();
        }
        MPI_Recv(&index, 1, MPI_LONG_LONG, 0, kAssign, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
        waited += seconds_since(wait_start);
        if (index < 0) break;
        if (static_cast<std::size_t>(index) >= plan.size())
            throw Error("rank 0 handed out chunk " + std::to_string(index) + " of " +
                        std::to_string(plan.size()));
        ask();  // the next one, while this one is computed
        ChunkResult r = computer.compute(plan[static_cast<std::size_t>(index)], checkpoint,
                                         [&](const Progress&) { release_sent(); });
        if (abort_after >= 0 && ++computed > abort_after) {
            // The test hook: die holding a chunk rank 0 waits for.
            std::cerr << "brdftab: rank " << session.rank()
                      << ": BRDFTAB_TEST_RANK_ABORT: aborting after " << abort_after
                      << " chunk(s), with one more computed and not sent" << std::endl;
            std::abort();
        }
        cells += r.chunk.count;
        buffers.push_back(pack(static_cast<std::uint64_t>(index), r, waited));
        waited = 0;
        requests.emplace_back();
        MPI_Isend(buffers.back().data(), static_cast<int>(buffers.back().size()), MPI_BYTE, 0,
                  kResult, MPI_COMM_WORLD, &requests.back());
    }
    if (!requests.empty())
        MPI_Waitall(static_cast<int>(requests.size()), requests.data(), MPI_STATUSES_IGNORE);
    return cells;
}

// ------------------------------------------------------- signal clean-up --

namespace {
char g_temporary[4096] = {0};

extern "C" void remove_temporary_and_exit(int sig) {
    if (g_temporary[0]) ::unlink(g_temporary);
    ::_exit(128 + sig);
}
}  // namespace

void remove_temporaries_on_termination(const std::string& temporary_path) {
    if (temporary_path.size() >= sizeof g_temporary) return;
    std::memcpy(g_temporary, temporary_path.c_str(), temporary_path.size() + 1);
    struct sigaction sa {};
    sa.sa_handler = remove_temporary_and_exit;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGTERM, &sa, nullptr);
    sigaction(SIGINT, &sa, nullptr);
}

namespace {

template <class T>
void append_bytes(std::string& out, const T& v) {
    out.append(reinterpret_cast<const char*>(&v), sizeof v);
}

void append_doubles(std::string& out, const std::vector<double>& v) {
    append_bytes<std::uint64_t>(out, v.size());
    out.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(double));
}

}  // namespace

EstimateResult estimate_at_shared(const MpiSession& session, Backend& backend, const ModelInfo& model,
                                  const QuantityInfo& quantity, const std::vector<int>& options,
                                  const std::vector<double>& kernel_points, const IntegrationSettings& settings) {
    const std::size_t stride = model.point_stride();
    const std::size_t n = kernel_points.size() / stride;
    std::string count = std::to_string(n);
    session.broadcast(count);
    const int agree = session.max(count == std::to_string(n) ? 0 : 1);
    if (agree != 0)
        throw Error("ranks hold different points for one engine run (rank 0: " + count +
                    "); the runs differ in settings or input");
    const std::size_t size = static_cast<std::size_t>(session.size()), rank = static_cast<std::size_t>(session.rank());
    const std::size_t first = n * rank / size, last = n * (rank + 1) / size;
    EstimateResult part;
    part.method = Method::Auto;  // none computed here
    if (last > first) {
        IntegrationSettings s = settings;
        s.cell_base = settings.cell_base + first;
        const std::vector<double> mine(kernel_points.begin() + static_cast<std::ptrdiff_t>(first * stride),
                                       kernel_points.begin() + static_cast<std::ptrdiff_t>(last * stride));
        part = estimate_at(backend, model, quantity, options, mine, s);
    }
    std::string bytes;
    append_bytes<std::int32_t>(bytes, static_cast<std::int32_t>(part.method));
    append_bytes(bytes, part.total_samples);
    append_bytes(bytes, part.tolerance_achieved);
    append_bytes<std::uint64_t>(bytes, part.cells_unconverged);
    append_bytes(bytes, part.elapsed_seconds);
    append_doubles(bytes, part.value);
    append_doubles(bytes, part.stderr_);
    std::string all;
    const std::vector<std::string> parts = session.gather(bytes);
    for (const std::string& p : parts) {
        append_bytes<std::uint64_t>(all, p.size());
        all += p;
    }
    session.broadcast(all);
    // Every rank unpacks the same bytes in rank order.
    EstimateResult r;
    r.method = Method::Auto;
    std::size_t pos = 0;
    auto take = [&](void* v, std::size_t k) {
        if (all.size() - pos < k) throw Error("a rank's engine results are truncated");
        std::memcpy(v, all.data() + pos, k);
        pos += k;
    };
    auto take_doubles = [&](std::vector<double>& out) {
        std::uint64_t k = 0;
        take(&k, sizeof k);
        if (k > (all.size() - pos) / sizeof(double)) throw Error("a rank's engine results are truncated");
        const std::size_t at = out.size();
        out.resize(at + k);
        take(out.data() + at, k * sizeof(double));
    };
    for (std::size_t q = 0; q < size; ++q) {
        std::uint64_t length = 0;
        take(&length, sizeof length);
        std::int32_t method = 0;
        take(&method, sizeof method);
        std::uint64_t samples = 0, unconverged = 0;
        double achieved = 0, elapsed = 0;
        take(&samples, sizeof samples);
        take(&achieved, sizeof achieved);
        take(&unconverged, sizeof unconverged);
        take(&elapsed, sizeof elapsed);
        if (static_cast<Method>(method) != Method::Auto && r.method == Method::Auto) r.method = static_cast<Method>(method);
        r.total_samples += samples;
        r.tolerance_achieved = std::max(r.tolerance_achieved, achieved);
        r.cells_unconverged += static_cast<std::size_t>(unconverged);
        r.elapsed_seconds = std::max(r.elapsed_seconds, elapsed);
        const std::size_t before = r.value.size();
        take_doubles(r.value);
        const std::size_t got = r.value.size() - before;
        std::vector<double> err;
        take_doubles(err);
        if (!err.empty() || !r.stderr_.empty()) {
            r.stderr_.resize(before, 0.0);
            err.resize(got, 0.0);
            r.stderr_.insert(r.stderr_.end(), err.begin(), err.end());
        }
    }
    if (r.value.size() != n) throw Error("the ranks' engine results hold " + std::to_string(r.value.size()) +
                                         " values for " + std::to_string(n) + " points");
    if (r.method == Method::Auto) r.method = resolve_method(quantity, settings.method);
    return r;
}

}  // namespace brdftab
