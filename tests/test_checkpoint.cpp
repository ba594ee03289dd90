// Checkpoint and resume (host/generate/checkpoint.h, the EstimateCheckpoint
// hook of host/engine/engine.h): an estimate continued from any stored state
// equals the uninterrupted estimate bit for bit; state files round-trip every
// bit; other settings, damaged files and a second writer are refused.
// The oracle of a resumed estimate is the uninterrupted run of the same cells.
#include <doctest/doctest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>

#include <unistd.h>

#include "host/core/error.h"
#include "host/engine/engine.h"
#include "host/generate/checkpoint.h"
#include "host/models/registry.h"
#include "host/spec/spec.h"
#include "test_support.h"

using namespace brdftab;
namespace fs = std::filesystem;

namespace {

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

void check_same_result(const EstimateResult& a, const EstimateResult& b) {
    REQUIRE(a.value.size() == b.value.size());
    for (std::size_t c = 0; c < a.value.size(); ++c) {
        CAPTURE(c);
        CHECK(same_bits(a.value[c], b.value[c]));
        CHECK(same_bits(a.stderr_[c], b.stderr_[c]));
        CHECK(a.samples[c] == b.samples[c]);
    }
    CHECK(a.total_samples == b.total_samples);
    CHECK(same_bits(a.tolerance_achieved, b.tolerance_achieved));
    CHECK(a.cells_unconverged == b.cells_unconverged);
}

void check_same_state(const EstimateState& a, const EstimateState& b) {
    REQUIRE(a.cells.size() == b.cells.size());
    REQUIRE(a.round_target == b.round_target);
    CHECK(same_bits(a.elapsed_seconds, b.elapsed_seconds));
    for (std::size_t c = 0; c < a.cells.size(); ++c) {
        CAPTURE(c);
        const CellState &x = a.cells[c], &y = b.cells[c];
        CHECK(same_bits(x.first_batch, y.first_batch));
        CHECK(same_bits(x.second_batch, y.second_batch));
        CHECK(same_bits(x.mean, y.mean));
        CHECK(same_bits(x.m2, y.m2));
        CHECK(same_bits(x.batch_mean, y.batch_mean));
        CHECK(same_bits(x.batch_m2, y.batch_m2));
        CHECK(x.samples == y.samples);
        CHECK(x.batches == y.batches);
        CHECK(x.done == y.done);
    }
}

// A few cells of one quantity on the host reference backend.
struct Cells {
    const ModelInfo& model;
    const QuantityInfo& quantity;
    std::vector<std::map<std::string, double>> points;
    EstimateResult run(Backend& backend, const IntegrationSettings& s,
                       EstimateCheckpoint* checkpoint = nullptr) const {
        PointBuilder builder(model, quantity);
        return estimate(
            backend, model, quantity, resolve_options(model, {}, "test"), points.size(),
            [&](std::size_t c, double* out) { builder.build(points[c], out); }, s, nullptr,
            checkpoint);
    }
};

// Every state the engine offers, in order.
std::vector<EstimateState> all_states(const Cells& cells, Backend& backend,
                                      const IntegrationSettings& s, EstimateResult& result) {
    std::vector<EstimateState> states;
    EstimateCheckpoint record;
    record.save = [&](const EstimateState& st, bool) { states.push_back(st); };
    result = cells.run(backend, s, &record);
    return states;
}

EstimateState sample_state() {
    EstimateState s;
    s.elapsed_seconds = 12.5;
    const double nan = std::numeric_limits<double>::quiet_NaN();
    const double inf = std::numeric_limits<double>::infinity();
    for (int c = 0; c < 5; ++c) {
        CellState x;
        x.first_batch = c == 0 ? -0.0 : 0.1 * c;
        x.second_batch = c == 1 ? nan : 1.0 / 3.0;
        x.mean = c == 2 ? inf : std::nextafter(0.5, 1.0);
        x.m2 = c == 3 ? std::numeric_limits<double>::denorm_min() : 1e-300;
        x.batch_mean = -1e300;
        x.batch_m2 = 7;
        x.samples = (std::uint64_t{1} << 40) + c;
        x.batches = 3 + c;
        x.done = c % 2 == 0;
        s.cells.push_back(x);
        s.round_target.push_back(x.done ? x.batches : x.batches + 4);
    }
    // Three cells not reached yet: left out of the file, restored as such.
    for (int c = 0; c < 3; ++c) {
        s.cells.push_back(CellState{});
        s.round_target.push_back(9);
    }
    return s;
}

struct ScratchOutput {
    fs::path dir;
    std::string output;
    ScratchOutput() {
        dir = fs::temp_directory_path() /
              ("bt_checkpoint_test_" + std::to_string(static_cast<long>(::getpid())));
        fs::remove_all(dir);
        fs::create_directories(dir);
        output = (dir / "out.h5").string();
    }
    ~ScratchOutput() {
        std::error_code ec;
        fs::remove_all(dir, ec);
    }
};

CheckpointKey key_for(std::uint64_t seed, const std::string& spec_text = "model = \"x\"\n") {
    Spec spec;
    spec.text = spec_text;
    IntegrationSettings s;
    s.seed = seed;
    auto host = make_backend("host", Precision::Double);
    return checkpoint_key(spec, s, *host, "");
}

}  // namespace

TEST_CASE("an estimate continued from any stored state equals the uninterrupted one") {
    auto host = make_backend("host", Precision::Double);
    const ModelInfo& rd = find_model("rough-dielectric");
    const Cells albedo{rd,
                       rd.quantity("albedo_r"),
                       {{{"theta_i", 10}, {"alpha", 0.2}, {"eta", 1.5}},
                        {{"theta_i", 50}, {"alpha", 0.05}, {"eta", 1.33}},
                        {{"theta_i", 80}, {"alpha", 0.6}, {"eta", 2.0}},
                        {{"theta_i", 30}, {"alpha", 0.9}, {"eta", 1.1}}}};
    const ModelInfo& on = find_model("oren-nayar");
    const Cells quadrature{on,
                           on.quantity("brdf"),
                           {{{"theta_i", 20}, {"theta_o", 40}, {"phi_d", 30}, {"sigma", 20}},
                            {{"theta_i", 60}, {"theta_o", 10}, {"phi_d", 150}, {"sigma", 35}}}};
    struct Case {
        const char* name;
        const Cells* cells;
        IntegrationSettings settings;
    };
    std::vector<Case> cases;
    for (const char* method : {"mc", "rqmc"}) {
        IntegrationSettings fixed;
        fixed.method = parse_method(method);
        fixed.samples = 1024;
        fixed.batch_size = 128;  // several batches per cell, straddling launches
        fixed.slab_work_items = 3;
        cases.push_back({method, &albedo, fixed});
        IntegrationSettings adaptive = fixed;
        adaptive.samples = 256;
        adaptive.batch_size = 32;
        adaptive.tolerance = 0.01;  // cells stop after different numbers of rounds
        adaptive.max_samples = 1u << 13;
        cases.push_back({method, &albedo, adaptive});
    }
    IntegrationSettings quad;
    quad.slab_work_items = 1;
    cases.push_back({"quadrature", &quadrature, quad});

    for (const Case& c : cases) {
        CAPTURE(c.name);
        CAPTURE(c.settings.tolerance);
        EstimateResult uninterrupted;
        const std::vector<EstimateState> states =
            all_states(*c.cells, *host, c.settings, uninterrupted);
        REQUIRE(states.size() >= 3);
        // The state offered last is the finished one.
        for (const CellState& s : states.back().cells) CHECK(s.done);
        for (std::size_t k = 0; k < states.size(); ++k) {
            CAPTURE(k);
            EstimateCheckpoint from;
            from.resume = states[k];
            std::size_t saves = 0;
            from.save = [&](const EstimateState&, bool) { ++saves; };
            const EstimateResult resumed = c.cells->run(*host, c.settings, &from);
            check_same_result(resumed, uninterrupted);
            CHECK(resumed.method == uninterrupted.method);
            // No work is repeated: a continued run makes only the launches
            // left (the same ones), then offers its final state.
            CHECK(saves == (k + 1 < states.size() ? states.size() - k - 1 : 1));
        }
    }
}

TEST_CASE("a state that cannot belong to the table is refused by the engine") {
    auto host = make_backend("host", Precision::Double);
    const ModelInfo& rd = find_model("rough-dielectric");
    const Cells one{rd, rd.quantity("albedo_r"), {{{"theta_i", 10}, {"alpha", 0.2}, {"eta", 1.5}}}};
    IntegrationSettings s;
    s.samples = 64;
    EstimateCheckpoint wrong_size;
    wrong_size.resume = EstimateState{};
    wrong_size.resume->cells.resize(2);
    wrong_size.resume->round_target.resize(2);
    CHECK_THROWS_AS(one.run(*host, s, &wrong_size), Error);
    EstimateCheckpoint beyond_target;
    beyond_target.resume = EstimateState{};
    beyond_target.resume->cells.resize(1);
    beyond_target.resume->cells[0].batches = 5;
    beyond_target.resume->round_target = {4};
    CHECK_THROWS_AS(one.run(*host, s, &beyond_target), Error);
}

TEST_CASE("state files round-trip every bit, trailing cells not reached included") {
    const EstimateState s = sample_state();
    const std::string fp = key_for(1).fingerprint();
    const std::string bytes = encode_table_state(s, 2, "albedo_r", fp, false);
    bool finished = true;
    check_same_state(decode_table_state(bytes, 2, "albedo_r", fp, s.cells.size(), "f", &finished), s);
    CHECK_FALSE(finished);
    // The three cells not reached are not stored: the file is shorter than
    // one holding every cell.
    EstimateState all_reached = s;
    for (CellState& c : all_reached.cells) c.batches = std::max<std::uint32_t>(c.batches, 1);
    CHECK(encode_table_state(all_reached, 2, "albedo_r", fp, false).size() > bytes.size());
}

TEST_CASE("damaged or foreign state files are refused with InputError") {
    const EstimateState s = sample_state();
    const std::string fp = key_for(1).fingerprint();
    const std::string bytes = encode_table_state(s, 0, "t", fp, false);
    const std::size_t n = s.cells.size();
    for (std::size_t at : {std::size_t{0}, std::size_t{13}, std::size_t{60}, bytes.size() / 2,
                           bytes.size() - 1}) {
        CAPTURE(at);
        std::string bad = bytes;
        bad[at] = static_cast<char>(bad[at] ^ 0x20);
        CHECK_THROWS_AS(decode_table_state(bad, 0, "t", fp, n, "f"), InputError);
    }
    CHECK_THROWS_AS(decode_table_state(bytes.substr(0, bytes.size() - 9), 0, "t", fp, n, "f"),
                    InputError);
    CHECK_THROWS_AS(decode_table_state("", 0, "t", fp, n, "f"), InputError);
    CHECK_THROWS_AS(decode_table_state(bytes, 1, "t", fp, n, "f"), InputError);      // index
    CHECK_THROWS_AS(decode_table_state(bytes, 0, "u", fp, n, "f"), InputError);      // name
    CHECK_THROWS_AS(decode_table_state(bytes, 0, "t", fp, n + 1, "f"), InputError);  // cells
    CHECK_THROWS_AS(decode_table_state(bytes, 0, "t", key_for(2).fingerprint(), n, "f"),
                    InputError);
    // A finished state must have every cell done.
    CHECK_THROWS_AS(decode_table_state(encode_table_state(s, 0, "t", fp, true), 0, "t", fp, n, "f"),
                    InputError);
}

TEST_CASE("the key holds every setting that changes values, and only those") {
    const CheckpointKey a = key_for(1);
    CHECK(a.fingerprint() == key_for(1).fingerprint());
    CHECK(a.fingerprint() != key_for(2).fingerprint());
    CHECK(a.fingerprint() != key_for(1, "model = \"y\"\n").fingerprint());
    Spec spec;
    auto host = make_backend("host", Precision::Double);
    IntegrationSettings base;
    const std::string f0 = checkpoint_key(spec, base, *host, "").fingerprint();
    auto differs = [&](auto change) {
        IntegrationSettings s = base;
        change(s);
        return checkpoint_key(spec, s, *host, "").fingerprint() != f0;
    };
    CHECK(differs([](IntegrationSettings& s) { s.method = Method::MonteCarlo; }));
    CHECK(differs([](IntegrationSettings& s) { s.samples = 100; }));
    CHECK(differs([](IntegrationSettings& s) { s.tolerance = 0.01; }));
    CHECK(differs([](IntegrationSettings& s) { s.abs_floor = 1e-7; }));
    CHECK(differs([](IntegrationSettings& s) { s.max_samples = 5; }));
    CHECK(differs([](IntegrationSettings& s) { s.batch_size = 64; }));
    CHECK_FALSE(differs([](IntegrationSettings& s) { s.slab_work_items = 7; }));
    CHECK(checkpoint_key(spec, base, *host, "/some/kernels").fingerprint() != f0);
}

TEST_CASE("a checkpoint on disk: stored, resumed, refused with other settings, locked") {
    ScratchOutput out;
    const EstimateState s = sample_state();
    const std::size_t n = s.cells.size();
    CHECK(checkpoint_presence(out.output) == CheckpointPresence::None);
    {
        Checkpoint cp(out.output, key_for(1), false, 0);
        CHECK(fs::is_directory(cp.directory()));
        CHECK(checkpoint_presence(out.output) == CheckpointPresence::InUse);
        // A second writer of the same output is refused.
        CHECK_THROWS_AS(Checkpoint(out.output, key_for(1), true, 0), InputError);
        EstimateCheckpoint t0 = cp.table(0, "a", n);
        CHECK_FALSE(t0.resume.has_value());
        t0.save(s, false);  // interval 0: states in progress are not stored
        CHECK_FALSE(fs::exists(cp.directory() + "/table-0.state"));
        EstimateState done = s;
        for (std::size_t c = 0; c < n; ++c) {
            done.cells[c].done = true;
            done.round_target[c] = done.cells[c].batches;
        }
        t0.save(done, true);
        CHECK(fs::exists(cp.directory() + "/table-0.state"));
    }
    // The process that held it is gone: an interrupted run.
    CHECK(checkpoint_presence(out.output) == CheckpointPresence::Interrupted);
    // Without --resume an existing checkpoint is not touched.
    CHECK_THROWS_AS(Checkpoint(out.output, key_for(1), false, 0), InputError);
    // Other settings: refused, naming what differs.
    try {
        Checkpoint other(out.output, key_for(2), true, 0);
        FAIL("resumed with another seed");
    } catch (const InputError& e) {
        CHECK(std::string(e.what()).find("seed: checkpoint 1, this run 2") != std::string::npos);
    }
    {
        Checkpoint cp(out.output, key_for(1), true, 1e-9);
        CHECK(cp.resumed_summary() == "1 finished table(s), 0 in progress");
        EstimateCheckpoint t0 = cp.table(0, "a", n);
        REQUIRE(t0.resume.has_value());
        for (const CellState& c : t0.resume->cells) CHECK(c.done);
        CHECK(t0.resume->cells[3].samples == s.cells[3].samples);
        // Table 1 has no state yet; with an interval, states in progress are
        // stored and read back bit for bit.
        EstimateCheckpoint t1 = cp.table(1, "b", n);
        CHECK_FALSE(t1.resume.has_value());
        t1.save(s, false);
        CHECK(fs::exists(cp.directory() + "/table-1.state"));
    }
    {
        Checkpoint cp(out.output, key_for(1), true, 0);
        CHECK(cp.resumed_summary() == "1 finished table(s), 1 in progress");
        EstimateCheckpoint t1 = cp.table(1, "b", n);
        REQUIRE(t1.resume.has_value());
        check_same_state(*t1.resume, s);
        CHECK(cp.remove().empty());
    }
    CHECK(checkpoint_presence(out.output) == CheckpointPresence::None);
    CHECK_FALSE(fs::exists(out.output + ".checkpoint"));
}
