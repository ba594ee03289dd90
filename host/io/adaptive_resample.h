// adaptive_resample.h — an adaptive table (docs/adaptive.md) resampled onto
// a tensor grid, for the exports that need one (`export --exr`, `--png`,
// `--merl`), with the resampling error measured.
//
// The grid keeps each axis' warp (spacing, pivot, critical node position in
// t, explicit nodes subdivided evenly in t), so its nodes follow the same
// coordinate the adaptive table was refined in; a node's value (and stderr)
// is the adaptive table's linear interpolant there.  The error is
// max |tensor linear lookup - adaptive eval| at probe points between the
// resampled nodes: every cell's centre in t when there are at most
// kResampleProbeCap cells, else that many random points uniform in t
// (seeded: deterministic).  Library code: no printing.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "host/adaptive/adaptive_table.h"
#include "host/core/table.h"

namespace brdftab {

constexpr std::size_t kResampleProbeCap = std::size_t{1} << 20;
// The default grid: this many nodes per axis, fewer where the product would
// pass kResampleDefaultValues.
constexpr std::size_t kResampleDefaultNodes = 65;
constexpr std::size_t kResampleDefaultValues = std::size_t{1} << 22;

struct ResampleOptions {
    // Nodes per axis by name (an axis not named: `nodes`, or the default);
    // at least 2 (3 on a critical axis).  A critical or explicit axis is
    // rounded up to the next count that keeps its warp (its cells
    // subdivided evenly in t).
    std::map<std::string, std::size_t> axis_nodes;
    std::size_t nodes = 0;  // 0: the default (kResampleDefaultNodes, capped)
    std::uint64_t seed = 1; // of the random probes (more cells than the cap)
};

struct ResampleReport {
    std::vector<std::size_t> counts;  // nodes per axis of the grid
    std::size_t probes = 0;
    bool probes_at_centres = true;    // false: random probes
    double max_abs = 0;               // max |tensor - adaptive| at the probes
    double max_abs_value = 0;         // max |adaptive| at the nodes (a scale)
    std::vector<double> worst;        // probe point (axis units) of max_abs
};

// The tensor table (provenance, parameters and units of `t`; axes with the
// resampled counts) and the report.  InputError for a bad count or an axis
// name that is not the table's, naming it.
TableData resample_adaptive(const AdaptiveTable& t, const ResampleOptions& options,
                            ResampleReport& report);

}  // namespace brdftab
