// export (bench: cmd_bench.cpp).
#include <iostream>
#include <memory>

#include "host/cli/cli_common.h"
#include "host/cli/commands.h"
#include "host/cli/read_guard.h"
#include "host/core/error.h"
#include "host/io/exr_export.h"
#include "host/io/table_io.h"

namespace brdftab::cli {

void register_export(CLI::App& app) {
    auto* cmd = app.add_subcommand(
        "export", "write a 2-D slice of a table as an OpenEXR image (R = value, G = stderr)");
    struct State {
        std::string file, table, exr;
        std::vector<std::string> slice;
        bool half = false;
    };
    auto state = std::make_shared<State>();  // owned by the callback
    cmd->add_option("FILE", state->file, "brdftab HDF5 file")->required();
    cmd->add_option("--table", state->table, "table name (see `brdftab info FILE`)")->required();
    cmd->add_option("--exr", state->exr, "output .exr path")->required()->check(non_empty_path());
    cmd->add_option("--slice", state->slice,
                    "name=value for every axis except two (values must be grid nodes)");
    cmd->add_flag("--half", state->half, "store 16-bit half channels instead of 32-bit float");
    cmd->callback([state] {
        const State& st = *state;
        guard_table_file(st.file);
        TableData t = read_table(st.file, st.table);
        ExrExportOptions o;
        o.half = st.half;
        for (const auto& s : st.slice) {
            auto [name, text] = split_assignment(s);
            o.slice[name] = parse_number(text, "--slice " + name);
        }
        export_exr_slice(t, st.exr, o);
        std::cout << "wrote " << st.exr << "\n";
    });
}

}  // namespace brdftab::cli
