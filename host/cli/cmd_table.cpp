// query, validate, plot: commands over the renderer-side lookup library
// (host/lookup/lookup.h) and the table validation (host/generate/validate.h);
// this file parses, prints and warns.  Reference: docs/cli-table-commands.md.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>

#include "host/core/atomic_file.h"
#include "host/adaptive/adaptive_io.h"
#include "host/cli/cli_adaptive.h"
#include "host/cli/cli_common.h"
#include "host/cli/commands.h"
#include "host/core/error.h"
#include "host/generate/validate.h"
#include "host/io/adaptive_resample.h"
#include "host/io/point_file.h"
#include "host/io/table_io.h"
#include "host/lookup/lookup.h"
#include "host/lookup/lookup_internal.h"
#include "host/cli/plot_png.h"
#include "host/cli/read_guard.h"

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

// Coordinates outside an axis are clamped by the library; say so.
void warn_if_clamped(const LookupTable& lt, const std::vector<double>& coords,
                     const std::string& where) {
    const auto& ax = lt.axes();
    for (std::size_t a = 0; a < ax.size() && a < coords.size(); ++a) {
        const double tol = 1e-9 * (ax[a].max - ax[a].min);
        // phi_d is folded or wrapped by the lookup (isotropy, periodicity)
        // before any clamping: warn only about what is clamped after that.
        const double x = lookup_internal::fold_periodic(ax[a], coords[a]);
        if (x < ax[a].min - tol || x > ax[a].max + tol)
            std::cerr << "brdftab: warning: " << where << ": " << ax[a].name << " = "
                      << coords[a] << " is outside [" << ax[a].min << ", " << ax[a].max
                      << "], clamped (use --reject to make this an error)\n";
    }
}

// Coordinates in coordinate_names() order from a name -> value map; unknown
// or missing names are InputErrors (the library's message, shared with the
// Python module).
std::vector<double> ordered_coords(const LookupTable& lt,
                                   const std::map<std::string, double>& values,
                                   const std::string& where) {
    return lt.ordered_coordinates(values, where);
}

// ---------------------------------------------------------------- query

// "certified max total error 0.0253 absolute (cubic interpolation)": the
// table's stored certificate, the error between nodes that the interpolated
// stderr leaves out.
std::string certified_error_text(const StoredCertificate& c) {
    std::string s = "certified max total error " + sci_text(c.max_error) +
                    (c.absolute ? " absolute" : " relative to max(|value|, " + sci_text(c.abs_floor) + ")") +
                    " (" + c.interpolation + " interpolation";
    if (!c.passed) s += "; missed its target " + sci_text(c.target);
    return s + ")";
}

void run_query(const std::string& file, const std::string& table,
               const std::vector<std::string>& assignments, bool cubic, bool reject,
               const std::string& points_file, const std::string& output, bool json) {
    const Interpolation interp = cubic ? Interpolation::Cubic : Interpolation::Linear;
    const OutOfRange mode = reject ? OutOfRange::Reject : OutOfRange::Clamp;
    const std::map<std::string, double> fixed = parse_assignments(assignments, "argument");
    if (points_file.empty() && !output.empty())
        throw InputError("-o/--output needs --points (a single point is printed)");
    if (!output.empty()) check_output_writable(output);
    guard_table_file(file);
    if (is_adaptive_table(file, table))
        return run_adaptive_query(file, table, fixed, cubic, reject, points_file, output, json);
    const LookupTable lt = LookupTable::open(file, table);
    const auto se_table = stderr_lookup(lt);
    const char* interp_name = cubic ? "cubic" : "linear";
    const std::optional<StoredCertificate> certificate = read_stored_certificate(file, table);

    if (points_file.empty()) {
        const std::vector<double> c = ordered_coords(lt, fixed, "arguments");
        const double v = lt.eval(c, interp, mode);
        if (!reject) warn_if_clamped(lt, c, "arguments");
        if (json) {
            nlohmann::json j = {{"table", lt.table().name}, {"model", lt.model()},
                                {"quantity", lt.quantity()}, {"value", v},
                                {"units", lt.units()},      {"interpolation", interp_name}};
            if (se_table) j["stderr"] = se_table->eval(c, Interpolation::Linear, mode);
            if (certificate)
                j["certified_error"] = {{"max", certificate->max_error},
                                        {"rms", certificate->rms_error},
                                        {"measure", certificate->absolute ? "absolute" : "relative"},
                                        {"abs_floor", certificate->abs_floor},
                                        {"interpolation", certificate->interpolation},
                                        {"target", certificate->target},
                                        {"passed", certificate->passed}};
            std::cout << j.dump() << "\n";
        } else {
            std::cout << lt.table().name << " = " << fmt17(v);
            if (se_table)
                std::cout << " ± " << format_short(se_table->eval(c, Interpolation::Linear, mode))
                          << " (stderr, interpolated)";
            std::cout << " [" << lt.units() << "] (" << interp_name << ")";
            // The stderr is the integration noise at the nodes only: say what
            // is known of the error between them.
            if (certificate)
                std::cout << "; " << certified_error_text(*certificate);
            else if (se_table)
                std::cout << "; no certificate: the interpolation error is not in the ± (`brdftab certify "
                             "--store` measures it)";
            std::cout << "\n";
        }
        return;
    }

    // Rows are interpolated as they are read, so row errors and clamping
    // warnings come in file order.
    const auto names = lt.coordinate_names();
    std::ostringstream rows_csv;
    PointFileRules rules;
    rules.column_problem = [&](const std::string& h) {
        if (std::find(names.begin(), names.end(), h) != names.end()) return std::string();
        return "is not a coordinate of table '" + table + "' (coordinates: " + names_text(names) +
               ")";
    };
    rules.unique_columns = true;
    rules.on_row = [&](const PointFile& pf, const PointRow& row) {
        const std::string at = pf.where(row);
        const std::vector<double> c = ordered_coords(lt, pf.named(row, fixed), at);
        double v, se = 0;
        try {
            v = lt.eval(c, interp, mode);
            if (se_table) se = se_table->eval(c, Interpolation::Linear, mode);
        } catch (const InputError& e) {
            throw InputError(at + ": " + e.what());
        }
        if (!reject) warn_if_clamped(lt, c, at);
        for (const auto& cell : row.cells) rows_csv << cell << ",";
        rows_csv << fmt17(v);
        if (se_table) rows_csv << "," << fmt17(se);
        rows_csv << "\n";
    };
    const PointFile pf = read_point_file(points_file, rules);
    std::ostringstream csv;
    for (const auto& h : pf.header) csv << h << ",";
    csv << "value" << (se_table ? ",stderr" : "") << "\n" << rows_csv.str();
    const std::size_t rows = pf.rows.size();
    if (output.empty()) {
        std::cout << csv.str();
    } else {
        write_text_atomically(output, csv.str());
        std::cerr << "wrote " << rows << " rows to " << output << "\n";
    }
}

// ---------------------------------------------------------------- validate

struct ValidateArgs {
    std::string file, table;
    std::size_t points = 1000;
    std::string seed = "1";  // parse_seed() judges it
    std::uint64_t samples = 0;
    std::uint64_t max_samples = ValidateOptions{}.max_samples;
    double rel_floor = 1e-3;
    std::size_t worst = 5;
    bool json = false, quiet = false;
    ComputeOptions compute;
};

void run_validate(const ValidateArgs& va) {
    if (va.points < 1) throw InputError("--points must be >= 1");
    if (!(va.rel_floor > 0 && va.rel_floor < 1))
        throw InputError("--rel-floor must be in (0, 1), got " + format_short(va.rel_floor));
    guard_table_file(va.file);  // before the backend starts threads
    ValidateOptions options;
    options.points = va.points;
    options.max_samples = va.max_samples;
    options.seed = parse_seed("--seed", va.seed);
    options.samples = va.samples;
    options.rel_floor = va.rel_floor;
    options.worst = va.worst;
    const ValidationPlan plan(va.file, va.table, options);
    auto backend = va.compute.make_backend();
    std::unique_ptr<ProgressPrinter> printer;
    if (!va.quiet && plan.integral()) printer = std::make_unique<ProgressPrinter>("reference");
    const ValidationReport rep = plan.run(*backend, [&](const Progress& p) {
        if (printer) (*printer)(p);
    });
    if (printer) printer->finish();
    if (va.json) {
        std::cout << to_json(rep).dump(2) << "\n";
        return;
    }

    const std::size_t n = rep.points, dims = rep.axes.size();
    const EstimateResult& ref = rep.reference;
    const bool noisy = rep.noisy;
    const double floor = rep.relative_floor, scale = rep.max_abs_table_value;
    const ErrorStats& noise = rep.reference_noise;
    const ErrorStats& tnoise = rep.table_stderr;
    const std::vector<double>& ref_se = rep.reference_stderr;
    auto coords_text = [&](std::size_t k) {
        std::string s;
        for (std::size_t a = 0; a < dims; ++a)
            s += (a ? " " : "") + rep.axes[a].name + "=" + format_short(rep.coord(k, a));
        return s;
    };
    // An adaptive table interpolates linearly only: no cubic rows.
    const std::vector<const InterpolationErrors*> results =
        rep.adaptive ? std::vector<const InterpolationErrors*>{&rep.results[0]}
                     : std::vector<const InterpolationErrors*>{&rep.results[0], &rep.results[1]};
    std::cout << "validate " << va.file << ", table '" << rep.table << "': " << rep.model << " / "
              << rep.quantity << " [" << rep.units << "], " << (rep.adaptive ? "adaptive, " : "") << "axes";
    for (const auto& a : rep.axes) std::cout << " " << a.name << (rep.adaptive ? "" : "(" + std::to_string(a.count) + ")");
    std::cout << "\n  " << n << " random off-grid points (seed " << options.seed
              << ", uniform in each axis' warped coordinate)\n"
              << "  reference: " << to_string(ref.method) << " on " << rep.device << " ("
              << precision_name(rep.precision) << "), ";
    if (noisy) std::cout << format_count(double(ref.total_samples)) << " samples, ";
    std::cout << format_seconds(ref.elapsed_seconds) << "\n";
    if (rep.samples_capped)
        std::cout << "  note: the table asks for " << rep.table_budget
                  << " samples per point; the reference is capped at " << rep.sample_cap
                  << " (--max-samples)\n";
    if (rep.recombination_skipped)
        std::cout << "  note: the stored table is validated; its recombination recipe is not "
                     "applied\n";
    std::cout << "  relative error = |table - reference| / max(|reference|, " << format_short(floor)
              << ")   (floor = " << format_short(va.rel_floor) << " x max|table| = " << format_short(va.rel_floor)
              << " x " << format_short(scale) << ")\n\n";
    char buf[256];
    std::snprintf(buf, sizeof buf, "  %-16s %11s %11s %11s %11s %11s\n", "", "max", "rms", "p50",
                  "p95", "p99");
    std::cout << buf;
    for (const InterpolationErrors* rp : results) {
        const InterpolationErrors& r = *rp;
        for (int kind = 0; kind < 2; ++kind) {
            const ErrorStats& e = kind == 0 ? r.rel_stats : r.abs_stats;
            std::snprintf(buf, sizeof buf, "  %-7s %-8s %11.4g %11.4g %11.4g %11.4g %11.4g\n",
                          r.name, kind == 0 ? "rel" : "abs", e.max, e.rms, e.p50, e.p95, e.p99);
            std::cout << buf;
        }
    }
    if (noisy) {
        std::cout << "\n  reference stderr per point: median " << format_short(noise.p50) << ", max "
                  << format_short(noise.max) << " (" << rep.quantity_units << ")\n";
        for (const InterpolationErrors* rp : results)
            std::cout << "  " << rp->name << ": rms with the reference noise removed: abs "
                      << format_short(rp->rms_abs_corrected) << ", rel " << format_short(rp->rms_rel_corrected)
                      << "; |diff| > 3 reference stderr at " << rp->significant << "/" << n
                      << " points\n";
    }
    if (rep.has_table_stderr)
        std::cout << "  table stderr (interpolated) at the points: median " << format_short(tnoise.p50)
                  << ", max " << format_short(tnoise.max) << "\n";
    for (const InterpolationErrors* rp : results) {
        const InterpolationErrors& r = *rp;
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

// The table `plot` draws: a tensor table as stored, or an adaptive one
// (docs/adaptive.md) resampled onto the default tensor grid of `export`
// (adaptive_resample.h), with a note stating the resampling error.
LookupTable plot_table(const PlotArgs& pa) {
    if (!is_adaptive_table(pa.file, pa.table)) return LookupTable::open(pa.file, pa.table);
    if (pa.cubic)
        throw InputError("table '" + pa.table + "' of '" + pa.file +
                         "' is adaptive: its patches interpolate linearly only (no --cubic)");
    ResampleReport rep;
    TableData t = resample_adaptive(read_adaptive_table(pa.file, pa.table), ResampleOptions{}, rep);
    std::string grid;
    for (std::size_t k = 0; k < t.axes.size(); ++k)
        grid += (k ? " x " : "") + t.axes[k].name + "(" + std::to_string(rep.counts[k]) + ")";
    std::cerr << "brdftab: note: adaptive table '" << pa.table << "' drawn through a tensor grid " << grid
              << " resampled from it: resampling error max abs " << format_short(rep.max_abs) << " [" << t.units
              << "] over " << rep.probes << (rep.probes_at_centres ? " cell centres" : " random points") << "\n";
    return LookupTable(std::move(t));
}

void run_plot(const PlotArgs& pa) {
    if (pa.output.empty()) throw InputError("plot needs -o OUT.png");
    check_output_writable(pa.output);
    guard_table_file(pa.file);
    const LookupTable lt = plot_table(pa);
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
    // The slice rule of `export`: a fixed axis between nodes is interpolated,
    // and a note says so (with --cubic: Catmull-Rom, not linear weights).
    for (std::size_t a = 0; a < axes.size(); ++a) {
        if (!is_fixed[a] || axes[a].dependent()) continue;
        std::string note = slice_note(axes[a], base[a], axis_position(axes[a], base[a]));
        if (note.empty()) continue;
        if (pa.cubic) note = note.substr(0, note.find(": values")) + ": values interpolated (Catmull-Rom, --cubic)";
        std::cerr << "brdftab: note: " << note << "\n";
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
            // A critical axis holds t_k: place its node at this point's eta.
            auto node_at = [&](std::size_t axis, double tk) {
                if (!axes[axis].dependent()) return tk;
                for (std::size_t d = 0; d < axes.size(); ++d)
                    if (axes[d].name == axes[axis].depends_on) return axes[axis].warp_at(tk, c[d]);
                return tk;
            };
            if (want_curves) {
                c[ca] = node_at(ca, axes[ca].values[node]);
                cv.label = format_short(c[ca]);
            }
            for (int i = 0; i < samples; ++i) {
                c[xa] = axes[xa].min + (axes[xa].max - axes[xa].min) * i / (samples - 1);
                cv.x.push_back(c[xa]);
                cv.y.push_back(transform(lt.eval(c, interp, OutOfRange::Clamp)));
            }
            for (double tn : axes[xa].values) {
                const double xn = node_at(xa, tn);
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
        auto st = std::make_shared<State>();  // owned by the callback
        cmd->add_option("FILE", st->file, "HDF5 file written by `brdftab generate`")->required();
        cmd->add_option("VALUES", st->assignments,
                        "name=value for every axis of the table (user units, degrees for angles) "
                        "and the recombination parameter if the table has one");
        cmd->add_option("--table", st->table, "table (group) name in FILE")->required();
        cmd->add_flag("--cubic", st->cubic, "Catmull-Rom interpolation instead of multilinear");
        cmd->add_flag("--reject", st->reject,
                      "out-of-range coordinates are an error (default: clamp to the axis range "
                      "with a warning)");
        cmd->add_option("--points", st->points,
                        "CSV with a header row of coordinate names and one point per row; "
                        "name=value arguments supply columns the CSV lacks");
        cmd->add_option("-o,--output", st->output,
                        "with --points: write the CSV here (atomically) instead of stdout")
            ->check(non_empty_path());
        cmd->add_flag("--json", st->json, "single point: print one JSON object");
        cmd->callback([st] {
            run_query(st->file, st->table, st->assignments, st->cubic, st->reject, st->points,
                      st->output, st->json);
        });
    }
    // ---- validate
    {
        auto* cmd = app.add_subcommand(
            "validate",
            "accuracy certificate: compare the interpolated table (linear and cubic) with the "
            "model evaluated directly on the device at random off-grid points");
        auto st = std::make_shared<ValidateArgs>();  // owned by the callback
        cmd->add_option("FILE", st->file, "HDF5 file written by `brdftab generate`")->required();
        cmd->add_option("--table", st->table, "table (group) name in FILE")->required();
        cmd->add_option("--points", st->points, "number of random points (default 1000)");
        cmd->add_option("--seed", st->seed,
                        "seed of the random points, an integer in [0, 18446744073709551615] "
                        "(default 1)");
        cmd->add_option("--samples", st->samples,
                        "integrals: fixed sample budget per reference point (default: the "
                        "table's own budget / tolerance)")
            ->check(number_in(1, true, 4294967295.0, "integers in [1, 4294967295]"));
        cmd->add_option("--max-samples", st->max_samples,
                        "integrals: cap on the table's own budget per reference point (default "
                        "2^22 = 4194304), so a table asking for unbounded work cannot make "
                        "validate run forever; an explicit --samples is not capped")
            ->check(number_in(1, true, 4294967295.0, "integers in [1, 4294967295]"));
        cmd->add_option("--rel-floor", st->rel_floor,
                        "relative errors divide by max(|reference|, F * max|table value|); "
                        "default F = 1e-3");
        cmd->add_option("--worst", st->worst, "how many worst points to list (default 5)");
        cmd->add_flag("--json", st->json, "print the report as JSON");
        cmd->add_flag("-q,--quiet", st->quiet, "no progress display");
        st->compute.add_to(*cmd, false);
        cmd->callback([st] { run_validate(*st); });
    }
    // ---- plot
    {
        auto* cmd = app.add_subcommand(
            "plot",
            "draw a 1-D slice (curves) or 2-D slice (colour map) of a table as a PNG");
        auto st = std::make_shared<PlotArgs>();  // owned by the callback
        cmd->add_option("FILE", st->file, "HDF5 file written by `brdftab generate`")->required();
        cmd->add_option("--table", st->table, "table (group) name in FILE")->required();
        cmd->add_option("--slice", st->slices,
                        "name=value fixing an axis (repeat); one free axis gives curves, two a "
                        "colour map");
        cmd->add_option("-o,--output", st->output, "PNG file to write")
            ->required()
            ->check(non_empty_path());
        cmd->add_option("--x", st->x_axis, "free axis for the horizontal direction");
        cmd->add_option("--curves", st->curves_axis,
                        "with two free axes: one curve per node of this axis (at most 10) "
                        "instead of a colour map");
        cmd->add_flag("--cubic", st->cubic, "Catmull-Rom interpolation instead of multilinear");
        cmd->add_flag("--log", st->log, "plot log10 of the value (values <= 0 are left out)");
        cmd->callback([st] { run_plot(*st); });
    }
}

}  // namespace brdftab::cli
