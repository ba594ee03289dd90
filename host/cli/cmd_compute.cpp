// eval and generate: the commands that run the engine.
#include <sys/stat.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include "host/core/atomic_file.h"
#include "host/cli/cli_common.h"
#include "host/cli/commands.h"
#include "host/core/error.h"
#include "host/generate/generate.h"
#include "host/spec/spec.h"
#include "host/io/table_io.h"

namespace brdftab::cli {

void register_eval(CLI::App& app) {
    auto* cmd = app.add_subcommand(
        "eval",
        "evaluate one quantity at one point (or at every row of --points FILE.csv) on the "
        "device, with its standard error");
    struct State {
        std::string model, quantity;
        std::vector<std::string> assignments;
        bool json = false;
        std::string points_file, output;
        ComputeOptions compute;
    };
    static State st;
    cmd->add_option("MODEL", st.model, "model name (see `brdftab models`)")->required();
    cmd->add_option("QUANTITY", st.quantity, "quantity of the model")->required();
    cmd->add_option("VALUES", st.assignments,
                    "name=value pairs: directions theta_i phi_i theta_o phi_o phi_d (degrees) "
                    "or mu_i mu_o, model parameters, and options (e.g. distribution=ggx)");
    cmd->add_flag("--json", st.json, "print one JSON object (value, stderr, samples, method)");
    cmd->add_option("--points", st.points_file,
                    "CSV file with a header row of coordinate/parameter names and one point per "
                    "row; all rows are evaluated in one device launch");
    cmd->add_option("-o,--output", st.output, "with --points: write the CSV here instead of stdout");
    st.compute.add_to(*cmd);
    cmd->callback([] {
        const ModelInfo& model = find_model(st.model);
        const QuantityInfo& q = model.quantity(st.quantity);
        PointBuilder builder(model, q);
        nlohmann::json option_values = nlohmann::json::object();
        std::map<std::string, double> fixed;
        for (const auto& a : st.assignments) {
            auto [name, text] = split_assignment(a);
            if (model.find_option(name)) {
                option_values[name] = text;
                continue;
            }
            const double v = parse_number(text, "argument '" + name + "'");
            const std::string problem = builder.check(name, v);
            if (!problem.empty()) throw InputError("argument '" + a + "': " + problem);
            fixed[name] = v;
        }
        const std::vector<int> options = resolve_options(model, option_values, "argument");

        // Points: one from the arguments, or one per CSV row (arguments act as
        // defaults for columns the CSV does not have).
        std::vector<std::string> header;
        std::vector<std::vector<std::string>> rows;
        std::vector<std::map<std::string, double>> points;
        if (!st.points_file.empty()) {
            std::ifstream in(st.points_file);
            if (!in) throw InputError("cannot open points file '" + st.points_file + "'");
            std::string line;
            std::size_t line_no = 0;
            while (std::getline(in, line)) {
                ++line_no;
                if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
                if (header.empty()) {
                    header = split_csv(line);
                    for (const auto& h : header)
                        if (!is_direction_coordinate(h) && !model.find_parameter(h))
                            throw InputError(st.points_file + ":" + std::to_string(line_no) +
                                             ": column '" + h +
                                             "' is not a coordinate or parameter of '" +
                                             model.name + "'");
                    continue;
                }
                auto cells = split_csv(line);
                if (cells.size() != header.size())
                    throw InputError(st.points_file + ":" + std::to_string(line_no) + ": " +
                                     std::to_string(cells.size()) + " columns, header has " +
                                     std::to_string(header.size()));
                std::map<std::string, double> p = fixed;
                for (std::size_t c = 0; c < cells.size(); ++c) {
                    const std::string where = st.points_file + ":" + std::to_string(line_no) +
                                              ": column '" + header[c] + "'";
                    const double v = parse_number(cells[c], where);
                    const std::string problem = builder.check(header[c], v);
                    if (!problem.empty()) throw InputError(where + ": " + problem);
                    p[header[c]] = v;
                }
                rows.push_back(cells);
                points.push_back(std::move(p));
            }
            if (points.empty()) throw InputError("points file '" + st.points_file + "' has no rows");
        } else {
            points.push_back(fixed);
        }
        const std::size_t stride = model.point_stride();
        std::vector<double> kernel_points(points.size() * stride);
        for (std::size_t k = 0; k < points.size(); ++k) {
            try {
                builder.build(points[k], &kernel_points[k * stride]);
            } catch (const InputError& e) {
                throw InputError((st.points_file.empty() ? std::string("arguments")
                                                         : st.points_file + " row " +
                                                               std::to_string(k + 1)) +
                                 ": " + e.what());
            }
        }
        IntegrationSettings settings = st.compute.apply(IntegrationSettings{});
        if (!st.output.empty()) check_output_writable(st.output);
        auto backend = st.compute.make_backend();
        EstimateResult r = estimate(
            *backend, model, q, options, points.size(),
            [&](std::size_t cell, double* out) {
                std::copy_n(&kernel_points[cell * stride], stride, out);
            },
            settings);

        if (st.points_file.empty()) {
            if (st.json) {
                nlohmann::json j = {{"model", model.name},
                                    {"quantity", q.name},
                                    {"value", r.value[0]},
                                    {"stderr", r.stderr_[0]},
                                    {"samples", r.method == Method::ClosedForm ? 1u : r.samples[0]},
                                    {"method", to_string(r.method)},
                                    {"units", q.units},
                                    {"device", backend->device_name()},
                                    {"precision", precision_name(backend->precision())}};
                std::cout << j.dump() << "\n";
            } else {
                std::cout << model.name << " " << q.name << " = " << format_double(r.value[0]);
                if (r.method != Method::ClosedForm)
                    std::cout << " ± " << r.stderr_[0] << " (1 stderr, " << r.samples[0]
                              << " samples, " << to_string(r.method) << ")";
                else
                    std::cout << " (closed form)";
                std::cout << " [" << q.units << "]\n";
            }
            return;
        }
        std::ostringstream csv;
        for (const auto& h : header) csv << h << ",";
        csv << "value,stderr,samples\n";
        for (std::size_t k = 0; k < rows.size(); ++k) {
            for (const auto& c : rows[k]) csv << c << ",";
            csv << format_double(r.value[k]) << "," << format_double(r.stderr_[k]) << ","
                << (r.method == Method::ClosedForm ? 1u : r.samples[k]) << "\n";
        }
        if (st.output.empty()) {
            std::cout << csv.str();
        } else {
            write_text_atomically(st.output, csv.str());
            std::cerr << "wrote " << rows.size() << " rows to " << st.output << "\n";
        }
    });
}

namespace {

// "3.9%" for relative errors, "0.0012 1/sr" for absolute ones.
std::string format_error(double e, const ErrorSummary& s, const std::string& units) {
    if (s.measure == "relative") {
        std::ostringstream o;
        o.precision(3);
        o << e * 100 << "%";
        return o.str();
    }
    return units.empty() || units == "1" ? format_short(e) : format_short(e) + " " + units;
}

void print_error_summary(const ErrorSummary& s, const TableData& d) {
    std::cout << "    " << s.measure << " error of " << s.table << " against " << s.reference
              << ": max |e| " << format_error(s.max_abs, s, d.units) << " at ";
    for (std::size_t a = 0; a < s.worst.size(); ++a)
        std::cout << (a ? ", " : "") << d.axes[a].name << " " << format_short(s.worst[a]);
    std::cout << "; RMS " << format_error(s.rms, s, d.units) << ", mean "
              << format_error(s.mean, s, d.units) << "; noise (median stderr) "
              << format_error(s.median_stderr, s, d.units) << "; " << s.beyond_2sigma << " of "
              << s.cells << " cells beyond 2 stderr\n";
    if (s.nonfinite)
        std::cout << "    warning: " << s.nonfinite << " cell(s) are NaN or infinite\n";
    for (const auto& n : s.by_nodes)
        std::cout << "      " << s.by << " = " << format_short(n.value) << ": max |e| "
                  << format_error(n.max_abs, s, d.units) << ", RMS "
                  << format_error(n.rms, s, d.units) << "\n";
}

}  // namespace

void register_generate(CLI::App& app) {
    auto* cmd = app.add_subcommand(
        "generate",
        "compute every table of a TOML spec (see tables/ and docs/spec.md) and write them to "
        "one HDF5 file");
    struct State {
        std::string spec_path, output;
        ComputeOptions compute;
        bool quiet = false;
    };
    static State st;
    cmd->add_option("SPEC", st.spec_path, "table specification (TOML)")->required();
    cmd->add_option("-o,--output", st.output, "output file (default: the spec's output.path)");
    cmd->add_flag("-q,--quiet", st.quiet, "no progress display");
    st.compute.add_to(*cmd);
    cmd->callback([] {
        Spec spec = parse_spec_file(st.spec_path);
        const std::string out_path = st.output.empty() ? spec.output.path : st.output;
        check_output_writable(out_path);
        const IntegrationSettings settings = st.compute.apply(spec.integration);
        auto backend = st.compute.make_backend();
        std::cerr << "brdftab: " << spec.model << ", " << spec.tables.size() << " table(s)";
        if (!spec.recombined.empty()) std::cerr << " + " << spec.recombined.size() << " recombined";
        if (!spec.errors.empty()) std::cerr << " + " << spec.errors.size() << " error table(s)";
        if (!spec.inverted.empty()) std::cerr << " + " << spec.inverted.size() << " inverted";
        std::cerr << " from " << st.spec_path << " on " << backend->device_name()
                  << " (" << precision_name(backend->precision()) << ")\n";
        std::unique_ptr<ProgressPrinter> printer;
        std::size_t current = static_cast<std::size_t>(-1);
        auto on_progress = [&](const GenerateEvent& e) {
            if (st.quiet) return;
            if (e.table_index != current) {
                if (printer) printer->finish();
                current = e.table_index;
                printer = std::make_unique<ProgressPrinter>(
                    "[" + std::to_string(e.table_index + 1) + "/" +
                    std::to_string(e.table_count) + "] " + e.table->name);
            }
            (*printer)(e.progress);
        };
        std::vector<GeneratedTable> tables = generate_tables(spec, *backend, settings, on_progress);
        if (printer) printer->finish();
        std::vector<TableData> data;
        for (auto& t : tables) data.push_back(t.data);
        write_tables(out_path, data);
        std::cout << "wrote " << out_path << "\n";
        for (const auto& t : tables) {
            const TableData& d = t.data;
            double lo = d.value.empty() ? 0 : d.value[0], hi = lo;
            for (double v : d.value) lo = std::min(lo, v), hi = std::max(hi, v);
            std::cout << "  " << d.name << ": " << d.quantity << " [";
            for (std::size_t a = 0; a < d.axes.size(); ++a)
                std::cout << (a ? " x " : "") << d.axes[a].name << " " << d.axes[a].count;
            std::cout << "] = " << d.cell_count() << " cells, " << method_attribute(d);
            if (d.kind == TableKind::Computed &&
                (d.method == Method::MonteCarlo || d.method == Method::Rqmc ||
                 d.method == Method::Quadrature))
                std::cout << ", " << format_count(static_cast<double>(d.total_samples))
                          << " samples, max rel. stderr " << d.tolerance_achieved;
            std::cout << ", values in [" << lo << ", " << hi << "], "
                      << format_seconds(d.elapsed_seconds) << "\n";
            if (t.cells_unconverged)
                std::cout << "  warning: " << t.cells_unconverged
                          << " cell(s) reached max_samples before the tolerance\n";
            if (t.error) print_error_summary(*t.error, d);
        }
    });
}

}  // namespace brdftab::cli
