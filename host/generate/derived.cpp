// derived.cpp — tables formed from other tables of a spec, with no computing
// of their own: [[recombined]] (polynomial combinations, stored with their
// recipe), [[errors]] (cell-by-cell comparison and its summary) and
// [[inverted]] (inverse of a monotone 1-D table).  See derived.h.
#include "host/generate/derived.h"

#include <algorithm>
#include <cmath>

#include "host/core/error.h"
#include "host/core/polynomial.h"
#include "host/core/text.h"

namespace brdftab::generate_detail {

namespace {

// A derived table's provenance is that of the table it is formed from; its
// storage follows the spec's [output].
void inherit_provenance(TableData& d, const TableData& from, const Spec& spec) {
    d.model = from.model;
    d.seed = from.seed;
    d.precision = from.precision;
    d.device = from.device;
    d.version = from.version;
    d.spec_file = from.spec_file;
    d.spec_text = from.spec_text;
    d.stored_type = spec.output.stored_type;
    d.compression = spec.output.compression;
    d.round_accuracy = spec.output.round_accuracy;
    d.round_absolute = spec.output.round_absolute;
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

}  // namespace

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
        const double c = polynomial_at(coeffs, rs.stored_at);
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
    d.kind = TableKind::Recombined;
    d.description = (rs.description.empty() ? "recombined table" : rs.description) +
                    "; stored values at " + rs.parameter + " = " + number_text(rs.stored_at);
    d.parameters["recombine"] = recipe;
    d.parameters[rs.parameter] = rs.stored_at;
    d.keep_stderr = spec.output.keep_stderr && have_stderr;
    return g;
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
    d.kind = TableKind::Error;
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
    d.kind = TableKind::Inverted;
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

}  // namespace brdftab::generate_detail
