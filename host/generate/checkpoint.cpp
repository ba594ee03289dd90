#include "host/generate/checkpoint.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>

#include "host/core/atomic_file.h"
#include "host/core/error.h"
#include "host/core/text.h"

#ifndef BRDFTAB_VERSION
#define BRDFTAB_VERSION "unknown"
#endif

namespace brdftab {

namespace fs = std::filesystem;

namespace {

constexpr int kManifestFormat = 1;
constexpr char kMagic[8] = {'B', 'T', 'C', 'K', 'P', 'T', '\x01', '\n'};
constexpr std::uint32_t kByteOrderMark = 0x01020304u;
// Bytes of one cell: 6 doubles, samples (u64), batches (u32), done (u8),
// round target (u32).
constexpr std::size_t kCellBytes = 6 * 8 + 8 + 4 + 1 + 4;

// FNV-1a, 64 bit: detects damage and changed settings; not a defence
// against someone forging a checkpoint.
std::uint64_t fnv1a(const void* data, std::size_t n, std::uint64_t h = 0xcbf29ce484222325ull) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t k = 0; k < n; ++k) {
        h ^= p[k];
        h *= 0x100000001b3ull;
    }
    return h;
}

std::string hex64(std::uint64_t v) {
    char buf[17];
    std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(v));
    return buf;
}

double seconds_now() {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch())
        .count();
}

// Little helpers over a byte string in the machine's representation.
template <class T>
void put(std::string& out, T v) {
    out.append(reinterpret_cast<const char*>(&v), sizeof v);
}

class Reader {
public:
    Reader(const std::string& bytes, std::string what) : b_(bytes), what_(std::move(what)) {}
    template <class T>
    T get() {
        T v;
        need(sizeof v);
        std::memcpy(&v, b_.data() + pos_, sizeof v);
        pos_ += sizeof v;
        return v;
    }
    std::string text(std::size_t n) {
        need(n);
        std::string s = b_.substr(pos_, n);
        pos_ += n;
        return s;
    }
    std::size_t position() const { return pos_; }
    [[noreturn]] void damaged(const std::string& why) const {
        throw InputError("checkpoint file '" + what_ + "' " + why +
                         "; delete the checkpoint directory to start over");
    }

private:
    void need(std::size_t n) const {
        if (b_.size() - pos_ < n) damaged("is truncated");
    }
    const std::string& b_;
    std::string what_;
    std::size_t pos_ = 0;
};

std::string read_whole_file(const std::string& path) {
    std::ifstream f(path, std::ios::binary);
    if (!f) throw InputError("cannot read checkpoint file '" + path + "'");
    return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

void write_bytes_atomically(const std::string& path, const std::string& bytes) {
    AtomicOutput out(path);
    {
        std::ofstream f(out.path(), std::ios::binary);
        f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
        f.flush();
        if (!f) throw Error("cannot write checkpoint file '" + out.path() + "'");
    }
    out.commit();
}

std::string table_file(const std::string& dir, std::size_t index) {
    return dir + "/table-" + std::to_string(index) + ".state";
}

std::string chunk_file(const std::string& dir, std::size_t index, std::size_t first) {
    return dir + "/table-" + std::to_string(index) + "-" + std::to_string(first) + ".state";
}

// Index of a `table-<k>.state` or `table-<k>-<c>.state` file name, or -1.
long table_file_index(const std::string& file_name) {
    std::string name = file_name;
    const std::size_t dash = name.find('-', 6);
    if (name.compare(0, 6, "table-") == 0 && dash != std::string::npos) {
        const std::string first = name.substr(dash + 1);
        if (first.size() > 6 && first.find_first_not_of("0123456789") == first.size() - 6 &&
            first.compare(first.size() - 6, 6, ".state") == 0 && first.size() - 6 <= 19)
            name = name.substr(0, dash) + ".state";
        else
            return -1;
    }
    const std::string prefix = "table-", suffix = ".state";
    if (name.size() <= prefix.size() + suffix.size() || name.compare(0, prefix.size(), prefix) ||
        name.compare(name.size() - suffix.size(), suffix.size(), suffix))
        return -1;
    const std::string digits = name.substr(prefix.size(), name.size() - prefix.size() - suffix.size());
    if (digits.find_first_not_of("0123456789") != std::string::npos || digits.size() > 9) return -1;
    return std::stol(digits);
}

std::string adaptive_file(const std::string& dir, std::size_t index) {
    return dir + "/adaptive-" + std::to_string(index) + ".log";
}

bool is_adaptive_file(const std::string& name) {
    const std::string prefix = "adaptive-", suffix = ".log";
    if (name.size() <= prefix.size() + suffix.size() || name.compare(0, prefix.size(), prefix) ||
        name.compare(name.size() - suffix.size(), suffix.size(), suffix))
        return false;
    const std::string digits = name.substr(prefix.size(), name.size() - prefix.size() - suffix.size());
    return digits.find_first_not_of("0123456789") == std::string::npos && digits.size() <= 9;
}

}  // namespace

std::string CheckpointKey::fingerprint() const {
    std::uint64_t h = fnv1a(nullptr, 0);
    for (const auto& [name, value] : settings) {
        const std::string line = name + "=" + value + "\n";
        h = fnv1a(line.data(), line.size(), h);
    }
    return hex64(h);
}

CheckpointKey checkpoint_key(const Spec& spec, const IntegrationSettings& s, const Backend& backend,
                             const std::string& kernel_dir) {
    CheckpointKey k;
    // The spec text covers the model, axes, tables and the [integration]
    // defaults; the settings below are the ones in effect after command-line
    // overrides.  The slab size is left out: it does not change values.
    k.settings = {
        {"spec", "text hash " + hex64(fnv1a(spec.text.data(), spec.text.size()))},
        {"method", to_string(s.method)},
        {"samples", std::to_string(s.samples)},
        {"tolerance", number_text(s.tolerance, 17)},
        {"abs_floor", number_text(s.abs_floor, 17)},
        {"max_samples", std::to_string(s.max_samples)},
        {"seed", std::to_string(s.seed)},
        {"batch_size", std::to_string(s.batch_size)},
        {"precision", precision_name(backend.precision())},
        {"device", backend.device_name()},
        {"kernels", kernel_dir.empty() ? std::string("embedded") : kernel_dir},
        {"brdftab_version", BRDFTAB_VERSION},
    };
    return k;
}

std::string checkpoint_directory(const std::string& output_path) {
    return resolve_output_path(output_path) + ".checkpoint";
}

CheckpointPresence checkpoint_presence(const std::string& output_path) {
    const std::string dir = checkpoint_directory(output_path);
    std::error_code ec;
    if (!fs::exists(dir, ec)) return CheckpointPresence::None;
    const int fd = ::open((dir + "/lock").c_str(), O_RDWR | O_CLOEXEC);
    if (fd < 0) return CheckpointPresence::Interrupted;
    const bool held = ::flock(fd, LOCK_EX | LOCK_NB) != 0 && errno == EWOULDBLOCK;
    ::close(fd);  // also releases our lock if we got it
    return held ? CheckpointPresence::InUse : CheckpointPresence::Interrupted;
}

// ------------------------------------------------------------ state files

std::string encode_table_state(const EstimateState& state, std::size_t index,
                               const std::string& name, const std::string& fingerprint,
                               bool finished) {
    const std::size_t n = state.cells.size();
    if (state.round_target.size() != n) throw Error("estimator state: targets and cells differ in number");
    // Cells not reached yet (no batch, same target as the last cell) are left
    // out: early in a fixed-budget table the file holds only the cells done.
    const std::uint32_t rest_target = n ? state.round_target[n - 1] : 0;
    std::size_t stored = n;
    while (stored > 0 && state.cells[stored - 1].batches == 0 && !state.cells[stored - 1].done &&
           state.round_target[stored - 1] == rest_target)
        --stored;
    std::string out;
    out.reserve(96 + name.size() + stored * kCellBytes);
    out.append(kMagic, sizeof kMagic);
    put<std::uint32_t>(out, kByteOrderMark);
    put<std::uint8_t>(out, finished ? 1 : 0);
    out.append(3, '\0');
    put<std::uint64_t>(out, index);
    put<std::uint64_t>(out, n);
    put<std::uint64_t>(out, stored);
    put<std::uint32_t>(out, rest_target);
    put<std::uint32_t>(out, 0);
    put<double>(out, state.elapsed_seconds);
    std::string fp = fingerprint;
    fp.resize(16, ' ');
    out += fp;
    put<std::uint64_t>(out, name.size());
    out += name;
    // The cells (most of the bytes) into a buffer sized once.
    const std::size_t head = out.size();
    out.resize(head + stored * kCellBytes);
    char* p = &out[head];
    auto store = [&p](auto v) {
        std::memcpy(p, &v, sizeof v);
        p += sizeof v;
    };
    for (std::size_t c = 0; c < stored; ++c) {
        const CellState& s = state.cells[c];
        store(s.first_batch);
        store(s.second_batch);
        store(s.mean);
        store(s.m2);
        store(s.batch_mean);
        store(s.batch_m2);
        store(s.samples);
        store(s.batches);
        store(static_cast<std::uint8_t>(s.done ? 1 : 0));
        store(state.round_target[c]);
    }
    put<std::uint64_t>(out, fnv1a(out.data(), out.size()));
    return out;
}

EstimateState decode_table_state(const std::string& bytes, std::size_t index,
                                 const std::string& name, const std::string& fingerprint,
                                 std::size_t cell_count, const std::string& reading,
                                 bool* finished) {
    Reader r(bytes, reading);
    if (bytes.size() < 8 + sizeof(kMagic) ||
        fnv1a(bytes.data(), bytes.size() - 8) != [&] {
            std::uint64_t v;
            std::memcpy(&v, bytes.data() + bytes.size() - 8, 8);
            return v;
        }())
        r.damaged("is damaged (checksum mismatch)");
    if (r.text(sizeof kMagic) != std::string(kMagic, sizeof kMagic))
        r.damaged("is not a brdftab checkpoint state");
    if (r.get<std::uint32_t>() != kByteOrderMark)
        r.damaged("was written on a machine of another byte order");
    const bool is_finished = r.get<std::uint8_t>() != 0;
    r.text(3);
    const std::uint64_t stored_index = r.get<std::uint64_t>();
    const std::uint64_t n = r.get<std::uint64_t>();
    const std::uint64_t stored = r.get<std::uint64_t>();
    const std::uint32_t rest_target = r.get<std::uint32_t>();
    r.get<std::uint32_t>();
    const double elapsed = r.get<double>();
    std::string fp = fingerprint;
    fp.resize(16, ' ');
    if (r.text(16) != fp) r.damaged("belongs to other settings than its manifest");
    const std::uint64_t name_size = r.get<std::uint64_t>();
    if (name_size > bytes.size()) r.damaged("is damaged (name length)");
    const std::string stored_name = r.text(static_cast<std::size_t>(name_size));
    if (stored_index != index || stored_name != name)
        r.damaged("holds table " + std::to_string(stored_index) + " '" + stored_name +
                  "', expected table " + std::to_string(index) + " '" + name + "'");
    if (n != cell_count)
        r.damaged("has " + std::to_string(n) + " cells, table '" + name + "' has " +
                  std::to_string(cell_count));
    if (stored > n || bytes.size() - r.position() != stored * kCellBytes + 8)
        r.damaged("is damaged (cell count and size disagree)");
    EstimateState state;
    state.cells.resize(cell_count);
    state.round_target.assign(cell_count, rest_target);
    state.elapsed_seconds = elapsed;
    for (std::size_t c = 0; c < stored; ++c) {
        CellState& s = state.cells[c];
        s.first_batch = r.get<double>();
        s.second_batch = r.get<double>();
        s.mean = r.get<double>();
        s.m2 = r.get<double>();
        s.batch_mean = r.get<double>();
        s.batch_m2 = r.get<double>();
        s.samples = r.get<std::uint64_t>();
        s.batches = r.get<std::uint32_t>();
        s.done = r.get<std::uint8_t>() != 0;
        state.round_target[c] = r.get<std::uint32_t>();
        if (state.round_target[c] < s.batches || (s.done && state.round_target[c] != s.batches) ||
            (is_finished && !s.done))
            r.damaged("is inconsistent at cell " + std::to_string(c));
    }
    if (is_finished && stored != n) r.damaged("is inconsistent (a finished table with cells left)");
    if (finished) *finished = is_finished;
    return state;
}

// ------------------------------------------------------------- Checkpoint

Checkpoint::Checkpoint(const std::string& output_path, CheckpointKey key, bool resume,
                       double interval_seconds, bool helper)
    : dir_(checkpoint_directory(output_path)), key_(std::move(key)), interval_(interval_seconds),
      helper_(helper) {
    std::error_code ec;
    if (helper) {
        // The owner has checked (or started) the directory: use what is there.
        if (!fs::is_directory(dir_, ec))
            throw Error("checkpoint directory '" + dir_ +
                        "' is not visible to this process (the output directory must be on a "
                        "file system every process shares)");
        for (fs::directory_iterator it(dir_, ec), end; !ec && it != end; it.increment(ec))
            if (table_file_index(it->path().filename().string()) >= 0)
                stored_.push_back(it->path().filename().string());
        return;
    }
    const bool existed = fs::exists(dir_, ec);
    if (existed && !fs::is_directory(dir_, ec))
        throw InputError("checkpoint '" + dir_ + "' exists and is not a directory; remove it");
    if (existed && !resume)
        throw InputError("a checkpoint of an interrupted run exists at '" + dir_ +
                         "'; add --resume to continue it");
    if (!existed && !fs::create_directory(dir_, ec))
        throw InputError("cannot create checkpoint directory '" + dir_ + "': " + ec.message());
    lock_fd_ = ::open((dir_ + "/lock").c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (lock_fd_ < 0)
        throw InputError("cannot create '" + dir_ + "/lock': " + std::strerror(errno));
    try {
        if (::flock(lock_fd_, LOCK_EX | LOCK_NB) != 0)
            throw InputError("checkpoint '" + dir_ +
                             "' is in use by another running brdftab (same output file)");
        const std::string manifest_path = dir_ + "/manifest.json";
        bool keep_states = false;
        if (existed && fs::exists(manifest_path, ec)) {
            nlohmann::json m;
            try {
                m = nlohmann::json::parse(read_whole_file(manifest_path));
            } catch (const nlohmann::json::exception& e) {
                throw InputError("checkpoint manifest '" + manifest_path + "' is damaged (" +
                                 e.what() + "); delete '" + dir_ + "' to start over");
            }
            if (!m.is_object() || m.value("brdftab_checkpoint", 0) != kManifestFormat ||
                !m.contains("settings") || !m["settings"].is_object())
                throw InputError("checkpoint manifest '" + manifest_path +
                                 "' is not one this brdftab writes; delete '" + dir_ +
                                 "' to start over");
            std::string differences;
            for (const auto& [name, value] : key_.settings) {
                const auto& stored = m["settings"];
                const std::string was = stored.contains(name) && stored[name].is_string()
                                            ? stored[name].get<std::string>()
                                            : std::string("(not recorded)");
                if (was != value)
                    differences += "\n  " + name + ": checkpoint " + was + ", this run " + value;
            }
            if (!differences.empty() || m.value("fingerprint", "") != key_.fingerprint())
                throw InputError("cannot resume from '" + dir_ +
                                 "': it was made with other settings" +
                                 (differences.empty() ? std::string(" (fingerprint differs)")
                                                      : differences) +
                                 "\nrun with the same spec and options, or delete '" + dir_ +
                                 "' to start over");
            keep_states = true;
            if (m.contains("layout") && m["layout"].is_string()) layout_ = m["layout"];
        }
        // Index the state files (removing any that no manifest vouches for:
        // the run that wrote them died before its manifest, which cannot be).
        for (fs::directory_iterator it(dir_, ec), end; !ec && it != end; it.increment(ec)) {
            if (is_adaptive_file(it->path().filename().string())) {
                std::error_code ignored;
                if (!keep_states)
                    fs::remove(it->path(), ignored);
                else
                    ++resumed_adaptive_;
                continue;
            }
            const long k = table_file_index(it->path().filename().string());
            if (k < 0) continue;
            if (!keep_states) {
                std::error_code ignored;
                fs::remove(it->path(), ignored);
                continue;
            }
            stored_.push_back(it->path().filename().string());
            // The finished flag is at a fixed offset of the header.
            std::ifstream f(it->path(), std::ios::binary);
            char head[13] = {0};
            f.read(head, sizeof head);
            const bool chunk = it->path().filename().string().find('-', 6) != std::string::npos;
            (f && head[12] ? (chunk ? resumed_chunks_finished_ : resumed_finished_)
                           : (chunk ? resumed_chunks_partial_ : resumed_partial_)) += 1;
        }
        if (!keep_states) {
            nlohmann::json settings = nlohmann::json::object();
            for (const auto& [name, value] : key_.settings) settings[name] = value;
            const nlohmann::json m = {{"brdftab_checkpoint", kManifestFormat},
                                      {"fingerprint", key_.fingerprint()},
                                      {"settings", settings}};
            write_text_atomically(manifest_path, m.dump(2) + "\n");
        }
    } catch (...) {
        ::close(lock_fd_);
        lock_fd_ = -1;
        throw;
    }
}

Checkpoint::~Checkpoint() {  // a helper holds no lock: lock_fd_ < 0
    if (lock_fd_ >= 0) ::close(lock_fd_);
}

std::string Checkpoint::resumed_summary() const {
    const std::size_t chunks = resumed_chunks_finished_ + resumed_chunks_partial_;
    if (resumed_adaptive_ && resumed_finished_ + resumed_partial_ + chunks == 0)
        return "refinement rounds of " + std::to_string(resumed_adaptive_) + " adaptive table(s)";
    if (resumed_finished_ + resumed_partial_ + chunks == 0) return "nothing stored yet";
    std::string s = std::to_string(resumed_finished_) + " finished table(s), " +
                    std::to_string(resumed_partial_) + " in progress";
    if (chunks)
        s += "; chunks of tables: " + std::to_string(resumed_chunks_finished_) + " finished, " +
             std::to_string(resumed_chunks_partial_) + " in progress";
    return s;
}

void Checkpoint::record_layout(const std::string& layout) {
    layout_ = layout;
    if (helper_) return;
    nlohmann::json settings = nlohmann::json::object();
    for (const auto& [name, value] : key_.settings) settings[name] = value;
    const nlohmann::json m = {{"brdftab_checkpoint", kManifestFormat},
                              {"fingerprint", key_.fingerprint()},
                              {"settings", settings},
                              {"layout", layout}};
    write_text_atomically(dir_ + "/manifest.json", m.dump(2) + "\n");
}

EstimateCheckpoint Checkpoint::table(std::size_t index, const std::string& name,
                                     std::size_t cell_count) {
    return hooks(table_file(dir_, index), index, name, cell_count);
}

EstimateCheckpoint Checkpoint::chunk(std::size_t index, const std::string& name,
                                     std::size_t first, std::size_t count,
                                     std::size_t table_cells) {
    if (first == 0 && count == table_cells) return table(index, name, count);
    return hooks(chunk_file(dir_, index, first), index,
                 name + " cells " + std::to_string(first) + "+" + std::to_string(count), count);
}

EstimateCheckpoint Checkpoint::hooks(const std::string& path, std::size_t index,
                                     const std::string& name, std::size_t cell_count) {
    EstimateCheckpoint hooks;
    bool restored_finished = false;
    if (std::find(stored_.begin(), stored_.end(), fs::path(path).filename().string()) !=
        stored_.end())
        hooks.resume = decode_table_state(read_whole_file(path), index, name, key_.fingerprint(),
                                          cell_count, path, &restored_finished);
    double last_write = seconds_now(), write_cost = 0;
    hooks.save = [this, index, name, path, restored_finished, last_write,
                  write_cost](const EstimateState& state, bool finished) mutable {
        if (finished) {
            if (restored_finished) return;  // already stored as it is
            // A table computed in less than ten times the time its state
            // takes to write is cheaper to compute again than to store.
            const double bytes = static_cast<double>(state.cells.size() * kCellBytes);
            if (state.elapsed_seconds < 10 * bytes / write_rate_) return;
        } else {
            const double since = seconds_now() - last_write;
            // Writing never takes more than a tenth of the run.
            if (interval_ <= 0 || since < std::max(interval_, 10 * write_cost)) return;
        }
        const double start = seconds_now();
        const std::string bytes =
            encode_table_state(state, index, name, key_.fingerprint(), finished);
        write_bytes_atomically(path, bytes);
        last_write = seconds_now();
        write_cost = last_write - start;
        if (write_cost > 0) write_rate_ = std::max(1e6, static_cast<double>(bytes.size()) / write_cost);
    };
    return hooks;
}

std::string Checkpoint::adaptive_log(std::size_t index) const {
    const std::string path = adaptive_file(dir_, index);
    std::error_code ec;
    if (resumed_adaptive_ == 0 || !fs::exists(path, ec)) return "";
    return read_whole_file(path);
}

void Checkpoint::store_adaptive_log(std::size_t index, const std::string& bytes) {
    if (helper_) return;  // the owner stores the log
    write_bytes_atomically(adaptive_file(dir_, index), bytes);
}

std::string Checkpoint::remove() {
    std::error_code ec;
    if (helper_) return "";  // the owner removes the directory
    fs::remove_all(dir_, ec);
    if (lock_fd_ >= 0) ::close(lock_fd_);
    lock_fd_ = -1;
    return ec ? ec.message() : std::string();
}

}  // namespace brdftab
