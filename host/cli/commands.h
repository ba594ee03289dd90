// commands.h — one register_* function per subcommand group.
#pragma once

#include <CLI/CLI.hpp>

namespace brdftab::cli {

void register_devices(CLI::App& app);
void register_models(CLI::App& app);
void register_eval(CLI::App& app);
void register_generate(CLI::App& app);
void register_info(CLI::App& app);
void register_export(CLI::App& app);
void register_bench(CLI::App& app);
// scene files -> the tables their materials need (host/scene)
void register_scene(CLI::App& app);
// query / validate / plot (renderer-side library, issue 7)
void register_table_commands(CLI::App& app);
void register_plan(CLI::App& app);  // plan (issue 13)
void register_certify(CLI::App& app);  // certify an existing table (issue 13)

}  // namespace brdftab::cli
