// distributed.h — `mpirun -n N brdftab generate`: the chunks of
// cells of host/generate/chunked.h shared among N MPI processes (ranks).
// Built only with -DBRDFTAB_MPI=ON (then BRDFTAB_MPI is defined).
//
// Rank 0 coordinates and writes the file; it computes chunks too, while a
// thread of its own answers the other ranks (chunked.h, ChunkSharing).  The other ranks ask for one chunk at a time, and ask for
// the next as soon as they start one, so that a rank rarely waits for rank 0
// (dynamic load balancing: a rank with cheap cells simply asks more often).
// Results go to rank 0, which writes them into the output's temporary file.
// Values do not depend on which rank computed a cell (chunked.h), so the file
// is bit-identical to a one-process run.
//
// Messages (MPI_COMM_WORLD): kReady (rank -> 0, asks for a chunk), kAssign
// (0 -> rank: a chunk index of the plan, or -1: stop), kResult (rank -> 0:
// the chunk's totals and cells, and how long the rank waited for it, packed
// as bytes in this machine's order).
#pragma once

#include <atomic>
#include <exception>
#include <memory>
#include <mutex>
#include <thread>
#include <string>
#include <vector>

#include "host/generate/chunked.h"

namespace brdftab {

// MPI_Init / MPI_Finalize around a run.  Errors are fatal (Open MPI's
// default handler): a rank that dies ends the job.
class MpiSession {
public:
    // True when the process was started by an MPI launcher (mpirun, srun):
    // Open MPI's, PMIx's or PMI's rank variable is set.
    static bool launched();
    MpiSession();
    ~MpiSession();
    MpiSession(const MpiSession&) = delete;
    MpiSession& operator=(const MpiSession&) = delete;

    // MPI_Finalize now (before std::exit); the destructor then does nothing.
    void finalize();
    int rank() const { return rank_; }
    int size() const { return size_; }
    // Rank among the processes of the same node (MPI_COMM_TYPE_SHARED).
    int local_rank() const { return local_rank_; }
    void barrier() const;
    // Rank 0's `text` on every rank.
    void broadcast(std::string& text) const;
    // Texts of every rank, on rank 0 (elsewhere: empty).
    std::vector<std::string> gather(const std::string& text) const;
    // Rank 0's `value` on every rank.
    int broadcast(int value) const;
    // The largest `value` over ranks, on every rank.
    int max(int value) const;
    // Ends every rank of the job with `code` (MPI_Abort).
    [[noreturn]] void abort(int code) const;

private:
    int rank_ = 0, size_ = 1, local_rank_ = 0;
    bool finalized_ = false;
};

// Rank 0's side (chunked.h ChunkSharing): a thread that answers the other
// ranks while rank 0 computes; the only thread that calls MPI meanwhile
// (MPI_THREAD_SERIALIZED).
class MpiChunkSharing : public ChunkSharing {
public:
    MpiChunkSharing(const MpiSession& session, const std::vector<CellChunk>& plan);
    ~MpiChunkSharing() override;
    void start(const std::function<bool(std::size_t&)>& take,
               const std::function<void(ChunkResult&&)>& accept) override;
    void finish() override;
    void check() override;
    void abandon() override;
    void computed_here(std::uint64_t cells) override { cells_[0] += cells; }
    std::vector<std::uint64_t> cells_per_process() const override { return cells_; }
    // "rank 0 received and wrote 12 results ... in 0.004 s (0.33 ms each);
    // they waited 0.021 s in all for chunks": the cost of the sharing.
    std::string statistics() const;

private:
    void serve();
    void handle(int tag, int from);
    const MpiSession& session_;
    const std::vector<CellChunk>& plan_;
    std::function<bool(std::size_t&)> take_;
    std::function<void(ChunkResult&&)> accept_;
    std::vector<std::uint64_t> cells_;
    std::vector<bool> stopped_;
    std::size_t outstanding_ = 0;  // chunks handed out, results not back
    std::size_t results_ = 0;      // received from the other ranks
    double handling_ = 0;          // seconds spent receiving and writing them
    double waited_ = 0;            // seconds the other ranks waited for chunks
    std::thread thread_;
    std::atomic<bool> abandoned_{false};
    std::mutex failure_lock_;
    std::exception_ptr failure_;
};

// A rank other than 0: asks rank 0 for chunks of `plan`, computes them with
// `computer` (storing their states in `checkpoint`, if any), and sends the
// results back, until told to stop.  Returns the cells it computed.
//
// Test hook: with BRDFTAB_TEST_RANK_ABORT="R:K" in the environment, rank R
// aborts (SIGABRT, like a crash) when it has computed chunk K + 1, after
// sending K results: rank 0 then waits for a chunk that never comes.
std::uint64_t run_chunk_worker(const MpiSession& session, ChunkComputer& computer,
                               const std::vector<CellChunk>& plan, Checkpoint* checkpoint);

// estimate_at (host/engine/evaluate.h) over kernel points shared among every
// rank of `session`: rank r computes the points [n r / N, n (r + 1) / N)
// numbered from settings.cell_base + n r / N, and every rank receives every
// result (values, stderr, totals), the same bits as one process computing
// them all.  Every rank calls it with the same points (the adaptive
// refinement, replicated on each: host/adaptive/adaptive_generate.h); a rank
// holding another number of points throws Error.
EstimateResult estimate_at_shared(const MpiSession& session, Backend& backend, const ModelInfo& model,
                                  const QuantityInfo& quantity, const std::vector<int>& options,
                                  const std::vector<double>& kernel_points, const IntegrationSettings& settings);

// On SIGTERM/SIGINT (what mpirun sends the surviving ranks when one dies),
// removes the output's temporary file (TableFileWriter::temporary_path) and
// exits with 128 + signal: no partial file is left.
void remove_temporaries_on_termination(const std::string& temporary_path);

}  // namespace brdftab
