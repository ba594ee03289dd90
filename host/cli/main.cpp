// brdftab — command-line front end.  Thin: parsing, printing and exit codes;
// all work is done by the library (host/).
//
// Exit codes: 0 success, 1 runtime failure (OpenCL, I/O), 2 bad input
// (arguments, spec, input files).
#include <CLI/CLI.hpp>

#include <cstdio>
#include <iostream>

#include "host/cli/cli_common.h"
#include "host/cli/commands.h"
#include "host/core/error.h"
#include "host/engine/opencl_runtime.h"

#ifndef BRDFTAB_VERSION
#define BRDFTAB_VERSION "unknown"
#endif

int main(int argc, char** argv) {
    using namespace brdftab;
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
    cli::register_table_commands(app);
    cli::register_plan(app);

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
