// cli_adaptive.h — `generate --representation adaptive` (docs/adaptive.md):
// the options and the run, kept apart from cmd_compute.cpp's tensor paths.
#pragma once

#include <cstddef>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "host/cli/cli_common.h"
#include "host/spec/spec.h"

namespace brdftab {
struct AdaptiveTable;
}

namespace brdftab::cli {

struct AdaptiveCliOptions {
    // "tensor" | "adaptive" | "auto"; empty: not given (the spec's [output]
    // representation, else auto with --accuracy and tensor without).
    std::string representation;
    // Unset: the spec's [adaptive] / table `adaptive` value, else the default
    // (65536 values, 3-node patches, order 1).
    std::optional<std::size_t> max_values;
    std::optional<std::size_t> patch_nodes;
    std::optional<int> patch_order;  // 1: multilinear patches, 2: piecewise quadratic per axis
    double safety = 0;    // --refine-safety: a leaf passes at probe error <= safety x E (0: by patch order)
    std::vector<std::string> breakpoints, jumps, initial_levels;  // NAME=X / NAME=L
    bool full_precision = false;  // generate --full-precision: no rounded storage
    bool resume = false;          // generate --resume: continue from OUTPUT.checkpoint/
    bool adaptive() const { return representation == "adaptive"; }
    // The options as spec settings (NAME=X parsed; InputError naming the option).
    AdaptiveSpecSettings overrides() const;
};

void add_adaptive_options(CLI::App& cmd, AdaptiveCliOptions& o);

// Every table of the spec as an adaptive table refined to `accuracy`
// (absolute with `absolute`, else relative to max(|value|, floor)), each
// certified (certify_adaptive) and written with its certificate.  Without
// --accuracy the spec's [adaptive] accuracy and measure are used (--abs wins
// over the measure).  Exit code 1 (Error) when a certificate misses the
// accuracy; the file is written.
// The refinement rounds are checkpointed (OUTPUT.checkpoint/, --resume
// replays them: host/adaptive/adaptive_generate.h AdaptiveCheckpoint); under
// mpirun every rank refines the same tree and each round's engine run is
// shared among them (estimate_at_shared), rank 0 writing the file.
// Test hook: BRDFTAB_TEST_ADAPTIVE_STOP=K in the environment stops the run
// (exit 1, checkpoint kept) once K refinement rounds of the run, over its
// tables in order, are computed and stored.
void run_adaptive_generate(const std::string& spec_path, const std::string& output,
                           const ComputeOptions& compute, std::optional<double> accuracy, bool absolute,
                           bool quiet, const AdaptiveCliOptions& o);

// The representation `generate` uses: --representation, else the spec's
// [output] representation, else "auto" with an accuracy (--accuracy, or the
// spec's [adaptive] accuracy) and "tensor" without.
std::string generate_representation(const std::string& spec_path, const AdaptiveCliOptions& o,
                                    bool accuracy_given);

// `generate --representation auto` (docs/adaptive.md, "Choosing the
// representation"): the tensor planner's choice for the accuracy and the
// adaptive plan predicted from pilot refinements, compared on stored values;
// prints both and the choice with its reason, and returns true for adaptive.
// `accuracy` unset: the spec's [adaptive] accuracy; none is an InputError.
bool choose_generate_adaptive(const std::string& spec_path, const ComputeOptions& compute,
                              std::optional<double>& accuracy, bool& absolute, bool cubic, bool quiet,
                              const AdaptiveCliOptions& o);

// `info`'s lines for an adaptive table (axes and warps, patches, values,
// breakpoints, storage; value range with `values`).
void print_adaptive_summary(const AdaptiveTable& t, bool values);

// `query` on an adaptive table (run_query hands it over): one point from
// `fixed` (axis name -> value) or every row of `points_file`, with the
// table's own patch interpolation (no --cubic).
// Coordinates outside an axis are clamped with a warning, or refused with
// `reject`.
void run_adaptive_query(const std::string& file, const std::string& table,
                        const std::map<std::string, double>& fixed, bool cubic, bool reject,
                        const std::string& points_file, const std::string& output, bool json);

}  // namespace brdftab::cli
