// export: one table into a format other tools read — an OpenEXR image (or a
// multi-part EXR of slices), a C99 header, or a MERL binary BRDF.
#include <filesystem>
#include <iostream>
#include <memory>

#include "host/cli/cli_common.h"
#include "host/cli/commands.h"
#include "host/cli/read_guard.h"
#include "host/core/atomic_file.h"
#include "host/core/error.h"
#include "host/io/exr_export.h"
#include "host/io/header_export.h"
#include "host/io/merl_export.h"
#include "host/io/table_io.h"
#include "host/lookup/lookup.h"

namespace brdftab::cli {

namespace {

struct ExportArgs {
    std::string file, table;
    std::string exr, header, merl;  // exactly one
    std::vector<std::string> slice;
    // EXR
    bool half = false, layers = false, no_stderr = false;
    std::string axes;
    // header
    std::string name, type;
    // MERL
    std::string rgb;
};

// "a,b" -> {a, b}; "r,g,b" numbers.
std::vector<std::string> split_commas(const std::string& s) {
    std::vector<std::string> out;
    std::size_t start = 0;
    while (true) {
        const std::size_t c = s.find(',', start);
        out.push_back(s.substr(start, c == std::string::npos ? std::string::npos : c - start));
        if (c == std::string::npos) break;
        start = c + 1;
    }
    return out;
}

void refuse_unless(bool applies, bool given, const std::string& option, const std::string& format) {
    if (given && !applies)
        throw InputError(option + " applies to " + format + " only");
}

void run_export(const ExportArgs& a) {
    const int outputs = int(!a.exr.empty()) + int(!a.header.empty()) + int(!a.merl.empty());
    if (outputs != 1)
        throw InputError("give exactly one output: --exr FILE.exr, --header FILE.h or "
                         "--merl FILE.binary");
    const bool exr = !a.exr.empty(), header = !a.header.empty(), merl = !a.merl.empty();
    refuse_unless(exr, a.half, "--half", "--exr");
    refuse_unless(exr, a.layers, "--layers", "--exr");
    refuse_unless(exr, a.no_stderr, "--no-stderr", "--exr");
    refuse_unless(exr, !a.axes.empty(), "--axes", "--exr");
    refuse_unless(header, !a.name.empty(), "--name", "--header");
    refuse_unless(header, !a.type.empty(), "--type", "--header");
    refuse_unless(merl, !a.rgb.empty(), "--rgb", "--merl");
    refuse_unless(!header, !a.slice.empty(), "--slice", "--exr and --merl");
    std::map<std::string, double> slice;
    for (const auto& s : a.slice) {
        auto [name, text] = split_assignment(s);
        if (!slice.emplace(name, parse_number(text, "--slice " + name)).second)
            throw InputError("--slice " + name + " is given twice");
    }
    const std::string out = exr ? a.exr : header ? a.header : a.merl;
    check_output_writable(out);
    const OutputLock lock(out);  // one writer of the output (docs/spec.md)
    guard_table_file(a.file);

    if (exr) {
        ExrExportOptions o;
        o.half = a.half;
        o.layers = a.layers;
        o.with_stderr = !a.no_stderr;
        o.slice = slice;
        if (!a.axes.empty()) {
            const auto xy = split_commas(a.axes);
            if (xy.size() != 2 || xy[0].empty() || xy[1].empty())
                throw InputError("--axes '" + a.axes + "': expected two axis names, X,Y");
            o.x_axis = xy[0];
            o.y_axis = xy[1];
        }
        export_exr_slice(read_table(a.file, a.table), a.exr, o);
    } else if (header) {
        HeaderExportOptions o;
        o.name = a.name;
        if (!a.type.empty()) o.type = parse_header_value_type(a.type);
        o.source = std::filesystem::path(a.file).filename().string();
        // Through the lookup library, so a reciprocal-half table is completed
        // exactly as `query` sees it.
        const LookupTable lt = LookupTable::open(a.file, a.table);
        export_c_header(lt.table(), a.header, o);
    } else {
        MerlExportOptions o;
        o.parameters = slice;
        if (!a.rgb.empty()) {
            const auto parts = split_commas(a.rgb);
            if (parts.size() != 3)
                throw InputError("--rgb '" + a.rgb + "': expected three numbers, R,G,B");
            o.rgb = true;
            for (int c = 0; c < 3; ++c) o.rgb_values[c] = parse_number(parts[c], "--rgb");
        }
        const LookupTable lt = LookupTable::open(a.file, a.table);
        const MerlExportReport r = export_merl(lt, a.merl, o);
        for (const auto& note : r.notes) std::cerr << "brdftab: note: " << note << "\n";
    }
    std::cout << "wrote " << out << "\n";
}

}  // namespace

void register_export(CLI::App& app) {
    auto* cmd = app.add_subcommand(
        "export",
        "write a table for other tools: a 2-D slice (or a stack of slices) as an OpenEXR image "
        "(R = value, G = stderr), a C99 header with a lookup function, or a MERL binary BRDF");
    auto a = std::make_shared<ExportArgs>();  // owned by the callback
    cmd->add_option("FILE", a->file, "brdftab HDF5 file")->required();
    cmd->add_option("--table", a->table, "table name (see `brdftab info FILE`)")->required();
    cmd->add_option("--exr", a->exr, "output .exr path")->check(non_empty_path());
    cmd->add_option("--header", a->header, "output C header path (.h)")->check(non_empty_path());
    cmd->add_option("--merl", a->merl, "output MERL .binary path (isotropic BRDF tables)")
        ->check(non_empty_path());
    cmd->add_option("--slice", a->slice,
                    "name=value: with --exr, fix every axis except two (three with --layers) "
                    "at a grid node; with --merl, the value of every non-angle coordinate "
                    "(interpolated)");
    cmd->add_flag("--half", a->half, "EXR: 16-bit half channels instead of 32-bit float");
    cmd->add_flag("--layers", a->layers,
                  "EXR: three free axes; one image part per node of the axis not on x or y, "
                  "named axis=value (a multi-part EXR)");
    cmd->add_option("--axes", a->axes,
                    "EXR: X,Y — the free axes that become image x and y (default: the later "
                    "free axis on x, the earlier on y)");
    cmd->add_flag("--no-stderr", a->no_stderr, "EXR: G = 0 instead of the standard error");
    cmd->add_option("--name", a->name,
                    "header: prefix of its identifiers (a C identifier; default: the table name)");
    cmd->add_option("--type", a->type,
                    "header: value storage, float (default), half or uint16 (see docs/format.md "
                    "for each one's error)");
    cmd->add_option("--rgb", a->rgb,
                    "MERL: R,G,B values of a factored table's parameter (e.g. rho) for the red, "
                    "green and blue channels (default: the same value in all three)");
    cmd->callback([a] { run_export(*a); });
}

}  // namespace brdftab::cli
