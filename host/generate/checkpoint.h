// checkpoint.h — checkpoint and resume of `brdftab generate`.
//
// While a spec is computed, the estimator state of each table (per cell: the
// running sums of host/engine/engine.h CellState and the round's batch
// target) is stored in a directory beside the output, `<output>.checkpoint/`:
//   manifest.json     the settings the state is valid for, and their hash
//   table-<k>.state   table k: finished, or in progress (rewritten at most
//                     every `interval` seconds)
//   table-<k>-<c>.state  the same for the chunk of table k that starts at
//                     cell c, when a table is computed in chunks
//                     (host/generate/chunked.h); every process of a
//                     distributed run stores the chunks it computes here
//   adaptive-<k>.log  table k of an adaptive run: every refinement round's
//                     points and values so far (rewritten after each round)
//   lock              held (flock) by the process writing the directory
// Every file is replaced atomically (host/core/atomic_file.h), so a killed
// run leaves the previous complete state.  Random numbers depend only on
// (seed, cell, batch, sample), and a cell's batches continue from its stored
// count, so a resumed run computes bit-identical tables.  The state files are
// binary in the machine's byte order: resume on the machine that wrote them.
#pragma once

#include <cstdint>
#include <set>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "host/engine/engine.h"
#include "host/spec/spec.h"

namespace brdftab {

// The settings a checkpoint belongs to: everything that can change a value
// (spec text, integration settings, precision, device, kernels, version), as
// (name, text) pairs in a fixed order, plus their hash.
struct CheckpointKey {
    std::vector<std::pair<std::string, std::string>> settings;
    std::string fingerprint() const;  // 16 hex digits (FNV-1a 64 of the pairs)
};

// `kernel_dir`: the --kernel-dir in use ("" = kernels embedded in the binary).
CheckpointKey checkpoint_key(const Spec& spec, const IntegrationSettings& settings,
                             const Backend& backend, const std::string& kernel_dir);

// `<resolved output path>.checkpoint`.
std::string checkpoint_directory(const std::string& output_path);

enum class CheckpointPresence { None, Interrupted, InUse };
// Whether a checkpoint directory exists for the output, and whether a running
// process holds it.
CheckpointPresence checkpoint_presence(const std::string& output_path);

class Checkpoint {
public:
    // Opens the checkpoint of `output_path` and locks it.  With `resume`, the
    // stored state is used when its settings equal `key` (else InputError
    // listing every setting that differs); a missing or empty checkpoint
    // starts from nothing.  Without `resume` the directory must not exist.
    // `interval_seconds`: least time between two states of a table in progress
    // (0: store finished tables only); a write never takes more than a tenth
    // of the time between writes, and a finished table that took less than
    // ten times as long as writing its state is not stored (it is computed
    // again on resume).
    // `helper`: a process of a distributed run other than the one that owns
    // the directory (host/generate/distributed.h): it neither locks nor
    // writes the manifest, and uses the directory the owner opened (which
    // must exist), storing the chunks it computes there.
    Checkpoint(const std::string& output_path, CheckpointKey key, bool resume,
               double interval_seconds, bool helper = false);
    ~Checkpoint();
    Checkpoint(const Checkpoint&) = delete;
    Checkpoint& operator=(const Checkpoint&) = delete;

    const std::string& directory() const { return dir_; }
    // "2 finished table(s), 1 in progress" (what a resume starts from).
    std::string resumed_summary() const;

    // The hooks estimate() takes for table `index` (`cell_count` cells): its
    // stored state, if any (InputError if damaged or of another shape), and
    // the function that stores new states.  The Checkpoint must outlive them.
    EstimateCheckpoint table(std::size_t index, const std::string& name, std::size_t cell_count);
    // The same for cells [first, first + count) of table `index`, which has
    // `table_cells` cells (the whole table: the same file as table()).
    EstimateCheckpoint chunk(std::size_t index, const std::string& name, std::size_t first,
                             std::size_t count, std::size_t table_cells);

    // How the tables were cut into chunks (a text the caller defines, e.g.
    // "chunk_cells=256 ranks=4"), stored in the manifest so that a resumed
    // run cuts them the same way whatever its number of processes; "" when
    // none was recorded.
    const std::string& layout() const { return layout_; }
    void record_layout(const std::string& layout);

    // Adaptive tables (host/adaptive/adaptive_generate.h, AdaptiveCheckpoint):
    // the refinement log of table `index` that an interrupted run stored
    // (`adaptive-<k>.log`; "" when none), and its atomic replacement.
    std::string adaptive_log(std::size_t index) const;
    void store_adaptive_log(std::size_t index, const std::string& bytes);

    // Deletes the directory (after the output file is written); returns
    // why it could not, or "".
    std::string remove();

private:
    std::string dir_;
    CheckpointKey key_;
    double interval_;
    double write_rate_ = 100e6;  // bytes per second of state writes (measured)
    int lock_fd_ = -1;
    std::size_t resumed_finished_ = 0, resumed_partial_ = 0;
    std::size_t resumed_chunks_finished_ = 0, resumed_chunks_partial_ = 0;
    std::size_t resumed_adaptive_ = 0;
    std::vector<std::string> stored_;  // names of the state files present at the start
    std::string layout_;
    bool helper_ = false;

    EstimateCheckpoint hooks(const std::string& file, std::size_t index,
                             const std::string& name, std::size_t cell_count);
};

// Bytes of a table's state file, and back (exposed for the tests).  `reading`
// names the file in messages; read throws InputError on damage.
std::string encode_table_state(const EstimateState& state, std::size_t index,
                               const std::string& name, const std::string& fingerprint,
                               bool finished);
EstimateState decode_table_state(const std::string& bytes, std::size_t index,
                                 const std::string& name, const std::string& fingerprint,
                                 std::size_t cell_count, const std::string& reading,
                                 bool* finished = nullptr);

}  // namespace brdftab
