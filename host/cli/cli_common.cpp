#include "host/cli/cli_common.h"

#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <iostream>
#include <sstream>

#include "host/core/error.h"
#include "host/core/text.h"

namespace brdftab::cli {

void ComputeOptions::add_to(CLI::App& app, bool with_integration) {
    app.add_option("--device", device,
                   "OpenCL device: index or name substring (see `brdftab devices`), or `host` "
                   "for the serial C++ reference. Default: $BRDFTAB_DEVICE, else the first CPU "
                   "device");
    app.add_option("--precision", precision, "kernel floating type: double (default) or float")
        ->check(CLI::IsMember({"double", "float"}));
    app.add_option("--kernel-dir", kernel_dir,
                   "load kernel sources from this directory instead of the embedded copy "
                   "(development)");
    if (!with_integration) return;
    app.add_option("--method", method, "integration method: auto, closed-form, quadrature, mc, rqmc (default: each quantity's own, see `brdftab models`)")
        ->check(CLI::IsMember(method_names()));
    app.add_option("--samples", samples, "fixed sample budget per cell (default 4096)")
        ->check(CLI::PositiveNumber);
    app.add_option("--tolerance", tolerance,
                   "adaptive: stop each cell when its standard error <= tolerance * |value| "
                   "(or <= --abs-floor); in (0, 1)")
        ->check(CLI::Range(0.0, 1.0));
    app.add_option("--abs-floor", abs_floor,
                   "absolute standard-error floor for values near zero (default 1e-6)")
        ->check(CLI::PositiveNumber);
    app.add_option("--max-samples", max_samples, "sample cap per cell under --tolerance")
        ->check(CLI::PositiveNumber);
    app.add_option("--seed", seed, "random seed (64-bit); same seed, same table")
        ->each([this](const std::string&) { seed_given = true; });
    app.add_option("--slab", slab,
                   "work items per device launch (results do not depend on it)")
        ->check(CLI::PositiveNumber);
}

IntegrationSettings ComputeOptions::apply(IntegrationSettings s) const {
    if (!method.empty()) s.method = parse_method(method);
    if (samples) {
        s.samples = samples;
        if (tolerance <= 0) s.tolerance = 0;  // an explicit budget on the CLI wins
    }
    if (tolerance > 0) s.tolerance = tolerance;
    if (abs_floor > 0) s.abs_floor = abs_floor;
    if (max_samples) s.max_samples = max_samples;
    if (seed_given) s.seed = seed;
    if (slab) s.slab_work_items = slab;
    return s;
}

std::unique_ptr<Backend> ComputeOptions::make_backend() const {
    return brdftab::make_backend(device, parse_precision(precision), kernel_dir);
}

ProgressPrinter::ProgressPrinter(std::string label)
    : label_(std::move(label)), tty_(isatty(STDERR_FILENO) != 0),
      last_(std::chrono::steady_clock::now()) {}

void ProgressPrinter::operator()(const Progress& p) {
    const auto now = std::chrono::steady_clock::now();
    const double since = std::chrono::duration<double>(now - last_).count();
    const bool final = p.fraction >= 1.0;
    // Terminal: redraw at most 10x per second.  Log: a line every 5 s.
    if (!final && since < (tty_ ? 0.1 : 5.0)) return;
    if (final && last_fraction_ >= 1.0) return;
    last_ = now;
    last_fraction_ = p.fraction;
    const double rate = p.elapsed_seconds > 0 ? p.samples_done / p.elapsed_seconds : 0;
    const double eta = p.fraction > 0 ? p.elapsed_seconds * (1 - p.fraction) / p.fraction : 0;
    std::ostringstream line;
    line << label_ << " ";
    if (tty_) {
        const int width = 30;
        const int filled = static_cast<int>(std::lround(p.fraction * width));
        line << "[" << std::string(filled, '#') << std::string(width - filled, '.') << "] ";
    }
    char pct[16];
    std::snprintf(pct, sizeof pct, "%5.1f%%", 100 * p.fraction);
    line << pct << "  cells " << p.cells_done << "/" << p.cells_total << "  "
         << format_count(rate) << " samples/s  elapsed " << format_seconds(p.elapsed_seconds);
    if (!final) line << "  ETA " << format_seconds(eta);
    if (tty_)
        std::cerr << "\r" << line.str() << "\033[K" << std::flush;
    else
        std::cerr << line.str() << "\n" << std::flush;
    printed_ = true;
}

void ProgressPrinter::finish() {
    if (tty_ && printed_) std::cerr << "\n";
    printed_ = false;
}

std::pair<std::string, std::string> split_assignment(const std::string& arg) {
    const auto eq = arg.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == arg.size())
        throw InputError("argument '" + arg + "' is not of the form name=value");
    return {arg.substr(0, eq), arg.substr(eq + 1)};
}

std::string format_double(double v) { return number_text(v, 17); }

std::string format_short(double v) { return number_text(v, 6); }

std::string format_seconds(double s) {
    char buf[32];
    if (s < 60)
        std::snprintf(buf, sizeof buf, "%.1fs", s);
    else if (s < 3600)
        std::snprintf(buf, sizeof buf, "%dm%02ds", static_cast<int>(s) / 60, static_cast<int>(s) % 60);
    else
        std::snprintf(buf, sizeof buf, "%dh%02dm", static_cast<int>(s) / 3600,
                      (static_cast<int>(s) % 3600) / 60);
    return buf;
}

std::string format_count(double n) {
    char buf[32];
    if (n >= 1e9)
        std::snprintf(buf, sizeof buf, "%.2fG", n / 1e9);
    else if (n >= 1e6)
        std::snprintf(buf, sizeof buf, "%.2fM", n / 1e6);
    else if (n >= 1e3)
        std::snprintf(buf, sizeof buf, "%.1fk", n / 1e3);
    else
        std::snprintf(buf, sizeof buf, "%.0f", n);
    return buf;
}

CLI::Validator non_empty_path() {
    return CLI::Validator(
        [](std::string& path) {
            return path.empty() ? std::string("an empty path is not a file name") : std::string();
        },
        "PATH");
}

}  // namespace brdftab::cli
