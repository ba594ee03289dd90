// query, validate, plot: commands over the renderer-side lookup library
// (host/lookup.h).  Reference: docs/cli-table-commands.md.
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <set>
#include <sstream>

#include "host/core/atomic_file.h"
#include "host/cli/cli_common.h"
#include "host/cli/commands.h"
#include "host/core/error.h"
#include "host/lookup/lookup.h"
#include "host/cli/plot_png.h"

namespace brdftab::cli {

namespace {

std::string fmt17(double v) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.17g", v);
    return buf;
}


// name=value arguments -> map; a name given twice is an error.
std::map<std::string, double> parse_assignments(const std::vector<std::string>& args,
                                                const std::string& what) {
    std::map<std::string, double> out;
    for (const auto& a : args) {
        auto [name, text] = split_assignment(a);
        const double v = parse_number(text, what + " '" + name + "'");
        if (!out.emplace(name, v).second)
            throw InputError(what + " '" + name + "' is given twice");
    }
    return out;
}

std::string names_text(const std::vector<std::string>& names) {
    std::string s;
    for (const auto& n : names) s += (s.empty() ? "" : ", ") + n;
    return s;
}

// The stored table without its recombination recipe (validate compares the
// stored values with the model, whatever the user-level recombination is).
TableData stored_only(const TableData& t) {
    TableData d = t;
    if (d.parameters.is_object()) d.parameters.erase("recombine");
    return d;
}

// A lookup over the per-cell standard errors, or nothing when the table has
// none (closed form) or is recombined from several tables.
std::unique_ptr<LookupTable> stderr_table(const LookupTable& lt) {
    const TableData& t = lt.table();
    if (lt.has_recombination() || t.stderr_.size() != t.value.size()) return nullptr;
    TableData d = stored_only(t);
    d.value = t.stderr_;
    d.stderr_.clear();
    return std::make_unique<LookupTable>(std::move(d));
}

// Coordinates outside an axis are clamped by the library; say so.
void warn_if_clamped(const LookupTable& lt, const std::vector<double>& coords,
                     const std::string& where) {
    const auto& ax = lt.axes();
    for (std::size_t a = 0; a < ax.size() && a < coords.size(); ++a) {
        const double tol = 1e-9 * (ax[a].max - ax[a].min);
        if (coords[a] < ax[a].min - tol || coords[a] > ax[a].max + tol)
            std::cerr << "brdftab: warning: " << where << ": " << ax[a].name << " = "
                      << coords[a] << " is outside [" << ax[a].min << ", " << ax[a].max
                      << "], clamped (use --reject to make this an error)\n";
    }
}

// Coordinates in coordinate_names() order from a name -> value map; unknown
// or missing names are InputErrors.
std::vector<double> ordered_coords(const LookupTable& lt,
                                   const std::map<std::string, double>& values,
                                   const std::string& where) {
    const auto names = lt.coordinate_names();
    for (const auto& kv : values)
        if (std::find(names.begin(), names.end(), kv.first) == names.end())
            throw InputError(where + ": '" + kv.first + "' is not a coordinate of table '" +
                             lt.table().name + "' (coordinates: " + names_text(names) + ")");
    std::vector<double> out;
    std::vector<std::string> missing;
    for (const auto& n : names) {
        auto it = values.find(n);
        if (it == values.end())
            missing.push_back(n);
        else
            out.push_back(it->second);
    }
    if (!missing.empty())
        throw InputError(where + ": missing " + names_text(missing) + " (table '" +
                         lt.table().name + "' needs " + names_text(names) + ")");
    return out;
}

// ---------------------------------------------------------------- query

void run_query(const std::string& file, const std::string& table,
               const std::vector<std::string>& assignments, bool cubic, bool reject,
               const std::string& points_file, const std::string& output, bool json) {
    const Interpolation interp = cubic ? Interpolation::Cubic : Interpolation::Linear;
    const OutOfRange mode = reject ? OutOfRange::Reject : OutOfRange::Clamp;
    const std::map<std::string, double> fixed = parse_assignments(assignments, "argument");
    if (points_file.empty() && !output.empty())
        throw InputError("-o/--output needs --points (a single point is printed)");
    if (!output.empty()) check_output_writable(output);
    const LookupTable lt = LookupTable::open(file, table);
    const auto se_table = stderr_table(lt);
    const char* interp_name = cubic ? "cubic" : "linear";

    if (points_file.empty()) {
        const std::vector<double> c = ordered_coords(lt, fixed, "arguments");
        const double v = lt.eval(c, interp, mode);
        if (!reject) warn_if_clamped(lt, c, "arguments");
        if (json) {
            nlohmann::json j = {{"table", lt.table().name}, {"model", lt.model()},
                                {"quantity", lt.quantity()}, {"value", v},
                                {"units", lt.units()},      {"interpolation", interp_name}};
            if (se_table) j["stderr"] = se_table->eval(c, Interpolation::Linear, mode);
            std::cout << j.dump() << "\n";
        } else {
            std::cout << lt.table().name << " = " << fmt17(v);
            if (se_table)
                std::cout << " ± " << format_short(se_table->eval(c, Interpolation::Linear, mode))
                          << " (stderr, interpolated)";
            std::cout << " [" << lt.units() << "] (" << interp_name << ")\n";
        }
        return;
    }

    std::ifstream in(points_file);
    if (!in) throw InputError("cannot open points file '" + points_file + "'");
    std::vector<std::string> header;
    std::ostringstream csv;
    std::string line;
    std::size_t line_no = 0, rows = 0;
    const auto names = lt.coordinate_names();
    while (std::getline(in, line)) {
        ++line_no;
        if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
        const std::string at = points_file + ":" + std::to_string(line_no);
        if (header.empty()) {
            header = split_csv(line);
            std::set<std::string> seen;
            for (const auto& h : header) {
                if (std::find(names.begin(), names.end(), h) == names.end())
                    throw InputError(at + ": column '" + h + "' is not a coordinate of table '" +
                                     table + "' (coordinates: " + names_text(names) + ")");
                if (!seen.insert(h).second) throw InputError(at + ": column '" + h + "' twice");
            }
            for (const auto& h : header) csv << h << ",";
            csv << "value" << (se_table ? ",stderr" : "") << "\n";
            continue;
        }
        const auto cells = split_csv(line);
        if (cells.size() != header.size())
            throw InputError(at + ": " + std::to_string(cells.size()) + " columns, header has " +
                             std::to_string(header.size()));
        std::map<std::string, double> p = fixed;
        for (std::size_t k = 0; k < cells.size(); ++k)
            p[header[k]] = parse_number(cells[k], at + ": column '" + header[k] + "'");
        const std::vector<double> c = ordered_coords(lt, p, at);
        double v, se = 0;
        try {
            v = lt.eval(c, interp, mode);
            if (se_table) se = se_table->eval(c, Interpolation::Linear, mode);
        } catch (const InputError& e) {
            throw InputError(at + ": " + e.what());
        }
        if (!reject) warn_if_clamped(lt, c, at);
        for (const auto& cell : cells) csv << cell << ",";
        csv << fmt17(v);
        if (se_table) csv << "," << fmt17(se);
        csv << "\n";
        ++rows;
    }
    if (rows == 0) throw InputError("points file '" + points_file + "' has no rows");
    if (output.empty()) {
        std::cout << csv.str();
    } else {
        write_text_atomically(output, csv.str());
        std::cerr << "wrote " << rows << " rows to " << output << "\n";
    }
}

// ---------------------------------------------------------------- validate

// splitmix64: a tiny, fully specified generator so the validation points
// depend only on the seed, on every platform and standard library.
struct SplitMix {
    std::uint64_t s;
    std::uint64_t next() {
        std::uint64_t z = (s += 0x9E3779B97F4A7C15ull);
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
        return z ^ (z >> 31);
    }
    double uniform() { return (next() >> 11) * (1.0 / 9007199254740992.0); }  // [0, 1)
};

struct ErrorStats {
    double max = 0, rms = 0, p50 = 0, p95 = 0, p99 = 0;
};

// Nearest-rank percentiles of |x|.
ErrorStats stats_of(std::vector<double> x) {
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

nlohmann::json stats_json(const ErrorStats& s) {
    return {{"max", s.max}, {"rms", s.rms}, {"p50", s.p50}, {"p95", s.p95}, {"p99", s.p99}};
}

struct ValidateArgs {
    std::string file, table;
    std::size_t points = 1000;
    std::uint64_t seed = 1;
    std::uint64_t samples = 0;
    double rel_floor = 1e-3;
    std::size_t worst = 5;
    bool json = false, quiet = false;
    ComputeOptions compute;
};

void run_validate(const ValidateArgs& va) {
    if (va.points < 1) throw InputError("--points must be >= 1");
    if (!(va.rel_floor > 0 && va.rel_floor < 1))
        throw InputError("--rel-floor must be in (0, 1), got " + format_short(va.rel_floor));
    const LookupTable full = LookupTable::open(va.file, va.table);
    if (full.table().kind == TableKind::Error) {
        const nlohmann::json& e = full.table().parameters.value("comparison", nlohmann::json::object());
        throw InputError(va.file + ": table '" + full.table().name +
                         "' is an error table (no model quantity of its own); validate the "
                         "tables it compares: '" + e.value("table", std::string("?")) + "' and '" +
                         e.value("reference", std::string("?")) + "'");
    }
    if (full.table().kind == TableKind::Inverted) {
        const nlohmann::json& e = full.table().parameters.value("inverse_of", nlohmann::json::object());
        throw InputError(va.file + ": table '" + full.table().name +
                         "' is an inverted table (no model quantity of its own); validate the "
                         "table it inverts: '" + e.value("table", std::string("?")) + "'");
    }
    // Validate the stored values: the recombination recipe (if any) is a
    // user-level formula applied on top of them.
    const LookupTable lt(stored_only(full.table()));
    const TableData& t = lt.table();
    const ModelInfo& model = find_model(t.model);
    const QuantityInfo& q = model.quantity(t.quantity);
    const std::string where = va.file + ": table '" + t.name + "' parameters";

    // Fixed model inputs from the table's attributes; keys the model does not
    // know (recombine, reciprocal_half, ...) describe the storage, not the model.
    std::map<std::string, double> fixed;
    nlohmann::json option_values = nlohmann::json::object();
    std::vector<std::string> ignored;
    if (t.parameters.is_object())
        for (auto it = t.parameters.begin(); it != t.parameters.end(); ++it) {
            if (it.value().is_number() &&
                (model.find_parameter(it.key()) || is_direction_coordinate(it.key())))
                fixed[it.key()] = it.value().get<double>();
            else if (it.value().is_string() && model.find_option(it.key()))
                option_values[it.key()] = it.value();
            else
                ignored.push_back(it.key());
        }
    const std::vector<int> options = resolve_options(model, option_values, where);
    PointBuilder builder(model, q);

    // Random points, uniform in each axis' warped coordinate t (each grid cell
    // equally likely, e.g. uniform in cos(theta) on a cos axis).  With
    // continuous t they are off the nodes with probability 1.
    SplitMix rng{va.seed};
    const std::size_t n = va.points, dims = t.axes.size(), stride = model.point_stride();
    std::vector<double> coords(n * dims), kernel_points(n * stride);
    for (std::size_t k = 0; k < n; ++k) {
        std::map<std::string, double> values = fixed;
        for (std::size_t a = 0; a < dims; ++a) {
            const double x = std::clamp(t.axes[a].warp(rng.uniform()), t.axes[a].min, t.axes[a].max);
            coords[k * dims + a] = x;
            values[t.axes[a].name] = x;
        }
        try {
            builder.build(values, &kernel_points[k * stride]);
        } catch (const InputError& e) {
            throw InputError(where + ": " + e.what());
        }
    }

    // Reference on the device with the table's own method and budget.  The
    // seed differs from the table's so the reference noise is independent of
    // the table's noise.
    IntegrationSettings s;
    // A recombined table has no method of its own: parse_method rejects its
    // attribute ("integration method 'recombined' is not valid; ...").
    s.method = t.kind == TableKind::Computed ? t.method : parse_method(method_attribute(t));
    if (va.samples) {
        s.samples = va.samples;
    } else if (t.tolerance_requested > 0) {
        s.tolerance = t.tolerance_requested;
        s.max_samples = std::max<std::uint64_t>(t.samples_requested, 1);
    } else {
        s.samples = t.samples_requested > 1 ? t.samples_requested : 0;
    }
    if (t.abs_floor > 0) s.abs_floor = t.abs_floor;
    s.seed = t.seed * 0x9E3779B97F4A7C15ull + va.seed + 0x5EED;
    auto backend = va.compute.make_backend();
    std::unique_ptr<ProgressPrinter> printer;
    if (!va.quiet && q.kind != QuantityKind::ClosedForm)
        printer = std::make_unique<ProgressPrinter>("reference");
    const EstimateResult ref = estimate(
        *backend, model, q, options, n,
        [&](std::size_t c, double* out) { std::copy_n(&kernel_points[c * stride], stride, out); },
        s, [&](const Progress& p) {
            if (printer) (*printer)(p);
        });
    if (printer) printer->finish();
    const bool noisy = ref.method != Method::ClosedForm;

    // Relative errors use a floor: |diff| / max(|ref|, rel_floor * max|table|),
    // so points where the function is ~0 do not dominate.
    double scale = 0;
    for (double v : t.value) scale = std::max(scale, std::fabs(v));
    const double floor = va.rel_floor * scale > 0 ? va.rel_floor * scale : 1e-300;

    const auto se_table = stderr_table(lt);
    std::vector<double> ref_se(n, 0.0), table_se(n, 0.0);
    for (std::size_t k = 0; k < n; ++k) {
        ref_se[k] = noisy ? ref.stderr_[k] : 0.0;
        if (se_table)
            table_se[k] = se_table->eval(std::vector<double>(&coords[k * dims], &coords[(k + 1) * dims]));
    }

    struct Result {
        const char* name;
        std::vector<double> value, abs, rel;
        ErrorStats abs_stats, rel_stats;
        std::vector<std::size_t> worst;
        double rms_abs_corrected = 0, rms_rel_corrected = 0;
        std::size_t significant = 0;  // |diff| > 3 reference stderr
    };
    Result res[2] = {{"linear", {}, {}, {}, {}, {}, {}, 0, 0, 0},
                     {"cubic", {}, {}, {}, {}, {}, {}, 0, 0, 0}};
    for (int m = 0; m < 2; ++m) {
        Result& r = res[m];
        const Interpolation interp = m == 0 ? Interpolation::Linear : Interpolation::Cubic;
        double noise_abs2 = 0, noise_rel2 = 0;
        for (std::size_t k = 0; k < n; ++k) {
            const std::vector<double> c(&coords[k * dims], &coords[(k + 1) * dims]);
            const double v = lt.eval(c, interp, OutOfRange::Clamp);
            const double den = std::max(std::fabs(ref.value[k]), floor);
            r.value.push_back(v);
            r.abs.push_back(v - ref.value[k]);
            r.rel.push_back((v - ref.value[k]) / den);
            noise_abs2 += ref_se[k] * ref_se[k];
            noise_rel2 += (ref_se[k] / den) * (ref_se[k] / den);
            if (noisy && std::fabs(v - ref.value[k]) > 3 * ref_se[k]) ++r.significant;
        }
        r.abs_stats = stats_of(r.abs);
        r.rel_stats = stats_of(r.rel);
        // The reference's own noise adds (in quadrature, being independent of
        // the table) to the observed differences; remove it from the RMS.
        r.rms_abs_corrected = std::sqrt(std::max(0.0, r.abs_stats.rms * r.abs_stats.rms - noise_abs2 / n));
        r.rms_rel_corrected = std::sqrt(std::max(0.0, r.rel_stats.rms * r.rel_stats.rms - noise_rel2 / n));
        std::vector<std::size_t> order(n);
        for (std::size_t k = 0; k < n; ++k) order[k] = k;
        const std::size_t w = std::min(va.worst, n);
        std::partial_sort(order.begin(), order.begin() + w, order.end(),
                          [&](std::size_t a, std::size_t b) {
                              return std::fabs(r.rel[a]) > std::fabs(r.rel[b]);
                          });
        r.worst.assign(order.begin(), order.begin() + w);
    }
    const ErrorStats noise = stats_of(ref_se), tnoise = stats_of(table_se);

    auto coords_json = [&](std::size_t k) {
        nlohmann::json c = nlohmann::json::object();
        for (std::size_t a = 0; a < dims; ++a) c[t.axes[a].name] = coords[k * dims + a];
        return c;
    };
    auto coords_text = [&](std::size_t k) {
        std::string s;
        for (std::size_t a = 0; a < dims; ++a)
            s += (a ? " " : "") + t.axes[a].name + "=" + format_short(coords[k * dims + a]);
        return s;
    };

    if (va.json) {
        nlohmann::json j = {
            {"file", va.file},
            {"table", t.name},
            {"model", t.model},
            {"quantity", t.quantity},
            {"units", t.units},
            {"points", n},
            {"seed", va.seed},
            {"recombination_applied", false},
            {"relative_floor", floor},
            {"relative_floor_factor", va.rel_floor},
            {"max_abs_table_value", scale},
            {"reference",
             {{"method", to_string(ref.method)},
              {"device", backend->device_name()},
              {"precision", precision_name(backend->precision())},
              {"total_samples", ref.total_samples},
              {"seconds", ref.elapsed_seconds},
              {"stderr", stats_json(noise)}}},
        };
        if (se_table) j["table_stderr_interpolated"] = stats_json(tnoise);
        for (const Result& r : res) {
            nlohmann::json w = nlohmann::json::array();
            for (std::size_t k : r.worst) {
                nlohmann::json e = {{"coordinates", coords_json(k)},
                                    {"table", r.value[k]},
                                    {"reference", ref.value[k]},
                                    {"abs", r.abs[k]},
                                    {"rel", r.rel[k]}};
                if (noisy) e["reference_stderr"] = ref_se[k];
                w.push_back(e);
            }
            nlohmann::json o = {{"abs", stats_json(r.abs_stats)},
                                {"rel", stats_json(r.rel_stats)},
                                {"worst", w}};
            if (noisy) {
                o["abs"]["rms_noise_corrected"] = r.rms_abs_corrected;
                o["rel"]["rms_noise_corrected"] = r.rms_rel_corrected;
                o["significant_fraction"] = double(r.significant) / n;
            }
            j[r.name] = o;
        }
        std::cout << j.dump(2) << "\n";
        return;
    }

    std::cout << "validate " << va.file << ", table '" << t.name << "': " << t.model << " / "
              << t.quantity << " [" << t.units << "], axes";
    for (const auto& a : t.axes) std::cout << " " << a.name << "(" << a.count << ")";
    std::cout << "\n  " << n << " random off-grid points (seed " << va.seed
              << ", uniform in each axis' warped coordinate)\n"
              << "  reference: " << to_string(ref.method) << " on " << backend->device_name() << " ("
              << precision_name(backend->precision()) << "), ";
    if (noisy) std::cout << format_count(double(ref.total_samples)) << " samples, ";
    std::cout << format_seconds(ref.elapsed_seconds) << "\n";
    if (full.has_recombination())
        std::cout << "  note: the stored table is validated; its recombination recipe is not "
                     "applied\n";
    std::cout << "  relative error = |table - reference| / max(|reference|, " << format_short(floor)
              << ")   (floor = " << format_short(va.rel_floor) << " x max|table| = " << format_short(va.rel_floor)
              << " x " << format_short(scale) << ")\n\n";
    char buf[256];
    std::snprintf(buf, sizeof buf, "  %-16s %11s %11s %11s %11s %11s\n", "", "max", "rms", "p50",
                  "p95", "p99");
    std::cout << buf;
    for (const Result& r : res) {
        for (int kind = 0; kind < 2; ++kind) {
            const ErrorStats& e = kind == 0 ? r.rel_stats : r.abs_stats;
            std::snprintf(buf, sizeof buf, "  %-7s %-8s %11.4g %11.4g %11.4g %11.4g %11.4g\n",
                          r.name, kind == 0 ? "rel" : "abs", e.max, e.rms, e.p50, e.p95, e.p99);
            std::cout << buf;
        }
    }
    if (noisy) {
        std::cout << "\n  reference stderr per point: median " << format_short(noise.p50) << ", max "
                  << format_short(noise.max) << " (" << q.units << ")\n";
        for (const Result& r : res)
            std::cout << "  " << r.name << ": rms with the reference noise removed: abs "
                      << format_short(r.rms_abs_corrected) << ", rel " << format_short(r.rms_rel_corrected)
                      << "; |diff| > 3 reference stderr at " << r.significant << "/" << n
                      << " points\n";
    }
    if (se_table)
        std::cout << "  table stderr (interpolated) at the points: median " << format_short(tnoise.p50)
                  << ", max " << format_short(tnoise.max) << "\n";
    for (const Result& r : res) {
        std::cout << "\n  worst " << r.worst.size() << " (" << r.name << ", by relative error):\n";
        for (std::size_t k : r.worst) {
            std::cout << "    " << coords_text(k) << ": table " << format_short(r.value[k])
                      << ", reference " << format_short(ref.value[k]);
            if (noisy) std::cout << " ± " << format_short(ref_se[k]);
            std::cout << ", rel " << format_short(r.rel[k]) << ", abs " << format_short(r.abs[k]) << "\n";
        }
    }
}

// ---------------------------------------------------------------- plot

struct PlotArgs {
    std::string file, table, output, x_axis, curves_axis;
    std::vector<std::string> slices;
    bool cubic = false, log = false;
};

std::string axis_label(const Axis& a) {
    return a.unit.empty() || a.unit == "1" ? a.name : a.name + " [" + a.unit + "]";
}

void run_plot(const PlotArgs& pa) {
    if (pa.output.empty()) throw InputError("plot needs -o OUT.png");
    check_output_writable(pa.output);
    const LookupTable lt = LookupTable::open(pa.file, pa.table);
    const auto& axes = lt.axes();
    const auto names = lt.coordinate_names();
    const std::map<std::string, double> slice = parse_assignments(pa.slices, "--slice");
    const Interpolation interp = pa.cubic ? Interpolation::Cubic : Interpolation::Linear;

    // Fixed coordinates: every --slice must name a coordinate and lie in its
    // range (a plot of clamped values would silently show the wrong slice).
    std::vector<double> base(names.size(), 0.0);
    std::vector<bool> is_fixed(names.size(), false);
    for (const auto& kv : slice) {
        const auto it = std::find(names.begin(), names.end(), kv.first);
        if (it == names.end())
            throw InputError("--slice " + kv.first + ": not a coordinate of table '" +
                             lt.table().name + "' (coordinates: " + names_text(names) + ")");
        base[it - names.begin()] = kv.second;
        is_fixed[it - names.begin()] = true;
    }
    std::vector<std::size_t> free;
    for (std::size_t a = 0; a < names.size(); ++a)
        if (!is_fixed[a]) {
            if (a >= axes.size())  // the recombination parameter is not an axis
                throw InputError("table '" + lt.table().name + "' is recombined in '" + names[a] +
                                 "': give it with --slice " + names[a] + "=VALUE");
            free.push_back(a);
        }
    // Range check through the library (Reject names the axis and its range).
    {
        std::vector<double> probe = base;
        for (std::size_t a : free) probe[a] = axes[a].min;
        lt.eval(probe, Interpolation::Linear, OutOfRange::Reject);
    }
    std::vector<std::string> free_names;
    for (std::size_t a : free) free_names.push_back(names[a]);
    if (free.empty())
        throw InputError("--slice fixes every axis of table '" + lt.table().name +
                         "': leave one axis free for curves or two for a colour map");
    if (free.size() > 2)
        throw InputError("table '" + lt.table().name + "' has " + std::to_string(free.size()) +
                         " axes without --slice (" + names_text(free_names) +
                         "); fix all but one or two of them with --slice NAME=VALUE");
    auto free_index = [&](const std::string& name, const char* opt) {
        for (std::size_t a : free)
            if (names[a] == name) return a;
        throw InputError(std::string(opt) + " " + name + ": not a free axis (free: " +
                         names_text(free_names) + ")");
    };

    std::string slice_text;
    for (const auto& kv : slice) slice_text += (slice_text.empty() ? "" : ", ") + kv.first + "=" + format_short(kv.second);
    const std::string title = lt.table().name + ": " + lt.model() + " / " + lt.quantity();
    const std::string subtitle = pa.file + (slice_text.empty() ? "" : "   slice " + slice_text) +
                                 "   " + (pa.cubic ? "cubic" : "linear") + " interpolation" +
                                 (pa.log ? ", log10 scale" : "");
    const std::string vlabel = (pa.log ? "log10 " : "") + lt.quantity() +
                               (lt.units().empty() || lt.units() == "1" ? "" : " [" + lt.units() + "]");
    auto transform = [&](double v) {
        if (!pa.log) return v;
        return v > 0 ? std::log10(v) : std::nan("");
    };

    const bool want_curves = !pa.curves_axis.empty();
    if (free.size() == 1 || want_curves) {
        std::size_t xa, ca = static_cast<std::size_t>(-1);
        if (want_curves) {
            if (free.size() != 2)
                throw InputError("--curves needs exactly two free axes (free: " +
                                 names_text(free_names) + ")");
            ca = free_index(pa.curves_axis, "--curves");
            xa = free[0] == ca ? free[1] : free[0];
            if (!pa.x_axis.empty() && free_index(pa.x_axis, "--x") != xa)
                throw InputError("--x and --curves name the same axis");
        } else {
            xa = free[0];
            if (!pa.x_axis.empty()) free_index(pa.x_axis, "--x");
        }
        LinePlot lp;
        lp.title = title;
        lp.subtitle = subtitle;
        lp.xlabel = axis_label(axes[xa]);
        lp.ylabel = vlabel;
        std::vector<std::size_t> curve_nodes{0};
        if (want_curves) {
            // At most 10 curves, at evenly spread nodes of the curve axis.
            const std::size_t nc = axes[ca].count, shown = std::min<std::size_t>(nc, 10);
            curve_nodes.clear();
            for (std::size_t k = 0; k < shown; ++k) {
                const std::size_t node = shown == 1 ? 0 : (k * (nc - 1) + (shown - 1) / 2) / (shown - 1);
                if (curve_nodes.empty() || curve_nodes.back() != node) curve_nodes.push_back(node);
            }
            lp.legend_title = axis_label(axes[ca]) + (shown < nc ? " (" + std::to_string(curve_nodes.size()) +
                                                                       " of " + std::to_string(nc) + " nodes)"
                                                                 : "");
        }
        const int samples = 720;
        for (std::size_t node : curve_nodes) {
            Curve cv;
            std::vector<double> c = base;
            if (want_curves) {
                c[ca] = axes[ca].values[node];
                cv.label = format_short(c[ca]);
            }
            for (int i = 0; i < samples; ++i) {
                c[xa] = axes[xa].min + (axes[xa].max - axes[xa].min) * i / (samples - 1);
                cv.x.push_back(c[xa]);
                cv.y.push_back(transform(lt.eval(c, interp, OutOfRange::Clamp)));
            }
            for (double xn : axes[xa].values) {
                c[xa] = xn;
                cv.mx.push_back(xn);
                cv.my.push_back(transform(lt.eval(c, interp, OutOfRange::Clamp)));
            }
            lp.curves.push_back(std::move(cv));
        }
        render_line_plot(lp, pa.output);
        std::cerr << "wrote " << pa.output << " (" << names[xa]
                  << (want_curves ? ", one curve per " + names[ca] + " node" : "") << ")\n";
        return;
    }

    // Two free axes: colour map.
    std::size_t xa = free[0], ya = free[1];
    if (!pa.x_axis.empty()) {
        xa = free_index(pa.x_axis, "--x");
        ya = xa == free[0] ? free[1] : free[0];
    }
    MapPlot mp;
    mp.title = title;
    mp.subtitle = subtitle;
    mp.xlabel = axis_label(axes[xa]);
    mp.ylabel = axis_label(axes[ya]);
    mp.zlabel = vlabel;
    mp.x0 = axes[xa].min, mp.x1 = axes[xa].max;
    mp.y0 = axes[ya].min, mp.y1 = axes[ya].max;
    std::vector<double> c = base;
    mp.value = [&](double x, double y) {
        c[xa] = x;
        c[ya] = y;
        return transform(lt.eval(c, interp, OutOfRange::Clamp));
    };
    render_map_plot(mp, pa.output);
    std::cerr << "wrote " << pa.output << " (" << names[xa] << " x " << names[ya] << ")\n";
}

}  // namespace

void register_table_commands(CLI::App& app) {
    // ---- query
    {
        auto* cmd = app.add_subcommand(
            "query",
            "interpolate a stored table at one point (name=value for every axis) or at every "
            "row of --points FILE.csv; no OpenCL needed");
        struct State {
            std::string file, table, points, output;
            std::vector<std::string> assignments;
            bool cubic = false, reject = false, json = false;
        };
        static State st;
        cmd->add_option("FILE", st.file, "HDF5 file written by `brdftab generate`")->required();
        cmd->add_option("VALUES", st.assignments,
                        "name=value for every axis of the table (user units, degrees for angles) "
                        "and the recombination parameter if the table has one");
        cmd->add_option("--table", st.table, "table (group) name in FILE")->required();
        cmd->add_flag("--cubic", st.cubic, "Catmull-Rom interpolation instead of multilinear");
        cmd->add_flag("--reject", st.reject,
                      "out-of-range coordinates are an error (default: clamp to the axis range "
                      "with a warning)");
        cmd->add_option("--points", st.points,
                        "CSV with a header row of coordinate names and one point per row; "
                        "name=value arguments supply columns the CSV lacks");
        cmd->add_option("-o,--output", st.output,
                        "with --points: write the CSV here (atomically) instead of stdout");
        cmd->add_flag("--json", st.json, "single point: print one JSON object");
        cmd->callback([] {
            run_query(st.file, st.table, st.assignments, st.cubic, st.reject, st.points,
                      st.output, st.json);
        });
    }
    // ---- validate
    {
        auto* cmd = app.add_subcommand(
            "validate",
            "accuracy certificate: compare the interpolated table (linear and cubic) with the "
            "model evaluated directly on the device at random off-grid points");
        static ValidateArgs st;
        cmd->add_option("FILE", st.file, "HDF5 file written by `brdftab generate`")->required();
        cmd->add_option("--table", st.table, "table (group) name in FILE")->required();
        cmd->add_option("--points", st.points, "number of random points (default 1000)");
        cmd->add_option("--seed", st.seed, "seed of the random points (default 1)");
        cmd->add_option("--samples", st.samples,
                        "integrals: fixed sample budget per reference point (default: the "
                        "table's own budget / tolerance)")
            ->check(CLI::PositiveNumber);
        cmd->add_option("--rel-floor", st.rel_floor,
                        "relative errors divide by max(|reference|, F * max|table value|); "
                        "default F = 1e-3");
        cmd->add_option("--worst", st.worst, "how many worst points to list (default 5)");
        cmd->add_flag("--json", st.json, "print the report as JSON");
        cmd->add_flag("-q,--quiet", st.quiet, "no progress display");
        st.compute.add_to(*cmd, false);
        cmd->callback([] { run_validate(st); });
    }
    // ---- plot
    {
        auto* cmd = app.add_subcommand(
            "plot",
            "draw a 1-D slice (curves) or 2-D slice (colour map) of a table as a PNG");
        static PlotArgs st;
        cmd->add_option("FILE", st.file, "HDF5 file written by `brdftab generate`")->required();
        cmd->add_option("--table", st.table, "table (group) name in FILE")->required();
        cmd->add_option("--slice", st.slices,
                        "name=value fixing an axis (repeat); one free axis gives curves, two a "
                        "colour map");
        cmd->add_option("-o,--output", st.output, "PNG file to write")->required();
        cmd->add_option("--x", st.x_axis, "free axis for the horizontal direction");
        cmd->add_option("--curves", st.curves_axis,
                        "with two free axes: one curve per node of this axis (at most 10) "
                        "instead of a colour map");
        cmd->add_flag("--cubic", st.cubic, "Catmull-Rom interpolation instead of multilinear");
        cmd->add_flag("--log", st.log, "plot log10 of the value (values <= 0 are left out)");
        cmd->callback([] { run_plot(st); });
    }
}

}  // namespace brdftab::cli
