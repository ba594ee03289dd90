// chunked.h — `brdftab generate` in chunks of cells, streamed to the output
// file as they finish, and shared among processes (distributed.h).
//
// A computed table is cut into chunks of consecutive (row-major) cells.  Each
// chunk is one engine run over its cells, with the cells' global indices in
// the random-number counters, so a chunk's values are bit-identical to the
// same cells of a whole-table run: every random number depends only on (seed,
// cell, batch, sample, dimension) and the stopping rule only on the cell's
// own batches (host/engine/engine.h).  Finished chunks go straight into the
// output's temporary file (TableFileWriter); only tables that a derived table
// reads ([[recombined]] terms, [[errors]] table and reference, [[inverted]]
// source) are also kept whole in memory, and the derived tables themselves.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "host/generate/generate.h"

namespace brdftab {

class Checkpoint;

// Consecutive cells [first, first + count) of computed table `table`.
struct CellChunk {
    std::size_t table = 0, first = 0, count = 0;
};

// The chunks of every computed table of a spec, table by table, in cell
// order.  `chunk_cells`: cells per chunk (0: automatic: a table of up to
// kDefaultChunkCells cells is one chunk when `ranks` is 1; with more ranks a
// table is cut into about 8 chunks per rank, at least kMinChunkCells cells
// each, so that ranks finishing early find work left).
constexpr std::size_t kDefaultChunkCells = std::size_t(1) << 18;
constexpr std::size_t kMinChunkCells = 16;
std::size_t chunk_cells_for(std::size_t table_cells, std::size_t chunk_cells, int ranks);
std::vector<CellChunk> plan_chunks(const Spec& spec, std::size_t chunk_cells, int ranks);

// What one chunk computed.
struct ChunkResult {
    CellChunk chunk;
    std::vector<double> value, stderr_;
    std::vector<std::uint32_t> samples;  // empty for closed forms
    std::uint64_t total_samples = 0;
    double tolerance_achieved = 0;  // max over the chunk's cells
    std::uint64_t cells_unconverged = 0;
    double elapsed_seconds = 0;
};

// The spec's computed tables prepared once (points, options, settings), so
// that any process can compute any chunk.
class ChunkComputer {
public:
    ChunkComputer(const Spec& spec, Backend& backend, const IntegrationSettings& settings);
    ~ChunkComputer();
    std::size_t table_count() const;
    std::size_t cell_count(std::size_t table) const;
    // Computes one chunk.  With `checkpoint`, the chunk's estimator state is
    // stored and continued from where stored.  `after_launch` is called after
    // every device launch (progress display, and the coordinator's turn to
    // answer other processes).
    ChunkResult compute(const CellChunk& chunk, Checkpoint* checkpoint,
                        const ProgressFn& after_launch = nullptr);
    // Table `table` without its data: every field generate_tables() sets,
    // the totals (elapsed, samples, achieved tolerance) left at zero.
    TableData describe(std::size_t table) const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

// How chunks are shared among processes, seen from the process that writes
// the file (the coordinator).  distributed.h implements it with MPI; without
// one, the coordinator computes every chunk itself.  The coordinator
// computes chunks too, so the other processes are answered by a thread of
// their own: a device launch of the coordinator may take long.
class ChunkSharing {
public:
    virtual ~ChunkSharing() = default;
    // From now on, answers the other processes in the background: hands out
    // chunks (indices into the plan) taken with `take` (false: none left)
    // and passes the results that arrive to `accept`.  Both are called from
    // that background thread; the caller makes them safe to call there.
    virtual void start(const std::function<bool(std::size_t&)>& take,
                       const std::function<void(ChunkResult&&)>& accept) = 0;
    // Once the coordinator has no chunk left to compute: waits until every
    // chunk handed out is back and the others are told to stop.  Rethrows
    // a failure of the background thread.
    virtual void finish() = 0;
    // Rethrows a failure of the background thread, if any (called between
    // the coordinator's launches).
    virtual void check() = 0;
    // The coordinator failed: stops the background thread at once (it calls
    // `take` and `accept` no more), without waiting for the others.
    virtual void abandon() = 0;
    // The coordinator computed a chunk of `cells` cells itself.
    virtual void computed_here(std::uint64_t cells) = 0;
    // Cells computed by each process (index: rank), for the summary.
    virtual std::vector<std::uint64_t> cells_per_process() const = 0;
};

struct StreamOptions {
    std::size_t chunk_cells = 0;  // 0: automatic (chunk_cells_for)
    int ranks = 1;                // processes sharing the chunks
    Checkpoint* checkpoint = nullptr;
    ChunkSharing* sharing = nullptr;  // null: this process computes everything
    // Called with the output's temporary file name once it exists (to remove
    // it should the process be terminated).
    std::function<void(const std::string&)> temporary_created;
};

// Computes every table of `spec` (then its derived tables) and writes them to
// `output_path` as write_tables(generate_tables(...)) would, bit for bit,
// holding at a time only the chunks in progress (and the tables derived
// tables need).  The file appears only when complete.  Returns the tables
// for the summary: computed ones without their data, with lo/hi set.
std::vector<GeneratedTable> generate_to_file(const Spec& spec, Backend& backend,
                                             const IntegrationSettings& settings,
                                             const std::string& output_path,
                                             const GenerateProgressFn& progress = nullptr,
                                             const StreamOptions& options = {});

// The same into an open writer, which the caller commits: several specs'
// tables in one file (`brdftab scene`: one spec per table set).
class TableFileWriter;
std::vector<GeneratedTable> generate_into(const Spec& spec, Backend& backend,
                                          const IntegrationSettings& settings,
                                          TableFileWriter& writer,
                                          const GenerateProgressFn& progress = nullptr,
                                          const StreamOptions& options = {});

// The names of the computed tables whose data a derived table of `spec`
// reads (kept whole in memory by generate_to_file).
std::vector<std::string> tables_read_by_derived(const Spec& spec);

namespace generate_detail {
// Computed table `table` of `spec` without its data and totals: what
// generate_tables() records for it (`options`: resolved; `method`: the
// resolved estimator).
TableData describe_table(const Spec& spec, const Backend& backend,
                         const IntegrationSettings& settings, std::size_t table,
                         const std::vector<int>& options, Method method);
}  // namespace generate_detail

}  // namespace brdftab
