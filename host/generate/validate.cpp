// validate.cpp — table against direct evaluation at random off-grid points
// (validate.h).
#include "host/generate/validate.h"

#include <algorithm>
#include <cmath>
#include <map>

#include "host/adaptive/adaptive_io.h"
#include "host/core/error.h"
#include "host/core/text.h"
#include "host/core/splitmix.h"
#include "host/engine/evaluate.h"

namespace brdftab {

namespace {


nlohmann::json stats_json(const ErrorStats& s) {
    return {{"max", s.max}, {"rms", s.rms}, {"p50", s.p50}, {"p95", s.p95}, {"p99", s.p99}};
}

// The options' own checks, then the table: error and inverted tables have
// no model quantity of their own.  Returns the stored values without the
// recombination recipe (a user-level formula applied on top of them).
void check_options(const ValidateOptions& options) {
    if (options.points < 1) throw InputError("validation needs at least one point");
    if (!(options.rel_floor > 0 && options.rel_floor < 1))
        throw InputError("the relative-error floor factor must be in (0, 1), got " +
                         number_text(options.rel_floor, 6));
}

LookupTable stored_table(const std::string& file, const std::string& table,
                         bool& recombination_skipped) {
    const LookupTable full = LookupTable::open(file, table);
    if (full.table().kind == TableKind::Error) {
        const nlohmann::json& e = full.table().parameters.value("comparison", nlohmann::json::object());
        throw InputError(file + ": table '" + full.table().name +
                         "' is an error table (no model quantity of its own); validate the "
                         "tables it compares: '" + e.value("table", std::string("?")) + "' and '" +
                         e.value("reference", std::string("?")) + "'");
    }
    if (full.table().kind == TableKind::Inverted) {
        const nlohmann::json& e = full.table().parameters.value("inverse_of", nlohmann::json::object());
        throw InputError(file + ": table '" + full.table().name +
                         "' is an inverted table (no model quantity of its own); validate the "
                         "table it inverts: '" + e.value("table", std::string("?")) + "'");
    }
    recombination_skipped = full.has_recombination();
    return LookupTable(without_recombination(full.table()));
}

}  // namespace

// Nearest-rank percentiles of |x|.
ErrorStats error_stats(std::vector<double> x) {
    ErrorStats s;
    if (x.empty()) return s;
    double sum2 = 0;
    for (double& v : x) v = std::fabs(v), sum2 += v * v;
    std::sort(x.begin(), x.end());
    auto pct = [&](double p) {
        const std::size_t rank = static_cast<std::size_t>(std::ceil(p * x.size()));
        return x[std::min(x.size() - 1, rank ? rank - 1 : 0)];
    };
    s.max = x.back();
    s.rms = std::sqrt(sum2 / x.size());
    s.p50 = pct(0.50);
    s.p95 = pct(0.95);
    s.p99 = pct(0.99);
    return s;
}

ValidationPlan::ValidationPlan(const std::string& file, const std::string& table,
                               const ValidateOptions& options)
    : file_(file), options_(options) {
    check_options(options_);
    // An adaptive table is generated from a model quantity only (no
    // recombined, error or inverted adaptive tables: cli_adaptive.cpp).
    if (is_adaptive_table(file, table))
        adaptive_ = read_adaptive_table(file, table);
    else
        table_ = stored_table(file, table, recombination_skipped_);
    const TableData& t = data();
    const ModelInfo& model = find_model(t.model);
    const QuantityInfo& q = model.quantity(t.quantity);
    model_ = &model;
    quantity_ = &q;
    const std::string where = file + ": table '" + t.name + "' parameters";

    // Fixed model inputs from the table's attributes; keys the model does not
    // know (recombine, reciprocal_half, ...) describe the storage, not the model.
    std::map<std::string, double> fixed;
    nlohmann::json option_values = nlohmann::json::object();
    if (t.parameters.is_object())
        for (auto it = t.parameters.begin(); it != t.parameters.end(); ++it) {
            if (it.value().is_number() &&
                (model.find_parameter(it.key()) || is_direction_coordinate(it.key())))
                fixed[it.key()] = it.value().get<double>();
            else if (it.value().is_string() && model.find_option(it.key()))
                option_values[it.key()] = it.value();
        }
    model_options_ = resolve_options(model, option_values, where);

    // Random points, uniform in each axis' warped coordinate t (each grid cell
    // equally likely, e.g. uniform in cos(theta) on a cos axis).  With
    // continuous t they are off the nodes with probability 1.
    SplitMix rng{options_.seed};
    const std::size_t n = options_.points, dims = t.axes.size();
    coords_.resize(n * dims);
    std::vector<std::map<std::string, double>> named(n, fixed);
    const Grid grid(t.axes);  // places axes that depend on another (critical)
    std::vector<double> tk(dims), xk(dims);
    for (std::size_t k = 0; k < n; ++k) {
        for (std::size_t a = 0; a < dims; ++a) tk[a] = rng.uniform();
        if (adaptive_)
            adaptive_->to_x(tk.data(), xk.data());
        else
            xk = grid.point_at(tk);
        for (std::size_t a = 0; a < dims; ++a) {
            coords_[k * dims + a] = xk[a];
            named[k][t.axes[a].name] = xk[a];
        }
    }
    kernel_points_ = build_kernel_points(model, q, named, [&](std::size_t) { return where; });

    // Reference on the device with the table's own method and budget.  The
    // seed differs from the table's so the reference noise is independent of
    // the table's noise.
    IntegrationSettings& s = reference_settings_;
    // A recombined table has no method of its own: its values (at stored_at)
    // are checked against the quantity of its name with that quantity's
    // default method (plan's recombined predictions are checked so).
    s.method = t.kind == TableKind::Computed ? t.method : Method::Auto;
    // The table's budget comes from the file, which may be hostile: capped.
    if (options_.max_samples < 1) throw InputError("--max-samples must be >= 1");
    const std::uint64_t cap = options_.max_samples;
    table_budget_ = t.samples_requested;
    if (options_.samples) {
        s.samples = options_.samples;
    } else if (t.tolerance_requested > 0) {
        s.tolerance = t.tolerance_requested;
        s.max_samples = std::min(std::max<std::uint64_t>(t.samples_requested, 1), cap);
        samples_capped_ = t.samples_requested > cap;
    } else {
        s.samples = t.samples_requested > 1 ? std::min(t.samples_requested, cap) : 0;
        samples_capped_ = t.samples_requested > 1 && t.samples_requested > cap;
    }
    if (t.abs_floor > 0) s.abs_floor = t.abs_floor;
    s.seed = t.seed * 0x9E3779B97F4A7C15ull + options_.seed + 0x5EED;
}

ValidationReport ValidationPlan::run(Backend& backend, const ProgressFn& progress) const {
    const TableData& t = data();
    const std::size_t n = options_.points, dims = t.axes.size();
    ValidationReport rep;
    rep.file = file_;
    rep.table = t.name;
    rep.model = t.model;
    rep.quantity = t.quantity;
    rep.units = t.units;
    rep.axes = t.axes;
    rep.quantity_units = quantity_->units;
    rep.recombination_skipped = recombination_skipped_;
    rep.samples_capped = samples_capped_;
    rep.table_budget = table_budget_;
    rep.sample_cap = options_.max_samples;
    rep.points = n;
    rep.seed = options_.seed;
    rep.coords = coords_;
    rep.rel_floor_factor = options_.rel_floor;

    rep.reference = estimate_at(backend, *model_, *quantity_, model_options_, kernel_points_,
                                reference_settings_, progress);
    rep.device = backend.device_name();
    rep.precision = backend.precision();
    const EstimateResult& ref = rep.reference;
    const bool noisy = ref.method != Method::ClosedForm;
    rep.noisy = noisy;

    // Relative errors use a floor: |diff| / max(|ref|, rel_floor * max|table|),
    // so points where the function is ~0 do not dominate.
    double scale = 0;
    for (double v : t.value) scale = std::max(scale, std::fabs(v));
    const double floor = options_.rel_floor * scale > 0 ? options_.rel_floor * scale : 1e-300;
    rep.max_abs_table_value = scale;
    rep.relative_floor = floor;

    // The table's interpolated stderr at the points (an adaptive table's
    // stderr per node, interpolated by its patches like its values).
    const auto se_table = table_ ? stderr_lookup(*table_) : nullptr;
    const bool adaptive_se = adaptive_ && adaptive_->data.stderr_.size() == adaptive_->value_count();
    std::vector<double> ref_se(n, 0.0), table_se(n, 0.0), tk(dims);
    for (std::size_t k = 0; k < n; ++k) {
        ref_se[k] = noisy ? ref.stderr_[k] : 0.0;
        if (se_table)
            table_se[k] = se_table->eval(std::vector<double>(&coords_[k * dims], &coords_[(k + 1) * dims]));
        if (adaptive_se) {
            adaptive_->to_t(&coords_[k * dims], tk.data());
            table_se[k] = adaptive_->layout.eval(tk.data(), adaptive_->data.stderr_.data());
        }
    }

    rep.adaptive = adaptive_.has_value();
    rep.results[0].name = "linear";
    rep.results[1].name = "cubic";
    for (int m = 0; m < (adaptive_ ? 1 : 2); ++m) {
        InterpolationErrors& r = rep.results[m];
        const Interpolation interp = m == 0 ? Interpolation::Linear : Interpolation::Cubic;
        double noise_abs2 = 0, noise_rel2 = 0;
        for (std::size_t k = 0; k < n; ++k) {
            const std::vector<double> c(&coords_[k * dims], &coords_[(k + 1) * dims]);
            const double v = adaptive_ ? adaptive_->eval(c.data()) : table_->eval(c, interp, OutOfRange::Clamp);
            const double den = std::max(std::fabs(ref.value[k]), floor);
            r.value.push_back(v);
            r.abs.push_back(v - ref.value[k]);
            r.rel.push_back((v - ref.value[k]) / den);
            noise_abs2 += ref_se[k] * ref_se[k];
            noise_rel2 += (ref_se[k] / den) * (ref_se[k] / den);
            if (noisy && std::fabs(v - ref.value[k]) > 3 * ref_se[k]) ++r.significant;
        }
        r.abs_stats = error_stats(r.abs);
        r.rel_stats = error_stats(r.rel);
        // The reference's own noise adds (in quadrature, being independent of
        // the table) to the observed differences; remove it from the RMS.
        r.rms_abs_corrected = std::sqrt(std::max(0.0, r.abs_stats.rms * r.abs_stats.rms - noise_abs2 / n));
        r.rms_rel_corrected = std::sqrt(std::max(0.0, r.rel_stats.rms * r.rel_stats.rms - noise_rel2 / n));
        std::vector<std::size_t> order(n);
        for (std::size_t k = 0; k < n; ++k) order[k] = k;
        const std::size_t w = std::min(options_.worst, n);
        std::partial_sort(order.begin(), order.begin() + w, order.end(),
                          [&](std::size_t a, std::size_t b) {
                              return std::fabs(r.rel[a]) > std::fabs(r.rel[b]);
                          });
        r.worst.assign(order.begin(), order.begin() + w);
    }
    rep.reference_noise = error_stats(ref_se);
    rep.table_stderr = error_stats(table_se);
    rep.has_table_stderr = se_table != nullptr || adaptive_se;
    rep.reference_stderr = std::move(ref_se);
    return rep;
}

nlohmann::json to_json(const ValidationReport& rep) {
    const std::size_t n = rep.points, dims = rep.axes.size();
    const EstimateResult& ref = rep.reference;
    auto coords_json = [&](std::size_t k) {
        nlohmann::json c = nlohmann::json::object();
        for (std::size_t a = 0; a < dims; ++a) c[rep.axes[a].name] = rep.coord(k, a);
        return c;
    };
    nlohmann::json j = {
        {"file", rep.file},
        {"table", rep.table},
        {"model", rep.model},
        {"quantity", rep.quantity},
        {"units", rep.units},
        {"points", n},
        {"seed", rep.seed},
        {"recombination_applied", false},
        {"relative_floor", rep.relative_floor},
        {"relative_floor_factor", rep.rel_floor_factor},
        {"max_abs_table_value", rep.max_abs_table_value},
        {"reference",
         {{"method", to_string(ref.method)},
          {"device", rep.device},
          {"precision", precision_name(rep.precision)},
          {"total_samples", ref.total_samples},
          {"samples_capped", rep.samples_capped},
          {"sample_cap", rep.sample_cap},
          {"table_samples_requested", rep.table_budget},
          {"seconds", ref.elapsed_seconds},
          {"stderr", stats_json(rep.reference_noise)}}},
    };
    if (rep.has_table_stderr) j["table_stderr_interpolated"] = stats_json(rep.table_stderr);
    if (rep.adaptive) j["representation"] = "adaptive";
    for (const InterpolationErrors& r : rep.results) {
        if (rep.adaptive && &r != &rep.results[0]) continue;  // linear only
        nlohmann::json w = nlohmann::json::array();
        for (std::size_t k : r.worst) {
            nlohmann::json e = {{"coordinates", coords_json(k)},
                                {"table", r.value[k]},
                                {"reference", ref.value[k]},
                                {"abs", r.abs[k]},
                                {"rel", r.rel[k]}};
            if (rep.noisy) e["reference_stderr"] = rep.reference_stderr[k];
            w.push_back(e);
        }
        nlohmann::json o = {{"abs", stats_json(r.abs_stats)},
                            {"rel", stats_json(r.rel_stats)},
                            {"worst", w}};
        if (rep.noisy) {
            o["abs"]["rms_noise_corrected"] = r.rms_abs_corrected;
            o["rel"]["rms_noise_corrected"] = r.rms_rel_corrected;
            o["significant_fraction"] = double(r.significant) / n;
        }
        j[r.name] = o;
    }
    return j;
}

}  // namespace brdftab
