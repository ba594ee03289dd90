#include "generate.h"

#include <cmath>

#include "error.h"

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
            d.model = term->model;
            d.seed = term->seed;
            d.precision = term->precision;
            d.device = term->device;
            d.version = term->version;
            d.spec_file = term->spec_file;
            d.stored_type = term->stored_type;
            d.compression = term->compression;
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
                    "; stored values at " + rs.parameter + " = " + std::to_string(rs.stored_at);
    d.parameters["recombine"] = recipe;
    d.parameters[rs.parameter] = rs.stored_at;
    d.keep_stderr = spec.output.keep_stderr && have_stderr;
    return g;
}

}  // namespace

std::vector<GeneratedTable> generate_tables(const Spec& spec, Backend& backend,
                                            const IntegrationSettings& settings,
                                            const GenerateProgressFn& progress) {
    const ModelInfo& model = find_model(spec.model);
    std::vector<GeneratedTable> out;
    for (std::size_t t = 0; t < spec.tables.size(); ++t) {
        const TableSpec& ts = spec.tables[t];
        const QuantityInfo& q = model.quantity(ts.quantity);
        const std::vector<int> options =
            resolve_options(model, ts.options, spec.file + ": table '" + ts.name + "'");
        CellPoints points(model, q, ts);
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
        EstimateResult r = estimate(
            backend, model, q, options, points.cell_count(),
            [&](std::size_t cell, double* p) { points.point(cell, p); }, table_settings, cb);

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
    return out;
}

}  // namespace brdftab
