// test_launch_support.h — what the tests that compare two launches of the
// engine on the same cells share (the sample-parallel and walk-parallel
// launches against the usual kernel): estimate() over named cells, and a
// bit-for-bit comparison of two results.
#pragma once

#include <doctest/doctest.h>

#include <map>
#include <string>
#include <vector>

#include "host/engine/engine.h"
#include "host/models/registry.h"

namespace brdftab::test {

// estimate() of `q` over `cells` (parameter and direction values by name,
// built into kernel points by PointBuilder), with the options `given`
// resolved as a spec's would be.
inline EstimateResult estimate_cells(Backend& backend, const ModelInfo& m, const QuantityInfo& q,
                                     const std::vector<std::map<std::string, double>>& cells,
                                     const IntegrationSettings& s,
                                     const nlohmann::json& given = nlohmann::json::object()) {
    PointBuilder builder(m, q);
    const std::vector<int> options = resolve_options(m, given, "test");
    return estimate(
        backend, m, q, options, cells.size(),
        [&](std::size_t c, double* out) { builder.build(cells[c], out); }, s);
}

// The same bits: == on the doubles of every cell (value, standard error),
// the same sample counts, per cell and in total.
inline void check_same_bits(const EstimateResult& a, const EstimateResult& b) {
    REQUIRE(a.value.size() == b.value.size());
    for (std::size_t c = 0; c < a.value.size(); ++c) {
        CAPTURE(c);
        CHECK(a.value[c] == b.value[c]);
        CHECK(a.stderr_[c] == b.stderr_[c]);
        CHECK(a.samples[c] == b.samples[c]);
    }
    CHECK(a.total_samples == b.total_samples);
}

}  // namespace brdftab::test
