// adaptive_generate.cpp — engine-computed adaptive tables and their
// certificate (adaptive_generate.h).
#include "host/adaptive/adaptive_generate.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>

#include "host/adaptive/adaptive_io.h"
#include "host/core/error.h"
#include "host/core/splitmix.h"
#include "host/engine/evaluate.h"
#include "host/generate/chunked.h"
#include "host/plan/plan.h"

namespace brdftab {

namespace {

double now_seconds() {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// The model inputs of a table: its fixed parameters and options from the
// table's `parameters` (keys the model does not know describe the storage).
struct ModelInputs {
    const ModelInfo* model = nullptr;
    const QuantityInfo* quantity = nullptr;
    std::map<std::string, double> fixed;
    std::vector<int> options;
};

ModelInputs model_inputs(const TableData& t) {
    ModelInputs m;
    m.model = &find_model(t.model);
    m.quantity = &m.model->quantity(t.quantity);
    nlohmann::json option_values = nlohmann::json::object();
    if (t.parameters.is_object())
        for (auto it = t.parameters.begin(); it != t.parameters.end(); ++it) {
            if (it.value().is_number() && (m.model->find_parameter(it.key()) || is_direction_coordinate(it.key())))
                m.fixed[it.key()] = it.value().get<double>();
            else if (it.value().is_string() && m.model->find_option(it.key()))
                option_values[it.key()] = it.value();
        }
    m.options = resolve_options(*m.model, option_values, "table '" + t.name + "' parameters");
    return m;
}

// Kernel points of `count` points in t.
std::vector<double> kernel_points_of(const AdaptiveTable& t, const ModelInputs& in,
                                     const std::map<std::string, double>& fixed, std::size_t count,
                                     const double* tp) {
    const std::size_t d = t.data.axes.size();
    std::vector<std::map<std::string, double>> named(count, fixed);
    std::vector<double> x(d);
    for (std::size_t k = 0; k < count; ++k) {
        t.to_x(tp + k * d, x.data());
        for (std::size_t a = 0; a < d; ++a) named[k][t.data.axes[a].name] = x[a];
    }
    return build_kernel_points(*in.model, *in.quantity, named,
                               [&](std::size_t) { return "table '" + t.data.name + "'"; });
}

// The refinement log of a table (AdaptiveCheckpoint): per round its points
// in t and the engine's results, in the machine's byte order.
struct LoggedRound {
    std::vector<double> t, value, stderr_;
    std::uint64_t total_samples = 0, unconverged = 0;
    double achieved = 0;
};

constexpr char kLogMagic[8] = {'B', 'T', 'A', 'D', 'L', 'O', 'G', '\x01'};
constexpr std::uint32_t kLogByteOrder = 0x01020304u;

std::uint64_t log_checksum(const std::string& b, std::size_t n) {
    std::uint64_t h = 0xcbf29ce484222325ull;  // FNV-1a 64
    for (std::size_t k = 0; k < n; ++k) {
        h ^= static_cast<unsigned char>(b[k]);
        h *= 0x100000001b3ull;
    }
    return h;
}

template <class T>
void put(std::string& out, const T& v) {
    out.append(reinterpret_cast<const char*>(&v), sizeof v);
}

void put_doubles(std::string& out, const std::vector<double>& v) {
    put<std::uint64_t>(out, v.size());
    out.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(double));
}

std::string encode_log(const std::vector<LoggedRound>& rounds, const std::string& fingerprint,
                       const std::string& table, std::size_t dims) {
    std::string out(kLogMagic, sizeof kLogMagic);
    put(out, kLogByteOrder);
    put<std::uint64_t>(out, fingerprint.size());
    out += fingerprint;
    put<std::uint64_t>(out, table.size());
    out += table;
    put<std::uint64_t>(out, dims);
    put<std::uint64_t>(out, rounds.size());
    for (const LoggedRound& r : rounds) {
        put(out, r.total_samples);
        put(out, r.unconverged);
        put(out, r.achieved);
        put_doubles(out, r.t);
        put_doubles(out, r.value);
        put_doubles(out, r.stderr_);
    }
    put(out, log_checksum(out, out.size()));
    return out;
}

std::vector<LoggedRound> decode_log(const std::string& b, const std::string& fingerprint,
                                    const std::string& table, std::size_t dims) {
    const std::string what = "the checkpointed refinement of table '" + table + "'";
    auto damaged = [&](const std::string& why) {
        throw InputError(what + " " + why + "; delete the checkpoint directory to start over");
    };
    std::uint64_t sum = 0;
    if (b.size() < sizeof kLogMagic + 8) damaged("is truncated");
    std::memcpy(&sum, b.data() + b.size() - 8, 8);
    if (sum != log_checksum(b, b.size() - 8)) damaged("is damaged (checksum mismatch)");
    std::size_t pos = 0;
    auto need = [&](std::size_t n) {
        if (b.size() - 8 - pos < n) damaged("is truncated");
    };
    auto get = [&](auto& v) {
        need(sizeof v);
        std::memcpy(&v, b.data() + pos, sizeof v);
        pos += sizeof v;
    };
    auto text = [&]() {
        std::uint64_t n = 0;
        get(n);
        need(n);
        std::string s = b.substr(pos, n);
        pos += n;
        return s;
    };
    auto doubles = [&](std::vector<double>& v) {
        std::uint64_t n = 0;
        get(n);
        if (n > (b.size() - 8 - pos) / sizeof(double)) damaged("is truncated");
        v.resize(n);
        std::memcpy(v.data(), b.data() + pos, n * sizeof(double));
        pos += n * sizeof(double);
    };
    need(sizeof kLogMagic);
    if (b.compare(0, sizeof kLogMagic, kLogMagic, sizeof kLogMagic) != 0) damaged("is not a brdftab refinement log");
    pos = sizeof kLogMagic;
    std::uint32_t order = 0;
    get(order);
    if (order != kLogByteOrder) damaged("was written on a machine of another byte order");
    if (text() != fingerprint) damaged("belongs to other settings");
    if (text() != table) damaged("holds another table");
    std::uint64_t d = 0, count = 0;
    get(d);
    get(count);
    if (d != dims) damaged("has another number of axes");
    std::vector<LoggedRound> rounds(count);
    for (LoggedRound& r : rounds) {
        get(r.total_samples);
        get(r.unconverged);
        get(r.achieved);
        doubles(r.t);
        doubles(r.value);
        doubles(r.stderr_);
        if (r.t.size() != r.value.size() * dims || (!r.stderr_.empty() && r.stderr_.size() != r.value.size()))
            damaged("is inconsistent");
    }
    if (pos != b.size() - 8) damaged("has trailing bytes");
    return rounds;
}

}  // namespace

AdaptiveGenerated generate_adaptive(const Spec& spec, std::size_t table, Backend& backend,
                                    const IntegrationSettings& settings,
                                    const AdaptiveGenerateOptions& options, const AdaptiveRoundFn& round) {
    const double start = now_seconds();
    const TableSpec& ts = spec.tables.at(table);
    const ModelInfo& model = find_model(spec.model);
    const QuantityInfo& q = model.quantity(ts.quantity);
    const std::vector<int> opts = resolve_options(model, ts.options, "table '" + ts.name + "' options");
    const Method method = resolve_method(q, settings.method);
    AdaptiveGenerated g;
    AdaptiveTable& t = g.table;
    t.data = generate_detail::describe_table(spec, backend, settings, table, opts, method);
    const std::size_t d = t.data.axes.size();
    if (d == 0) throw InputError("table '" + ts.name + "': an adaptive table needs at least one axis");

    // Breakpoints in t, per axis.
    AdaptiveBuildOptions build = options.build;
    build.breakpoints.assign(d, {});
    for (const NamedBreakpoint& b : options.breakpoints) {
        std::size_t a = 0;
        while (a < d && t.data.axes[a].name != b.axis) ++a;
        if (a == d) throw InputError("breakpoint on '" + b.axis + "': table '" + ts.name + "' has no such axis");
        const Axis& ax = t.data.axes[a];
        if (ax.dependent())
            throw InputError("breakpoint on '" + b.axis + "': its warp depends on '" + ax.depends_on +
                             "', so a fixed value is no plane of t (its critical node is one already)");
        if (!(b.x > std::min(ax.min, ax.max) && b.x < std::max(ax.min, ax.max)))
            throw InputError("breakpoint " + b.axis + " = " + std::to_string(b.x) + " lies outside the axis' open range (" +
                             std::to_string(ax.min) + ", " + std::to_string(ax.max) + ")");
        build.breakpoints[a].push_back({ax.unwarp(b.x), b.jump});
    }
    if (options.critical_breakpoints)
        for (std::size_t a = 0; a < d; ++a)
            if (t.data.axes[a].spacing == Spacing::Critical)
                build.breakpoints[a].push_back(
                    {double(t.data.axes[a].critical_node) / double(t.data.axes[a].count - 1), false});
    for (auto& list : build.breakpoints) {
        std::sort(list.begin(), list.end(), [](const auto& x, const auto& y) { return x.t < y.t; });
        list.erase(std::unique(list.begin(), list.end(), [](const auto& x, const auto& y) { return x.t == y.t; }),
                   list.end());
    }
    t.breakpoints_t.assign(d, {});
    t.breakpoint_jump.assign(d, {});
    for (std::size_t a = 0; a < d; ++a)
        for (const AdaptiveBreakpoint& b : build.breakpoints[a]) {
            t.breakpoints_t[a].push_back(b.t);
            t.breakpoint_jump[a].push_back(b.jump);
        }

    const ModelInputs in = model_inputs(t.data);
    std::map<std::string, double> fixed = ts.fixed;
    IntegrationSettings s = settings;
    s.method = method;
    std::uint64_t cell_base = settings.cell_base;
    std::uint64_t total_samples = 0;
    double achieved = 0;
    std::size_t unconverged = 0;
    const bool with_stderr = t.data.keep_stderr;
    const AdaptiveEstimator estimator =
        options.estimator ? options.estimator
                          : AdaptiveEstimator([&](const ModelInfo& m, const QuantityInfo& qi, const std::vector<int>& o,
                                                  const std::vector<double>& points, const IntegrationSettings& is) {
                                return estimate_at(backend, m, qi, o, points, is);
                            });
    AdaptiveCheckpoint* ck = options.checkpoint;
    std::vector<LoggedRound> log;
    if (ck && !ck->stored.empty()) log = decode_log(ck->stored, ck->fingerprint, ts.name, d);
    std::size_t round_index = 0;
    if (ck) ck->replayed_rounds = 0;
    const AdaptiveBatchFn batch = [&](std::size_t count, const double* tp, double* value, double* err) {
        LoggedRound r;
        if (round_index < log.size()) {
            // A logged round: the same points (bit for bit), the logged results.
            r = log[round_index];
            if (r.value.size() != count || std::memcmp(r.t.data(), tp, count * d * sizeof(double)) != 0)
                throw InputError("the checkpointed refinement of table '" + ts.name + "' asked for other points in "
                                 "round " + std::to_string(round_index + 1) +
                                 " than this run; delete the checkpoint directory to start over");
            ++ck->replayed_rounds;
        } else {
            const std::vector<double> points = kernel_points_of(t, in, fixed, count, tp);
            s.cell_base = cell_base;
            EstimateResult e = estimator(model, q, opts, points, s);
            r.t.assign(tp, tp + count * d);
            r.value = std::move(e.value);
            r.stderr_ = std::move(e.stderr_);
            r.total_samples = e.total_samples;
            r.achieved = e.tolerance_achieved;
            r.unconverged = e.cells_unconverged;
        }
        cell_base += count;
        total_samples += r.total_samples;
        achieved = std::max(achieved, r.achieved);
        unconverged += r.unconverged;
        for (std::size_t k = 0; k < count; ++k) {
            value[k] = r.value[k];
            if (err) err[k] = k < r.stderr_.size() ? r.stderr_[k] : 0.0;
        }
        if (ck && round_index >= log.size()) {
            log.push_back(std::move(r));
            if (ck->save) ck->save(encode_log(log, ck->fingerprint, ts.name, d));
        }
        ++round_index;
    };
    std::vector<double> values, stderrs;
    g.report = build_adaptive(d, build, batch, with_stderr, t.layout, values, stderrs, round);
    t.data.value = std::move(values);
    if (with_stderr) t.data.stderr_ = std::move(stderrs);
    t.target = build.target;
    t.absolute = build.absolute;
    t.estimated_max = g.report.estimated_max;
    t.data.total_samples = total_samples;
    t.data.tolerance_achieved = achieved;
    g.seconds = now_seconds() - start;
    t.data.elapsed_seconds = g.seconds;
    return g;
}

Certificate certify_adaptive(const AdaptiveTable& t, Backend& backend, const CertifyOptions& options,
                             const ProgressFn& progress, const AdaptiveEstimator& estimator) {
    const double start = now_seconds();
    if (!(options.target > 0) || !std::isfinite(options.target))
        throw InputError("certificate target must be a positive number");
    if (options.interpolation != Interpolation::Linear)
        throw InputError("table '" + t.data.name + "' is adaptive: it is certified with its own patch "
                         "interpolation (--interpolation linear)");
    if (t.data.kind != TableKind::Computed)
        throw InputError("table '" + t.data.name + "' is " + method_attribute(t.data) +
                         ": only computed tables can be certified");
    ModelInputs in = model_inputs(t.data);
    const ModelInfo& model = *in.model;
    const QuantityInfo& q = *in.quantity;
    const bool integral = q.kind != QuantityKind::ClosedForm;
    std::map<std::string, double> fixed = in.fixed;
    const double finer = finer_rule_nodes(model, q, fixed);
    if (finer > 0) fixed["nodes"] = finer;
    const std::size_t d = t.data.axes.size();
    const AdaptiveLayout& L = t.layout;

    double max_table = 0;
    for (double v : t.data.value)
        if (std::isfinite(v)) max_table = std::max(max_table, std::fabs(v));
    const double floor = options.absolute ? 0.0
                         : options.abs_floor > 0 ? options.abs_floor
                                                 : std::max(options.rel_floor_factor * max_table, 1e-300);
    IntegrationSettings ref;
    ref.method = resolve_method(q, Method::Auto);
    ref.seed = t.data.seed * 0x9E3779B97F4A7C15ull + options.seed + 0xCE27;
    if (integral) {
        const double noise = options.reference_noise_fraction * options.target;
        ref.tolerance = options.absolute ? 1e-12 : std::min(noise, 0.5);
        ref.abs_floor = options.absolute ? noise : noise * floor;
        ref.max_samples = options.reference_max_samples;
    }

    Certificate c;
    c.table = t.data.name;
    c.target = options.target;
    c.absolute = options.absolute;
    c.abs_floor = floor;
    c.interpolation = Interpolation::Linear;
    for (const Axis& ax : t.data.axes) c.axis_names.push_back(ax.name);
    c.axis_max.assign(d, 0.0);
    c.max_at.assign(d, 0.0);
    double sum2 = 0;
    bool have = false;
    std::vector<std::pair<double, std::vector<double>>> worst;  // (error, t)
    std::uint64_t cell_base = 0;

    // Evaluates probes (in t) and folds them in; `random`: they count in the RMS.
    auto evaluate = [&](const std::vector<double>& tp, bool random, std::size_t& counter) {
        const std::size_t n = tp.size() / d;
        if (n == 0) return;
        const std::vector<double> points = kernel_points_of(t, in, fixed, n, tp.data());
        ref.cell_base = cell_base;
        const EstimateResult r = estimator ? estimator(model, q, in.options, points, ref)
                                           : estimate_at(backend, model, q, in.options, points, ref, progress);
        cell_base += n;
        c.reference_method = to_string(r.method);
        std::vector<double> x(d);
        for (std::size_t k = 0; k < n; ++k) {
            const double* p = tp.data() + k * d;
            const double v = L.eval(p, t.data.value.data());
            const double den = options.absolute ? 1.0 : std::max(std::fabs(r.value[k]), floor);
            double e = std::fabs(v - r.value[k]) / den;
            if (!std::isfinite(e)) e = std::numeric_limits<double>::infinity();
            if (integral && k < r.stderr_.size()) c.reference_noise = std::max(c.reference_noise, r.stderr_[k] / den);
            t.to_x(p, x.data());
            if (!have || e > c.max_error) {
                c.max_error = e;
                c.max_at = x;
                have = true;
            }
            if (random) sum2 += e * e;
            worst.emplace_back(e, std::vector<double>(p, p + d));
            ++counter;
            ++c.probes;
        }
    };

    SplitMix rng{options.seed * 0x9E3779B97F4A7C15ull + t.data.seed + 0xADA7};
    const std::size_t nr = integral ? options.integral_random_points : options.random_points;
    std::vector<double> tp;
    for (std::size_t k = 0; k < nr; ++k)
        for (std::size_t a = 0; a < d; ++a) tp.push_back(rng.uniform());
    evaluate(tp, true, c.random_probes);
    // Every leaf's centre and a random point inside it (leaves beyond the cap
    // drawn at random).
    tp.clear();
    const std::size_t leaves = L.leaf_count();
    const std::size_t cap = integral ? options.integral_local_probe_cap : options.local_probe_cap;
    const std::size_t per_leaf = std::min<std::size_t>(2, std::max<std::size_t>(1, cap / std::max<std::size_t>(leaves, 1)));
    for (std::size_t l = 0; l < leaves; ++l) {
        if (leaves * per_leaf > cap && rng.uniform() * double(leaves * per_leaf) > double(cap)) continue;
        const double* b = L.box.data() + l * d * 2;
        for (std::size_t a = 0; a < d; ++a) tp.push_back(0.5 * (b[2 * a] + b[2 * a + 1]));
        if (per_leaf > 1)
            for (std::size_t a = 0; a < d; ++a) tp.push_back(b[2 * a] + rng.uniform() * (b[2 * a + 1] - b[2 * a]));
    }
    evaluate(tp, false, c.local_probes);
    // Local search in the leaves of the worst probes.
    std::stable_sort(worst.begin(), worst.end(), [](const auto& x, const auto& y) { return x.first > y.first; });
    const std::size_t nw = std::min(worst.size(), integral ? options.integral_local_worst : options.local_worst);
    tp.clear();
    for (std::size_t w = 0; w < nw; ++w) {
        const std::size_t l = L.leaf_of(worst[w].second.data());
        const double* b = L.box.data() + l * d * 2;
        std::size_t combos = 1;
        for (std::size_t a = 0; a < d; ++a) combos *= 3;
        for (std::size_t cidx = 0; cidx < combos; ++cidx) {
            std::size_t r = cidx;
            for (std::size_t a = 0; a < d; ++a) {
                const double f = 0.25 * double(1 + r % 3);
                r /= 3;
                tp.push_back(b[2 * a] + f * (b[2 * a + 1] - b[2 * a]));
            }
        }
    }
    evaluate(tp, false, c.local_probes);
    c.rms_error = c.random_probes ? std::sqrt(sum2 / double(c.random_probes)) : 0.0;
    c.passed = c.max_error <= options.target;
    c.seconds = now_seconds() - start;
    return c;
}

Certificate certify_adaptive_file(const std::string& path, const std::string& table, Backend& backend,
                                  const CertifyOptions& options, const ProgressFn& progress) {
    return certify_adaptive(read_adaptive_table(path, table), backend, options, progress);
}

}  // namespace brdftab
