#include "host/generate/generate.h"

#include <algorithm>
#include <cmath>
#include <optional>

#include "host/core/error.h"
#include "host/core/text.h"
#include "host/generate/checkpoint.h"

#ifndef BRDFTAB_VERSION
#define BRDFTAB_VERSION "unknown"
#endif

namespace brdftab {

namespace {
constexpr double kDegToRad = 3.14159265358979323846 / 180.0;
}

CellPoints::CellPoints(const ModelInfo& model, const QuantityInfo& quantity,
                       const TableSpec& table)
    : grid_(table.axes), base_(model.point_stride()) {
    // Validate everything once through the general builder, at the first node.
    std::map<std::string, double> values = table.fixed;
    for (const Axis& a : table.axes) values[a.name] = a.values.at(0);
    PointBuilder(model, quantity).build(values, base_.data());

    auto has = [&](const char* n) { return values.count(n) != 0; };
    phi_o_from_phi_d_ = has("phi_d");
    if (has("phi_d") && table.fixed.count("phi_d")) fixed_phi_d_ = table.fixed.at("phi_d") * kDegToRad;
    for (const Axis& a : table.axes) {
        if (a.name == "theta_i") feeds_.push_back({Feed::ThetaDeg, 0});
        else if (a.name == "mu_i") feeds_.push_back({Feed::Mu, 0});
        else if (a.name == "theta_o") feeds_.push_back({Feed::ThetaDeg, 2});
        else if (a.name == "mu_o") feeds_.push_back({Feed::Mu, 2});
        else if (a.name == "phi_i") feeds_.push_back({Feed::PhiIDeg, 1});
        else if (a.name == "phi_o") feeds_.push_back({Feed::PhiODeg, 3});
        else if (a.name == "phi_d") feeds_.push_back({Feed::PhiDDeg, 3});
        else {
            const ParameterInfo* p = model.find_parameter(a.name);
            if (!p) throw InputError("axis '" + a.name + "' is not a coordinate or parameter of '" +
                                     model.name + "'");
            const std::size_t slot = kDirectionSlots + static_cast<std::size_t>(p - model.parameters.data());
            feeds_.push_back({p->in_degrees ? Feed::ParamDeg : Feed::Param, slot});
        }
    }
}

void CellPoints::point(std::size_t cell, double* out) const {
    std::copy(base_.begin(), base_.end(), out);
    double phi_d = fixed_phi_d_;
    const std::vector<std::size_t> index = grid_.index_of(cell);
    for (std::size_t a = 0; a < feeds_.size(); ++a) {
        const double v = grid_.axes()[a].values[index[a]];
        switch (feeds_[a].feed) {
            case Feed::ThetaDeg:
            case Feed::PhiIDeg:
            case Feed::PhiODeg:
            case Feed::ParamDeg: out[feeds_[a].slot] = v * kDegToRad; break;
            case Feed::Mu: out[feeds_[a].slot] = std::acos(v); break;
            case Feed::PhiDDeg: phi_d = v * kDegToRad; break;
            case Feed::Param: out[feeds_[a].slot] = v; break;
        }
    }
    // Same rule as PointBuilder: phi_o = phi_i + phi_d when phi_d is given.
    if (phi_o_from_phi_d_) out[3] = out[1] + phi_d;
}

namespace {

double polynomial(const std::vector<double>& coeffs, double x) {
    double v = 0;
    for (std::size_t k = coeffs.size(); k-- > 0;) v = v * x + coeffs[k];
    return v;
}

// A derived table's provenance is that of the table it is formed from; its
// storage follows the spec's [output].
void inherit_provenance(TableData& d, const TableData& from, const Spec& spec) {
    d.model = from.model;
    d.seed = from.seed;
    d.precision = from.precision;
    d.device = from.device;
    d.version = from.version;
    d.spec_file = from.spec_file;
    d.stored_type = spec.output.stored_type;
    d.compression = spec.output.compression;
}

// A [[recombined]] table: the recipe for brdftab::LookupTable, and as values the
// recombination at p = stored_at with its standard error (terms independent).
GeneratedTable recombine(const RecombinedSpec& rs, const std::vector<GeneratedTable>& done,
                         const Spec& spec) {
    GeneratedTable g;
    TableData& d = g.data;
    nlohmann::json recipe = {{"parameter", rs.parameter}, {"terms", nlohmann::json::array()}};
    if (rs.range) recipe["range"] = {rs.range->first, rs.range->second};
    bool have_stderr = true;
    for (std::size_t k = 0; k < rs.terms.size(); ++k) {
        const auto& [name, coeffs] = rs.terms[k];
        const TableData* term = nullptr;
        for (const GeneratedTable& t : done)
            if (t.data.name == name) term = &t.data;
        if (!term) throw Error("recombined table '" + rs.name + "': term '" + name + "' missing");
        recipe["terms"].push_back({{"table", name}, {"coeffs", coeffs}});
        if (k == 0) {
            d = TableData{};
            d.axes = term->axes;
            d.value.assign(term->value.size(), 0.0);
            d.stderr_.assign(term->value.size(), 0.0);
            d.units = term->units;
            inherit_provenance(d, *term, spec);
            d.parameters = term->parameters;
        }
        have_stderr = have_stderr && term->stderr_.size() == term->value.size();
        const double c = polynomial(coeffs, rs.stored_at);
        for (std::size_t i = 0; i < d.value.size(); ++i) {
            d.value[i] += c * term->value[i];
            if (have_stderr) d.stderr_[i] += c * c * term->stderr_[i] * term->stderr_[i];
        }
        d.elapsed_seconds += term->elapsed_seconds;
    }
    for (double& v : d.stderr_) v = std::sqrt(v);
    if (!have_stderr) d.stderr_.clear();
    d.name = rs.name;
    d.quantity = rs.name;
    d.method = "recombined";
    d.description = (rs.description.empty() ? "recombined table" : rs.description) +
                    "; stored values at " + rs.parameter + " = " + number_text(rs.stored_at);
    d.parameters["recombine"] = recipe;
    d.parameters[rs.parameter] = rs.stored_at;
    d.keep_stderr = spec.output.keep_stderr && have_stderr;
    return g;
}

const TableData& find_done(const std::vector<GeneratedTable>& done, const std::string& name,
                           const std::string& user) {
    for (const GeneratedTable& t : done)
        if (t.data.name == name) return t.data;
    throw Error(user + ": table '" + name + "' missing");
}

std::string format_cell(const std::vector<Axis>& axes, const std::vector<double>& at) {
    std::string s;
    for (std::size_t a = 0; a < axes.size(); ++a)
        s += (a ? ", " : "") + axes[a].name + " = " + number_text(at[a], 6);
    return s;
}

// Max |e| and where, RMS, mean, noise level and cells beyond 2 sigma of an
// error table's values; per node of the `by` axis when given.
ErrorSummary summarise_errors(const TableData& d, const ErrorTableSpec& es) {
    const Grid grid(d.axes);
    const std::size_t n = d.value.size();
    ErrorSummary sum;
    sum.table = es.table;
    sum.reference = es.reference;
    sum.measure = es.relative ? "relative" : "absolute";
    sum.cells = n;
    std::size_t by_axis = d.axes.size();
    for (std::size_t a = 0; a < d.axes.size(); ++a)
        if (d.axes[a].name == es.by) by_axis = a;
    std::vector<double> by_sq, by_max;
    std::vector<std::size_t> by_count;
    if (by_axis < d.axes.size()) {
        sum.by = es.by;
        by_sq.assign(d.axes[by_axis].count, 0.0);
        by_max.assign(d.axes[by_axis].count, 0.0);
        by_count.assign(d.axes[by_axis].count, 0);
    }
    double sq = 0, total = 0;
    std::size_t used = 0, worst = n;
    std::vector<double> noise;
    for (std::size_t c = 0; c < n; ++c) {
        const double e = d.value[c];
        if (!std::isfinite(e)) {
            ++sum.nonfinite;
            continue;
        }
        ++used;
        sq += e * e;
        total += e;
        if (worst == n || std::fabs(e) > sum.max_abs) sum.max_abs = std::fabs(e), worst = c;
        noise.push_back(d.stderr_[c]);
        if (std::fabs(e) > 2 * d.stderr_[c]) ++sum.beyond_2sigma;
        if (by_axis < d.axes.size()) {
            const std::size_t k = grid.index_of(c)[by_axis];
            by_sq[k] += e * e;
            by_max[k] = std::max(by_max[k], std::fabs(e));
            ++by_count[k];
        }
    }
    if (used) {
        sum.rms = std::sqrt(sq / double(used));
        sum.mean = total / double(used);
        sum.worst = grid.coordinates(worst);
        std::nth_element(noise.begin(), noise.begin() + noise.size() / 2, noise.end());
        sum.median_stderr = noise[noise.size() / 2];
    }
    for (std::size_t k = 0; k < by_sq.size(); ++k)
        sum.by_nodes.push_back({d.axes[by_axis].values[k], by_max[k],
                                by_count[k] ? std::sqrt(by_sq[k] / double(by_count[k])) : 0.0});
    return sum;
}

// The summary as stored in the table's parameters["comparison"].
nlohmann::json summary_json(const ErrorSummary& sum, const ErrorTableSpec& es,
                            const std::vector<Axis>& axes) {
    nlohmann::json j = {{"table", es.table},
                        {"reference", es.reference},
                        {"measure", sum.measure},
                        {"cells", sum.cells},
                        {"nonfinite", sum.nonfinite},
                        {"max_abs", sum.max_abs},
                        {"rms", sum.rms},
                        {"mean", sum.mean},
                        {"median_stderr", sum.median_stderr},
                        {"beyond_2sigma", sum.beyond_2sigma}};
    if (es.relative) j["floor"] = es.floor;
    nlohmann::json w = nlohmann::json::object();
    for (std::size_t a = 0; a < sum.worst.size(); ++a) w[axes[a].name] = sum.worst[a];
    j["worst"] = w;
    if (!sum.by.empty()) {
        j["by"] = sum.by;
        nlohmann::json nodes = nlohmann::json::array();
        for (const auto& nd : sum.by_nodes)
            nodes.push_back({{sum.by, nd.value}, {"max_abs", nd.max_abs}, {"rms", nd.rms}});
        j["by_nodes"] = nodes;
    }
    return j;
}

// An [[errors]] table: (table - reference) / max(|reference|, floor) or
// table - reference, cell by cell.  Standard error by first-order propagation
// with the two tables independent: for e = t/r - 1,
//   var(e) = var(t)/r^2 + t^2 var(r)/r^4.
GeneratedTable compare(const ErrorTableSpec& es, const std::vector<GeneratedTable>& done,
                       const Spec& spec) {
    const std::string user = spec.file + ": errors table '" + es.name + "'";
    const TableData& t = find_done(done, es.table, user);
    const TableData& r = find_done(done, es.reference, user);
    if (t.value.size() != r.value.size()) throw Error(user + ": tables differ in size");
    GeneratedTable g;
    TableData& d = g.data;
    d.name = es.name;
    d.quantity = "error";
    d.method = "error";
    d.units = es.relative ? "1" : t.units;
    d.description = !es.description.empty()
                        ? es.description
                        : std::string(es.relative ? "relative" : "absolute") + " error of '" +
                              es.table + "' against '" + es.reference + "'";
    d.axes = t.axes;
    inherit_provenance(d, r, spec);
    const bool t_err = t.stderr_.size() == t.value.size();
    const bool r_err = r.stderr_.size() == r.value.size();
    const std::size_t n = t.value.size();
    d.value.resize(n);
    d.stderr_.resize(n);
    const Grid grid(d.axes);
    for (std::size_t c = 0; c < n; ++c) {
        const double tv = t.value[c], rv = r.value[c];
        const double st = t_err ? t.stderr_[c] : 0.0, sr = r_err ? r.stderr_[c] : 0.0;
        if (!es.relative) {
            d.value[c] = tv - rv;
            d.stderr_[c] = std::sqrt(st * st + sr * sr);
            continue;
        }
        const double den = std::max(std::fabs(rv), es.floor);
        if (den == 0) {
            if (tv != 0)
                throw InputError(user + ": the reference '" + es.reference + "' is 0 at " +
                                 format_cell(d.axes, grid.coordinates(c)) + " where '" + es.table +
                                 "' is " + number_text(tv) +
                                 "; a relative error is undefined there: give floor = (a "
                                 "value > 0; the denominator is max(|reference|, floor)) or "
                                 "measure = \"absolute\"");
            d.value[c] = 0;
            d.stderr_[c] = 0;
            continue;
        }
        d.value[c] = (tv - rv) / den;
        // d e / d r = -t/r^2 while |r| > floor; 1/floor below it.
        const double dr = std::fabs(rv) > es.floor ? std::fabs(tv) / (rv * rv) : 1.0 / den;
        d.stderr_[c] = std::sqrt(st * st / (den * den) + dr * dr * sr * sr);
    }
    d.keep_stderr = spec.output.keep_stderr && (t_err || r_err);
    g.error = summarise_errors(d, es);
    d.parameters = nlohmann::json::object();
    d.parameters["comparison"] = summary_json(*g.error, es, d.axes);
    return g;
}


// An [[inverted]] table.  The library interpolates a 1-D table linearly in
// its axis' warped coordinate t (node k at t_k = k/(n-1)), so on the segment
// between nodes k, k+1 the source is y = y_k + (t - t_k)/dt (y_(k+1) - y_k):
// its exact inverse is t = t_k + dt (y - y_k)/(y_(k+1) - y_k), x = warp(t).
// Standard error: sigma_x = sigma_y(x) / |dy/dx| with the segment's slope.
GeneratedTable invert(const InvertedSpec& is, const std::vector<GeneratedTable>& done,
                      const Spec& spec) {
    const std::string user = spec.file + ": inverted table '" + is.name + "'";
    const TableData& src = find_done(done, is.table, user);
    const Axis& xa = src.axes.front();
    const std::vector<double>& y = src.value;
    const std::size_t n = y.size();
    const double sign = y.back() > y.front() ? 1.0 : -1.0;
    for (std::size_t k = 0; k + 1 < n; ++k)
        if (!(sign * (y[k + 1] - y[k]) > 0))
            throw InputError(user + ": '" + is.table + "' is not strictly monotone along '" +
                             xa.name + "' (" + number_text(y[k]) + " at " + xa.name + " = " +
                             number_text(xa.values[k]) + ", " + number_text(y[k + 1]) +
                             " at " + number_text(xa.values[k + 1]) +
                             "), so it has no inverse; restrict its axis to a monotone part");
    const double ylo = std::min(y.front(), y.back()), yhi = std::max(y.front(), y.back());
    if (is.axis.min < ylo || is.axis.max > yhi)
        throw InputError(user + ": the axis '" + is.axis.name + "' spans [" +
                         number_text(is.axis.min) + ", " + number_text(is.axis.max) +
                         "], outside the values of '" + is.table + "', [" + number_text(ylo) +
                         ", " + number_text(yhi) + "]; give a range inside it");
    const bool have_err = src.stderr_.size() == n;
    GeneratedTable g;
    TableData& d = g.data;
    d.name = is.name;
    d.quantity = xa.name;
    d.units = xa.unit;
    d.method = "inverted";
    d.description = !is.description.empty()
                        ? is.description
                        : xa.name + " as a function of " + is.axis.name + " (the inverse of '" +
                              is.table + "')";
    d.axes = {is.axis};
    inherit_provenance(d, src, spec);
    d.parameters = src.parameters;
    d.parameters["inverse_of"] = {{"table", is.table}, {"axis", xa.name}};
    const double dt = 1.0 / double(n - 1);
    for (double target : is.axis.values) {
        std::size_t k = 0;  // segment with target between y_k and y_(k+1)
        while (k + 2 < n && sign * (target - y[k + 1]) > 0) ++k;
        const double f = (target - y[k]) / (y[k + 1] - y[k]);
        const double x = xa.warp((double(k) + f) * dt);
        d.value.push_back(std::clamp(x, xa.min, xa.max));
        if (have_err) {
            const double sy = (1 - f) * src.stderr_[k] + f * src.stderr_[k + 1];
            const double slope = (y[k + 1] - y[k]) / (xa.values[k + 1] - xa.values[k]);
            d.stderr_.push_back(sy / std::fabs(slope));
        }
    }
    d.keep_stderr = spec.output.keep_stderr && have_err;
    return g;
}

}  // namespace

std::vector<GeneratedTable> generate_tables(const Spec& spec, Backend& backend,
                                            const IntegrationSettings& settings,
                                            const GenerateProgressFn& progress,
                                            Checkpoint* checkpoint) {
    const ModelInfo& model = find_model(spec.model);
    std::vector<GeneratedTable> out;
    for (std::size_t t = 0; t < spec.tables.size(); ++t) {
        const TableSpec& ts = spec.tables[t];
        const QuantityInfo& q = model.quantity(ts.quantity);
        const std::vector<int> options =
            resolve_options(model, ts.options, spec.file + ": table '" + ts.name + "'");
        std::optional<CellPoints> built;
        try {
            built.emplace(model, q, ts);
        } catch (const InputError& e) {
            throw InputError(spec.file + ": table '" + ts.name + "': " + e.what());
        }
        const CellPoints& points = *built;
        ProgressFn cb;
        if (progress)
            cb = [&](const Progress& p) {
                GenerateEvent e;
                e.table_index = t;
                e.table_count = spec.tables.size();
                e.table = &ts;
                e.progress = p;
                progress(e);
            };
        IntegrationSettings table_settings = settings;
        table_settings.method = resolve_table_method(q, settings.method);
        EstimateCheckpoint stored;
        if (checkpoint) stored = checkpoint->table(t, ts.name, points.cell_count());
        EstimateResult r = estimate(
            backend, model, q, options, points.cell_count(),
            [&](std::size_t cell, double* p) { points.point(cell, p); }, table_settings, cb,
            checkpoint ? &stored : nullptr);

        GeneratedTable g;
        TableData& d = g.data;
        d.name = ts.name;
        d.model = model.name;
        d.quantity = q.name;
        d.units = q.units;
        d.description = ts.description.empty() ? q.description : ts.description;
        nlohmann::json params = nlohmann::json::object();
        for (const auto& [k, v] : ts.fixed) params[k] = v;
        // Record every option actually used (defaults included), by name.
        for (std::size_t k = 0; k < model.options.size(); ++k)
            params[model.options[k].name] = model.options[k].choices[options[k]];
        d.parameters = params;
        d.axes = ts.axes;
        d.value = std::move(r.value);
        d.stderr_ = std::move(r.stderr_);
        if (r.method != "closed-form") d.samples = std::move(r.samples);
        d.method = r.method;
        d.samples_requested = r.method == "closed-form"
                                  ? 1
                                  : (settings.tolerance > 0 ? settings.max_samples
                                                            : (settings.samples ? settings.samples : 4096));
        d.tolerance_requested = r.method == "closed-form" ? 0 : settings.tolerance;
        d.abs_floor = settings.abs_floor;
        d.tolerance_achieved = r.tolerance_achieved;
        d.seed = settings.seed;
        d.precision = precision_name(backend.precision());
        d.device = backend.device_name();
        d.version = BRDFTAB_VERSION;
        d.spec_file = spec.file;
        d.elapsed_seconds = r.elapsed_seconds;
        d.total_samples = r.total_samples;
        d.stored_type = spec.output.stored_type;
        d.compression = spec.output.compression;
        d.keep_stderr = spec.output.keep_stderr && r.method != "closed-form";
        g.cells_unconverged = r.cells_unconverged;
        out.push_back(std::move(g));
    }
    for (const RecombinedSpec& rs : spec.recombined) out.push_back(recombine(rs, out, spec));
    for (const ErrorTableSpec& es : spec.errors) out.push_back(compare(es, out, spec));
    for (const InvertedSpec& is : spec.inverted) out.push_back(invert(is, out, spec));
    return out;
}

}  // namespace brdftab
