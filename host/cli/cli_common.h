// cli_common.h — pieces shared by the CLI subcommands: device/integration
// options, progress display, name=value parsing.  Only the CLI prints.
#pragma once

#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdio>
#include <functional>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "host/engine/engine.h"
#include "host/generate/generate.h"
#include "host/io/point_file.h"
#include "host/models/registry.h"

namespace brdftab {
struct Certificate;
}

namespace brdftab::cli {

// Options every computing subcommand accepts.
struct ComputeOptions {
    std::string device;  // "" = $BRDFTAB_DEVICE or first CPU; "host" = serial reference
    std::string precision = "double";
    std::string kernel_dir;
    std::string method;  // empty = keep spec / auto
    std::uint64_t samples = 0;
    double tolerance = 0;
    double abs_floor = -1;
    std::uint64_t max_samples = 0;
    std::string seed_text;  // as typed: parse_seed() judges it
    bool seed_given = false;
    bool samples_given = false, tolerance_given = false, max_samples_given = false;
    std::string samples_text, max_samples_text;  // as typed (for messages: -1 wraps)
    std::size_t slab = 0;

    void add_to(CLI::App& app, bool with_integration = true);
    // Apply CLI overrides on top of `base` (from a spec or defaults).  Throws
    // InputError naming the option when --samples / --max-samples are outside
    // [1, 2^32 - 1], --tolerance outside (0, 1) or --seed not an integer in
    // [0, 2^64 - 1].
    IntegrationSettings apply(IntegrationSettings base) const;
    std::unique_ptr<Backend> make_backend() const;
};

// Progress on stderr: a redrawn bar on a terminal (at most 10 redraws a
// second), otherwise a plain line every 30 s ($BRDFTAB_PROGRESS_INTERVAL
// seconds when set), each with cells done, samples/s, elapsed time and ETA.
class ProgressPrinter {
public:
    // `sampled`: the run draws samples (Monte Carlo, RQMC), so its rate is
    // shown in samples/s; otherwise (closed form, quadrature) in cells/s.
    explicit ProgressPrinter(std::string label, bool sampled = true);
    void operator()(const Progress& p);
    void finish();

private:
    std::string label_;
    bool sampled_;
    bool tty_;
    std::chrono::steady_clock::time_point last_;
    double interval_;
    bool printed_ = false;
    double last_fraction_ = -1;
};

// The progress display of generate_tables() and friends: one ProgressPrinter
// per table, labelled "[<prefix>k/n] <table>"; nothing when `quiet`.  The
// callback refers to this object, which must outlive the run.
class TableProgress {
public:
    explicit TableProgress(bool quiet, std::string prefix = "")
        : quiet_(quiet), prefix_(std::move(prefix)) {}
    GenerateProgressFn callback();
    void finish();  // ends the last table's display
    // Whether a table's run draws samples (ProgressPrinter's `sampled`;
    // null: every table does).
    std::function<bool(const TableSpec&)> sampled;

private:
    bool quiet_;
    std::string prefix_;
    std::unique_ptr<ProgressPrinter> printer_;
    std::size_t current_ = static_cast<std::size_t>(-1);
};

// Split "name=value"; throws InputError naming the argument.  Numbers are
// read with brdftab::parse_number (host/io/point_file.h).
std::pair<std::string, std::string> split_assignment(const std::string& arg);

// A byte count with an optional binary suffix: "1048576", "512M", "8G",
// "1.5T" (K, M, G, T = powers of 1024; an optional trailing "B" or "iB").
// Throws InputError naming `option`.
std::uint64_t parse_byte_size(const std::string& text, const std::string& option);
// "1.50 GiB" etc.
std::string format_bytes(double bytes);

// Full precision ("%.17g") and short ("%.6g") number formatting.
std::string format_double(double v);
std::string format_short(double v);

// Check for output-path options: an empty path (`-o ""`) is an error (exit
// code 2), never a silent fall-back to a default path or to stdout.
CLI::Validator non_empty_path();
// A number in (min or [min, max]; the message names `allowed` (e.g. "> 0")
// rather than CLI11's range up to the largest double.
CLI::Validator number_in(double min, bool min_inclusive, double max, const std::string& allowed);

// A seed option's text (`option` names it in the message) as a 64-bit seed:
// decimal digits only, at most 2^64 - 1.  Throws InputError naming the option,
// the text and the range otherwise; CLI11 itself would read "-1" as 2^64 - 1
// and saturate larger values without a word.
std::uint64_t parse_seed(const std::string& option, const std::string& text);

// Human formatting.
std::string format_seconds(double s);
std::string format_count(double n);

// MemAvailable of /proc/meminfo in bytes; 0 when unknown (not Linux).  Used by
// the memory pre-checks of `generate` and `scene`.
double available_memory();

// A number in three significant digits (%.3g; "inf"/"nan"), for error targets
// and certificate figures.
std::string sci_text(double v);

// A certificate's figures as `generate --accuracy`, `certify` and `info` print
// them: "max absolute total error E at (axis x, ...), RMS R; target T".
// A value and the target it is compared with, each with 3 significant
// digits, or as many more (up to 17) as it takes for the two texts to differ
// when the numbers do: a miss of 0.0010013 against 0.001 reads "0.0010013".
std::pair<std::string, std::string> compared_text(double value, double target);
std::string certificate_error_text(const Certificate& c);
// Whether `spec`'s table `t` is computed by sampling (MC, RQMC) under
// `requested` (the run's method setting), not by a closed form or quadrature.
bool table_is_sampled(const Spec& spec, const TableSpec& t, Method requested);

// Free bytes (for an unprivileged user) on the file system of `path`'s
// directory; negative when unknown.
double free_disk_space(const std::string& path);

}  // namespace brdftab::cli
