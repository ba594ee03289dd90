// brdftab — command-line front end.  Thin: parsing, printing and exit codes;
// all work is done by the library (host/).
//
// Exit codes: 0 success, 1 runtime failure (OpenCL, I/O), 2 bad input
// (arguments, spec, input files).
#include <CLI/CLI.hpp>

#include <algorithm>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "host/cli/cli_common.h"
#include "host/cli/commands.h"
#include "host/core/error.h"
#include "host/engine/opencl_runtime.h"
#include "host/io/table_io.h"

#ifndef BRDFTAB_VERSION
#define BRDFTAB_VERSION "unknown"
#endif

namespace {

// Levenshtein distance: how many single-character edits turn a into b.
std::size_t edit_distance(const std::string& a, const std::string& b) {
    std::vector<std::size_t> row(b.size() + 1);
    for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
    for (std::size_t i = 1; i <= a.size(); ++i) {
        std::size_t diagonal = row[0];
        row[0] = i;
        for (std::size_t j = 1; j <= b.size(); ++j) {
            const std::size_t above = row[j];
            row[j] = std::min({row[j] + 1, row[j - 1] + 1,
                               diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
            diagonal = above;
        }
    }
    return row[b.size()];
}

// The first argument names the subcommand (the top level has only flags):
// an unknown word is named, with the closest subcommand as a suggestion,
// rather than CLI11's "A subcommand is required".  Returns false after
// printing the message.
bool known_subcommand(CLI::App& app, int argc, char** argv) {
    if (argc < 2 || argv[1][0] == '-') return true;
    const std::string word = argv[1];
    std::vector<std::string> names;
    for (const CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; }))
        names.push_back(sub->get_name());
    if (std::find(names.begin(), names.end(), word) != names.end()) return true;
    if (word == "help") {  // what a newcomer types first
        std::cerr << "brdftab: error: there is no 'help' command; use `brdftab --help`, or "
                     "`brdftab COMMAND --help`\n";
        return false;
    }
    std::string best;
    std::size_t best_distance = 0;
    for (const auto& n : names) {
        const std::size_t d = edit_distance(word, n);
        if (best.empty() || d < best_distance) best = n, best_distance = d;
    }
    std::string all;
    for (const auto& n : names) all += (all.empty() ? "" : ", ") + n;
    std::cerr << "brdftab: error: unknown command '" << word << "'";
    // A suggestion only when it is plausibly a typo: at most half the word edited.
    if (!best.empty() && best_distance <= std::max<std::size_t>(2, word.size() / 2))
        std::cerr << "; did you mean '" << best << "'?";
    std::cerr << "\n  commands: " << all << "\n  (brdftab --help for details)\n";
    return false;
}

}  // namespace

int main(int argc, char** argv) {
    using namespace brdftab;
    // Before anything touches HDF5: a failed write then still exits cleanly
    // (host/io/table_io.h).
    disable_hdf5_exit_cleanup();
    CLI::App app{
        "brdftab " BRDFTAB_VERSION
        " — tabulate BRDF/BSDF models that have no closed form, with per-cell error "
        "estimates, on any OpenCL 1.2 device (default: the CPU through PoCL).\n\n"
        "Typical use:\n"
        "  brdftab models                                 what can be computed\n"
        "  brdftab eval rough-dielectric bsdf theta_i=30 theta_o=150 phi_d=180 alpha=0.3 eta=1.5\n"
        "  brdftab generate tables/rough-dielectric-albedo.toml -o albedo.h5\n"
        "  brdftab info albedo.h5\n"
        "  brdftab export albedo.h5 --table albedo_r --exr albedo_r.exr --slice eta=3\n"
        "  brdftab validate albedo.h5 --table albedo_r   how accurate is the table between nodes\n",
        "brdftab"};
    app.set_version_flag("--version", BRDFTAB_VERSION);
    app.require_subcommand(1);
    app.fallthrough();

    cli::register_devices(app);
    cli::register_models(app);
    cli::register_eval(app);
    cli::register_generate(app);
    cli::register_info(app);
    cli::register_export(app);
    cli::register_bench(app);
    cli::register_scene(app);
    cli::register_table_commands(app);
    cli::register_plan(app);
    cli::register_certify(app);

    if (!known_subcommand(app, argc, argv)) return 2;
    try {
        app.parse(argc, argv);
        return 0;
    } catch (const CLI::ParseError& e) {
        // --help / --version are "errors" with exit code 0.
        const int code = app.exit(e);
        return code == 0 ? 0 : 2;
    } catch (const InputError& e) {
        std::fflush(stdout);
        std::cerr << "brdftab: error: " << e.what() << "\n";
        return 2;
    } catch (const Error& e) {
        std::fflush(stdout);
        std::cerr << "brdftab: error: " << e.what() << "\n";
        return 1;
    } catch (const std::exception& e) {
        std::fflush(stdout);
        std::cerr << "brdftab: internal error: " << e.what() << "\n";
        return 1;
    }
}
