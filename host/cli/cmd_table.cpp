// query, validate, plot: commands over the renderer-side lookup library.
#include "commands.h"

namespace brdftab::cli {

void register_table_commands(CLI::App& app) { (void)app; }

}  // namespace brdftab::cli
