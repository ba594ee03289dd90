// devices, models, info: commands that only describe things.
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <memory>

#include "host/adaptive/adaptive_io.h"
#include "host/cli/cli_adaptive.h"
#include "host/cli/cli_common.h"
#include "host/cli/commands.h"
#include "host/cli/read_guard.h"
#include "host/core/error.h"
#include "host/core/text.h"
#include "host/engine/opencl_runtime.h"
#include "host/io/bit_rounding.h"
#include "host/io/table_io.h"
#include "host/plan/certify.h"

namespace brdftab::cli {

void register_devices(CLI::App& app) {
    auto* cmd = app.add_subcommand("devices", "list OpenCL devices (and the `host` reference)");
    cmd->callback([] {
        const auto devices = list_devices();
        for (const auto& d : devices) {
            std::cout << "[" << d.index << "] " << d.name << "\n"
                      << "    platform: " << d.platform_name << " (" << d.version << ")\n"
                      << "    type: " << (d.is_cpu ? "CPU" : d.is_gpu ? "GPU" : "other")
                      << ", compute units: " << d.compute_units
                      << ", fp64: " << (d.has_fp64 ? "yes" : "no")
                      << ", memory: " << d.global_mem_bytes / (1024 * 1024) << " MiB"
                      << ", max allocation: " << d.max_alloc_bytes / (1024 * 1024) << " MiB\n";
        }
        std::cout << "[host] serial C++ reference path (double precision, one core)\n";
        const DeviceInfo chosen = select_device("");
        std::cout << "default: [" << chosen.index << "] " << chosen.name
                  << " (override with --device or BRDFTAB_DEVICE)\n";
    });
}

namespace {

// A unit for people: "1" (a pure number) reads as a count otherwise.
std::string unit_text(const std::string& unit) {
    return unit.empty() || unit == "1" ? "dimensionless" : unit;
}

// Names padded to the longest in their list (plus two spaces), so a long
// name shifts its column instead of running into the text after it.
template <class Items>
int name_width(const Items& items) {
    std::size_t w = 12;
    for (const auto& it : items) w = std::max(w, it.name.size());
    return static_cast<int>(w + 2);
}

void print_model(const ModelInfo& m) {
    std::cout << m.name << "\n  " << m.description << "\n  Source: " << m.citation
              << "\n  Parameters:\n";
    const int pw = name_width(m.parameters);
    for (const auto& p : m.parameters) {
        std::cout << "    " << std::left << std::setw(pw) << p.name << p.range_text();
        if (p.default_value) std::cout << "  default " << *p.default_value;
        std::cout << "  " << p.description << "\n";
    }
    std::cout << "  Options:\n";
    const int ow = name_width(m.options);
    for (const auto& o : m.options) {
        std::cout << "    " << std::left << std::setw(ow) << o.name;
        for (std::size_t k = 0; k < o.choices.size(); ++k)
            std::cout << (k ? " | " : "") << o.choices[k];
        std::cout << "  (default " << o.default_choice << ")  " << o.description << "\n";
    }
    std::cout << "  Quantities:\n";
    const int qw = name_width(m.quantities);
    for (const auto& q : m.quantities) {
        std::cout << "    " << std::left << std::setw(qw) << q.name << "["
                  << (q.kind == QuantityKind::ClosedForm ? "closed form" : "integral, " +
                                                                               to_string(q.default_method))
                  << "; " << unit_text(q.units) << "; depends on:";
        for (const auto& d : q.directions) std::cout << " " << d;
        if (q.directions.empty()) std::cout << " no direction";
        std::cout << "] " << q.description << "  (" << q.equations << ")\n";
        // Which stored types a float (single-precision) kernel can fill
        // without its rounding showing (--precision float).
        std::cout << "    " << std::string(static_cast<std::size_t>(qw), ' ') << "--precision float: ";
        if (!q.float_measured()) {
            std::cout << "not measured\n";
        } else {
            std::cout << "max rel. |float - double| " << q.float_max_rel_diff << " on the presets; "
                      << (q.float_enough_for_float32()   ? "fine for float32 and float16 tables"
                          : q.float_enough_for_float16() ? "fine for float16 tables; float32 tables need double"
                                                         : "float32 and float16 tables both need double");
            if (!q.float_note.empty()) std::cout << " (fails at: " << q.float_note << ")";
            std::cout << "\n";
        }
    }
}

}  // namespace

void register_models(CLI::App& app) {
    auto* cmd = app.add_subcommand(
        "models",
        "list models (or one: `brdftab models MODEL`): quantities, parameters with allowed "
        "ranges, options, equations");
    struct State {
        bool json = false;
        std::string model;
    };
    auto state = std::make_shared<State>();  // owned by the callback
    cmd->add_option("MODEL", state->model, "show this model only");
    cmd->add_flag("--json", state->json, "machine-readable output");
    cmd->callback([state] {
        std::vector<const ModelInfo*> chosen;
        if (state->model.empty()) {
            for (const auto& m : all_models()) chosen.push_back(&m);
        } else {
            chosen.push_back(&find_model(state->model));  // InputError names the known models
        }
        if (state->json) {
            nlohmann::json all = describe_models();
            if (state->model.empty()) {
                std::cout << all.dump(2) << "\n";
                return;
            }
            for (const auto& j : all)
                if (j.is_object() && j.value("name", "") == state->model) {
                    std::cout << j.dump(2) << "\n";
                    return;
                }
            std::cout << all.dump(2) << "\n";
            return;
        }
        for (const ModelInfo* m : chosen) {
            print_model(*m);
            std::cout << "\n";
        }
        std::cout << "Directions: theta in [0, 180] deg from the macro normal (> 90 = below the "
                     "surface), phi in deg; phi_d = phi_o - phi_i; mu = cos(theta).\n";
    });
}

namespace {
void print_table_summary(const TableData& t, bool verbose) {
    std::cout << "  table '" << t.name << "': " << t.model << " / " << t.quantity << " ["
              << t.units << "]\n";
    std::cout << "    shape:";
    for (const auto& a : t.axes) std::cout << " " << a.name << "=" << a.count;
    std::cout << "  (" << t.cell_count() << " cells, stored " << stored_type_name(t.stored_type)
              << ")\n";
    if (t.round_accuracy > 0) {  // rounded storage (host/io/bit_rounding.h)
        const RoundingRule rule = value_rounding(t);
        double max_abs = 0;
        for (double v : t.value)
            if (std::isfinite(v)) max_abs = std::max(max_abs, std::fabs(v));
        std::cout << "    storage: rounded for " << t.round_accuracy << " ("
                  << (t.round_absolute ? "absolute" : "relative") << "): ";
        if (!rule.active())
            std::cout << "every bit of " << stored_type_name(t.stored_type) << " needed\n";
        else
            std::cout << absolute_keep_bits(max_abs, rule) << " of " << mantissa_bits(t.stored_type)
                      << " mantissa bits kept" << (t.round_absolute ? " (largest value)" : "")
                      << ", error <= " << rule.bound << (t.round_absolute ? " " + t.units : " x |value|")
                      << "\n";
    }
    for (const auto& a : t.axes)
        std::cout << "    axis " << std::left << std::setw(8) << a.name << " [" << a.min << ", "
                  << a.max << "]" << unit_suffix(a.unit) << ", " << a.count << " nodes, "
                  << spacing_name(a.spacing) << "\n";
    std::cout << "    parameters: " << t.parameters.dump() << "\n";
    if (!t.spec_file.empty() || !t.spec_text.empty())
        std::cout << "    spec: " << (t.spec_file.empty() ? "(unnamed)" : t.spec_file)
                  << (t.spec_text.empty() ? "" : ", text stored (attribute 'spec')") << "\n";
    std::cout << "    method: " << method_attribute(t);
    if (t.kind != TableKind::Computed) {
        std::cout << " (formed from other tables of the file; see parameters)";
    } else if (t.method == Method::Quadrature) {
        // A deterministic rule: no sample budget to report.
        std::cout << " (accurate and coarse rule; error estimate = their difference), "
                     "tolerance metric difference/max(|value|, floor) "
                  << t.tolerance_achieved;
    } else if (t.method != Method::ClosedForm) {
        std::cout << ", samples/cell requested " << t.samples_requested;
        if (t.tolerance_requested > 0) std::cout << ", tolerance " << t.tolerance_requested;
        if (t.stderr_.size() == t.value.size() && !t.stderr_.empty()) {
            double se_abs = 0, se_rel = 0;
            for (std::size_t k = 0; k < t.value.size(); ++k) {
                se_abs = std::max(se_abs, t.stderr_[k]);
                if (t.value[k] != 0) se_rel = std::max(se_rel, t.stderr_[k] / std::fabs(t.value[k]));
            }
            std::cout << ", max stderr " << se_abs << " absolute, " << se_rel << " relative";
        }
        std::cout << ", tolerance metric stderr/max(|value|, floor) " << t.tolerance_achieved
                  << ", total samples " << t.total_samples;
    }
    std::cout << "\n    computed on " << t.device << " (" << t.precision << ") in "
              << format_seconds(t.elapsed_seconds) << ", seed " << t.seed << ", brdftab "
              << t.version << "\n";
    if (verbose && !t.value.empty()) {
        double lo = t.value[0], hi = t.value[0], se = 0;
        for (double v : t.value) lo = std::min(lo, v), hi = std::max(hi, v);
        for (double s : t.stderr_) se = std::max(se, s);
        std::cout << "    values in [" << lo << ", " << hi << "]";
        if (!t.stderr_.empty()) std::cout << ", max stderr " << se;
        std::cout << "\n";
    }
}
// A table's stored certificate (`certificate_*` attributes, docs/format.md),
// written by `generate --accuracy/--budget` or `certify --store`.
void print_certificate(const Certificate& c) {
    std::cout << "    certificate: " << (c.passed ? "passed" : "FAILED") << " (" << c.mode << "), "
              << certificate_error_text(c);
    if (!c.absolute) std::cout << ", floor " << sci_text(c.abs_floor);
    std::cout << "\n      " << (c.interpolation == Interpolation::Cubic ? "cubic" : "linear")
              << " interpolation; " << c.probes << " probes (" << c.line_probes << " on lines, "
              << c.random_probes << " random, " << c.node_probes << " at nodes, " << c.local_probes
              << " local); reference " << c.reference_method;
    if (c.reference_noise > 0) std::cout << " (noise " << sci_text(c.reference_noise) << ")";
    std::cout << "; " << sci_text(c.seconds) << " s";
    if (std::isfinite(c.predicted_max))
        std::cout << "; predicted max " << sci_text(c.predicted_max) << ", RMS " << sci_text(c.predicted_rms);
    if (c.refinements > 0) std::cout << "; after " << c.refinements << " refinement(s)";
    std::cout << "\n";
    if (!c.axis_names.empty()) {
        std::cout << "      largest along the lines:";
        for (std::size_t a = 0; a < c.axis_names.size() && a < c.axis_max.size(); ++a)
            std::cout << " " << c.axis_names[a] << " " << sci_text(c.axis_max[a]);
        std::cout << "\n";
    }
}
}  // namespace

void register_info(CLI::App& app) {
    auto* cmd = app.add_subcommand("info", "describe a brdftab table file");
    struct State {
        std::string path;
        bool values = false;
    };
    auto state = std::make_shared<State>();  // owned by the callback
    cmd->add_option("FILE", state->path, "HDF5 file written by `brdftab generate`")->required();
    cmd->add_flag("--values", state->values, "also read the data and print value ranges");
    cmd->callback([state] {
        const std::string& path = state->path;
        const bool values = state->values;
        guard_table_file(path);
        // One open file for the listing and every table: a file replaced
        // meanwhile (atomically, by another run) is read whole, old or new.
        const TableReader reader(path);
        const auto names = reader.table_names();
        const auto attrs = reader.file_attributes();
        std::vector<TableData> tables;
        std::vector<AdaptiveTable> adaptive;  // docs/adaptive.md
        for (const auto& n : names)
            if (is_adaptive_table(reader, n))
                adaptive.push_back(read_adaptive_table(reader, n));
            else
                tables.push_back(reader.read(n));
        std::cout << path << ": " << names.size() << " table(s)";
        if (attrs.contains("brdftab_version") && attrs["brdftab_version"].is_string())
            std::cout << ", written by brdftab " << attrs["brdftab_version"].get<std::string>();
        std::cout << "\n";
        for (const auto& t : tables) {
            print_table_summary(t, values);
            if (const auto c = read_certificate(reader, t.name)) print_certificate(*c);
        }
        for (const auto& t : adaptive) {
            print_adaptive_summary(t, values);
            if (const auto c = read_certificate(reader, t.data.name)) print_certificate(*c);
        }
    });
}

}  // namespace brdftab::cli
