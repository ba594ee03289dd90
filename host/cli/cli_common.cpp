#include "host/cli/cli_common.h"

#include <sys/statvfs.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include "host/core/error.h"
#include "host/core/text.h"
#include "host/engine/engine_tuning.h"
#include "host/plan/certify.h"

namespace brdftab::cli {

void ComputeOptions::add_to(CLI::App& app, bool with_integration) {
    app.add_option("--device", device,
                   "OpenCL device: index or name substring (see `brdftab devices`), `host` "
                   "for the serial C++ reference, or `host-threads[:N]` for the same on one "
                   "thread per core (N threads). Default: $BRDFTAB_DEVICE, else the first CPU "
                   "device");
    app.add_option("--precision", precision, "kernel floating type: double (default) or float")
        ->check(CLI::IsMember({"double", "float"}));
    app.add_option("--kernel-dir", kernel_dir,
                   "load kernel sources from this directory instead of the embedded copy "
                   "(development)");
    if (!with_integration) return;
    app.add_option("--method", method, "integration method: auto, closed-form, quadrature, mc, rqmc (default: each quantity's own, see `brdftab models`)")
        ->check(CLI::IsMember(method_names()));
    // --samples, --tolerance and --max-samples are range-checked by apply(),
    // which names the option and the range and exits with code 2.
    app.add_option("--samples", samples,
                   "fixed sample budget per cell, in [1, 4294967295] (default 4096)")
        ->each([this](const std::string& text) {
            samples_given = true;
            samples_text = text;
        });
    app.add_option("--tolerance", tolerance,
                   "adaptive: stop each cell when its standard error <= tolerance * |value| "
                   "(or <= --abs-floor); in (0, 1)")
        ->each([this](const std::string&) { tolerance_given = true; });
    app.add_option("--abs-floor", abs_floor,
                   "absolute standard-error floor for values near zero (default 1e-6)")
        ->check(number_in(0, false, 1e308, "a number > 0"));
    app.add_option("--max-samples", max_samples,
                   "sample cap per cell under --tolerance, in [1, 4294967295]")
        ->each([this](const std::string& text) {
            max_samples_given = true;
            max_samples_text = text;
        });
    app.add_option("--seed", seed_text,
                   "random seed, an integer in [0, 18446744073709551615]; same seed, same table")
        ->each([this](const std::string&) { seed_given = true; });
    app.add_option("--slab", slab,
                   "work items per device launch (results do not depend on it)")
        ->check(number_in(1, true, 1e18, "integers >= 1"));
}

IntegrationSettings ComputeOptions::apply(IntegrationSettings s) const {
    // CLI11 reads "-1" as 2^64 - 1 and saturates overflows: judge the text too.
    auto check_count = [](const char* option, std::uint64_t v, const std::string& text) {
        const bool negative = text.find('-') != std::string::npos;
        if (negative || v < 1 || v > kMaxSampleCount)
            throw InputError(std::string(option) + " " + text +
                             " is out of range; allowed: " + sample_count_range_text());
    };
    if (!method.empty()) s.method = parse_method(method);
    if (samples_given) {
        check_count("--samples", samples, samples_text);
        s.samples = samples;
        if (!tolerance_given) s.tolerance = 0;  // an explicit budget on the CLI wins
    }
    if (tolerance_given) {
        if (!(tolerance > 0 && tolerance < 1))
            throw InputError("--tolerance " + number_text(tolerance) +
                             " is out of range; allowed: (0, 1)");
        s.tolerance = tolerance;
    }
    if (abs_floor > 0) s.abs_floor = abs_floor;
    if (max_samples_given) {
        check_count("--max-samples", max_samples, max_samples_text);
        s.max_samples = max_samples;
    }
    if (seed_given) s.seed = parse_seed("--seed", seed_text);
    if (slab) s.slab_work_items = slab;
    return s;
}

std::uint64_t parse_seed(const std::string& option, const std::string& text) {
    const std::string allowed = "allowed: integers in [0, 18446744073709551615]";
    auto all_digits = [](const std::string& t) {
        return !t.empty() && t.find_first_not_of("0123456789") == std::string::npos;
    };
    if (!all_digits(text)) {
        const bool negative = text.size() > 1 && text[0] == '-' && all_digits(text.substr(1));
        throw InputError(option + " '" + text + "' " +
                         (negative ? "is out of range" : "is not an integer") + "; " + allowed);
    }
    errno = 0;
    const unsigned long long v = std::strtoull(text.c_str(), nullptr, 10);
    if (errno == ERANGE) throw InputError(option + " '" + text + "' is out of range; " + allowed);
    static_assert(sizeof v == sizeof(std::uint64_t), "unsigned long long holds a 64-bit seed");
    return v;
}

std::unique_ptr<Backend> ComputeOptions::make_backend() const {
    return brdftab::make_backend(device, parse_precision(precision), kernel_dir);
}

namespace {
// Seconds between two progress lines in a log: 30, or
// $BRDFTAB_PROGRESS_INTERVAL (seconds, > 0; for tests and impatient users).
double log_interval() {
    const char* env = environment_setting("BRDFTAB_PROGRESS_INTERVAL");
    if (env && *env) {
        char* end = nullptr;
        const double v = std::strtod(env, &end);
        if (end && *end == '\0' && v > 0 && std::isfinite(v)) return v;
    }
    return 30.0;
}
}  // namespace

ProgressPrinter::ProgressPrinter(std::string label, bool sampled)
    : label_(std::move(label)), sampled_(sampled), tty_(isatty(STDERR_FILENO) != 0),
      last_(std::chrono::steady_clock::now()), interval_(tty_ ? 0.1 : log_interval()) {}

void ProgressPrinter::operator()(const Progress& p) {
    const auto now = std::chrono::steady_clock::now();
    const double since = std::chrono::duration<double>(now - last_).count();
    const bool final = p.fraction >= 1.0;
    // Terminal: redraw at most 10x per second.  Log: one line per interval.
    // The engine reports after every launch, and sizes launches to well under
    // a second, so these are also the longest gaps between updates.
    // The first report is printed at once, so a log shows the run has
    // started (and its rate) without waiting a whole interval.
    if (!final && printed_ && since < interval_) return;
    if (final && last_fraction_ >= 1.0) return;
    last_ = now;
    last_fraction_ = p.fraction;
    const double rate =
        p.elapsed_seconds > 0 ? static_cast<double>(sampled_ ? p.samples_done : p.cells_done) / p.elapsed_seconds : 0;
    // Before any cell is done there is nothing to extrapolate from: no ETA yet.
    const double eta = p.fraction > 0 ? p.elapsed_seconds * (1 - p.fraction) / p.fraction : -1;
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
         << format_count(rate) << (sampled_ ? " samples/s" : " cells/s") << "  elapsed "
         << format_seconds(p.elapsed_seconds);
    if (!final) line << "  ETA " << (eta >= 0 ? format_seconds(eta) : std::string("unknown"));
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

std::uint64_t parse_byte_size(const std::string& text, const std::string& option) {
    auto bad = [&] {
        return InputError(option + " '" + text +
                          "' is not a byte count; give a number with an optional suffix K, M, "
                          "G or T (powers of 1024), e.g. 8G");
    };
    std::size_t used = 0;
    double number = 0;
    try {
        number = std::stod(text, &used);
    } catch (const std::exception&) {
        throw bad();
    }
    std::string suffix = text.substr(used);
    for (char& c : suffix) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    if (suffix.size() > 1 && suffix.back() == 'B') suffix.pop_back();    // "GB"
    if (suffix.size() > 1 && suffix.back() == 'I') suffix.pop_back();    // "GiB"
    double scale = 1;
    if (suffix == "K") scale = 1024.0;
    else if (suffix == "M") scale = 1024.0 * 1024;
    else if (suffix == "G") scale = 1024.0 * 1024 * 1024;
    else if (suffix == "T") scale = 1024.0 * 1024 * 1024 * 1024;
    else if (!suffix.empty() && suffix != "B") throw bad();
    const double bytes = number * scale;
    if (!std::isfinite(bytes) || !(bytes > 0) || bytes >= 1.8e19) throw bad();
    return static_cast<std::uint64_t>(bytes);
}

std::string format_bytes(double bytes) {
    const char* units[] = {"B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"};
    int u = 0;
    while (bytes >= 1024 && u < 6) bytes /= 1024, ++u;
    char buf[48];
    std::snprintf(buf, sizeof buf, u ? "%.2f %s" : "%.0f %s", bytes, units[u]);
    return buf;
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

CLI::Validator number_in(double min, bool min_inclusive, double max, const std::string& allowed) {
    return CLI::Validator(
        [=](std::string& text) {
            double v = 0;
            try {
                v = parse_number(text, "value");
            } catch (const InputError&) {
                return "'" + text + "' is not a number; allowed: " + allowed;
            }
            const bool ok = (min_inclusive ? v >= min : v > min) && v <= max;
            return ok ? std::string() : text + " is out of range; allowed: " + allowed;
        },
        "NUMBER");
}

GenerateProgressFn TableProgress::callback() {
    return [this](const GenerateEvent& e) {
        if (quiet_) return;
        if (e.table_index != current_) {
            if (printer_) printer_->finish();
            current_ = e.table_index;
            printer_ = std::make_unique<ProgressPrinter>(
                "[" + prefix_ + std::to_string(e.table_index + 1) + "/" +
                    std::to_string(e.table_count) + "] " + e.table->name,
                !sampled || sampled(*e.table));
        }
        (*printer_)(e.progress);
    };
}

void TableProgress::finish() {
    if (printer_) printer_->finish();
    printer_.reset();
}

double available_memory() {
    std::ifstream in("/proc/meminfo");
    std::string key, unit;
    double kib = 0;
    while (in >> key >> kib) {
        std::getline(in, unit);
        if (key == "MemAvailable:") return kib * 1024;
    }
    return 0;
}

double free_disk_space(const std::string& path) {
    std::filesystem::path dir = std::filesystem::path(path).parent_path();
    if (dir.empty()) dir = ".";
    struct statvfs fs {};
    if (statvfs(dir.c_str(), &fs) != 0) return -1;
    return static_cast<double>(fs.f_bavail) * static_cast<double>(fs.f_frsize);
}

std::string sci_text(double v) {
    if (!std::isfinite(v)) return v > 0 ? "inf" : "nan";
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.3g", v);
    return buf;
}

std::pair<std::string, std::string> compared_text(double value, double target) {
    if (!std::isfinite(value) || !std::isfinite(target) || value == target)
        return {sci_text(value), sci_text(target)};
    for (int digits = 3;; ++digits) {
        const std::string a = number_text(value, digits), b = number_text(target, digits);
        if (a != b || digits >= 17) return {a, b};
    }
}

std::string certificate_error_text(const Certificate& c) {
    const auto [max_text, target_text] = compared_text(c.max_error, c.target);
    std::string s = std::string("max ") + (c.absolute ? "absolute" : "relative") + " total error " +
                    max_text + " at (";
    for (std::size_t a = 0; a < c.axis_names.size(); ++a)
        s += (a ? ", " : "") + c.axis_names[a] + " " + sci_text(c.max_at[a]);
    return s + "), RMS " + sci_text(c.rms_error) + "; target " + target_text;
}

bool table_is_sampled(const Spec& spec, const TableSpec& t, Method requested) {
    const Method m = resolve_table_method(find_model(spec.model).quantity(t.quantity), requested);
    return m == Method::MonteCarlo || m == Method::Rqmc;
}

}  // namespace brdftab::cli
