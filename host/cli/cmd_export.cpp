// export: one table into a format other tools read — an OpenEXR image (or a
// multi-part EXR of slices), a C99 header, or a MERL binary BRDF.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <iostream>
#include <memory>

#include "host/cli/cli_common.h"
#include "host/cli/commands.h"
#include "host/cli/plot_png.h"
#include "host/cli/read_guard.h"
#include "host/core/atomic_file.h"
#include "host/core/error.h"
#include "host/core/text.h"
#include "host/adaptive/adaptive_io.h"
#include "host/io/adaptive_resample.h"
#include "host/io/exr_export.h"
#include "host/io/header_export.h"
#include "host/io/merl_export.h"
#include "host/io/renderer_layout.h"
#include "host/io/rgl_export.h"
#include "host/io/table_io.h"
#include "host/lookup/lookup.h"

#ifndef BRDFTAB_VERSION
#define BRDFTAB_VERSION "unknown"
#endif

namespace brdftab::cli {

namespace {

struct ExportArgs {
    std::string file, table;
    std::string exr, header, merl, png;  // exactly one
    std::vector<std::string> slice;
    // EXR
    bool half = false, layers = false, no_stderr = false;
    std::string axes;
    // header
    std::string name, type, layout;
    // MERL and RGL
    std::string rgb;
    // EXR, PNG, MERL of an adaptive table: the tensor grid (N or NAME=N)
    std::vector<std::string> resample;
    // RGL
    std::string rgl;
    int rgl_res = 0, rgl_theta_i = 0, rgl_phi_i = 0, rgl_ndf_res = 64;
    bool spectral = false;
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

// `export --png`: the image slice as a 16-bit greyscale PNG of the value,
// q = round((value - offset) / scale) with offset 0 and scale 1/65535 when
// every value lies in [0, 1] (value = q / 65535, as renderers read a 16-bit
// LUT), else offset = min and scale = (max - min) / 65535.  The mapping,
// axes and slice go into tEXt chunks and are printed.
void export_png(const TableData& table, const std::string& path, const ExrExportOptions& o) {
    const ImageSlice slice = image_slice(table, o);
    for (const std::string& note : slice.notes) std::cerr << "brdftab: note: " << note << "\n";
    const std::vector<double>& v = slice.layers.front().value;
    double lo = v.front(), hi = v.front();
    for (double x : v) {
        if (!std::isfinite(x)) throw InputError("PNG export of table '" + table.name + "': a value is NaN or infinite");
        lo = std::min(lo, x);
        hi = std::max(hi, x);
    }
    const bool unit_range = lo >= 0 && hi <= 1;
    const double offset = unit_range ? 0 : lo, scale = unit_range ? 1.0 / 65535 : (hi > lo ? (hi - lo) / 65535 : 1);
    std::vector<std::uint16_t> q(v.size());
    for (std::size_t i = 0; i < v.size(); ++i)
        q[i] = static_cast<std::uint16_t>(std::min(65535.0, std::max(0.0, std::nearbyint((v[i] - offset) / scale))));
    const std::vector<Axis>& axes = table.axes;
    auto label = [](const Axis& a) {
        return a.name + " [" + number_text(a.min, 6) + ", " + number_text(a.max, 6) + "]" + unit_suffix(a.unit) +
               ", " + std::to_string(a.count) + " nodes, " + spacing_name(a.spacing);
    };
    const std::string mapping = "value = " + number_text(offset, 17) + " + " + number_text(scale, 17) + " * q";
    write_png_gray16(path, slice.width, slice.height, q,
                     {{"Software", std::string("brdftab ") + BRDFTAB_VERSION},
                      {"brdftab_table", table.name},
                      {"brdftab_model", table.model},
                      {"brdftab_quantity", table.quantity},
                      {"brdftab_units", table.units},
                      {"brdftab_x_axis", label(axes[slice.x_axis])},
                      {"brdftab_y_axis", label(axes[slice.y_axis]) + " (row 0 = first node)"},
                      {"brdftab_slice", slice.layers.front().slice.empty() ? "none" : slice.layers.front().slice},
                      {"brdftab_mapping", mapping}});
    std::cout << "PNG 16-bit grey " << slice.width << " x " << slice.height << " (x " << axes[slice.x_axis].name
              << ", y " << axes[slice.y_axis].name << "), " << mapping << ", rounding error <= "
              << number_text(scale / 2, 3) << "\n";
}

std::array<double, 3> parse_rgb(const std::string& text) {
    const auto parts = split_commas(text);
    if (parts.size() != 3) throw InputError("--rgb '" + text + "': expected three numbers, R,G,B");
    std::array<double, 3> v{};
    for (int c = 0; c < 3; ++c) v[c] = parse_number(parts[c], "--rgb");
    return v;
}

// The table to export as a tensor table: read as it is, or an adaptive table
// (docs/adaptive.md) resampled onto a tensor grid (--resample; the grid and
// the measured resampling error are printed).
TableData tensor_table(const ExportArgs& a, const std::string& name) {
    if (!is_adaptive_table(a.file, name)) {
        if (!a.resample.empty())
            throw InputError("--resample applies to adaptive tables only; table '" + name + "' of '" + a.file +
                             "' is a tensor table");
        return read_table(a.file, name);
    }
    ResampleOptions o;
    for (const std::string& r : a.resample) {
        const bool named = r.find('=') != std::string::npos;
        const auto [axis, text] = named ? split_assignment(r) : std::pair<std::string, std::string>{"", r};
        const double n = parse_number(text, "--resample " + r);
        if (!(n >= 2 && n <= 1e6 && n == std::floor(n)))
            throw InputError("--resample " + r + ": nodes per axis must be a whole number in [2, 1000000]");
        if (named) {
            if (!o.axis_nodes.emplace(axis, std::size_t(n)).second)
                throw InputError("--resample " + axis + " is given twice");
        } else {
            if (o.nodes) throw InputError("--resample N is given twice");
            o.nodes = std::size_t(n);
        }
    }
    const AdaptiveTable t = read_adaptive_table(a.file, name);
    ResampleReport rep;
    TableData out = resample_adaptive(t, o, rep);
    std::string grid, worst;
    for (std::size_t k = 0; k < out.axes.size(); ++k) {
        grid += (k ? " x " : "") + out.axes[k].name + "(" + std::to_string(rep.counts[k]) + ")";
        worst += (k ? " " : "") + out.axes[k].name + "=" + number_text(rep.worst[k], 6);
    }
    std::cout << "adaptive table '" << name << "' resampled onto a tensor grid " << grid << " ("
              << out.value.size() << " values, each axis' own spacing; --resample sets it)\n"
              << "resampling error: max abs " << number_text(rep.max_abs, 3) << " [" << out.units << "] at "
              << worst << " (max |value| " << number_text(rep.max_abs_value, 3) << "), over " << rep.probes
              << (rep.probes_at_centres ? " cell centres" : " random points") << " between the resampled nodes\n";
    return out;
}

// `export --rgl`: the RGL tensor file (host/io/rgl_export.h); prints the
// grid, the distribution used and the measured resampling error.
void export_rgl_file(const ExportArgs& a, const std::map<std::string, double>& slice) {
    RglExportOptions o;
    o.parameters = slice;
    if (!a.rgb.empty()) {
        o.rgb = true;
        o.rgb_values = parse_rgb(a.rgb);
    }
    o.spectral = a.spectral;
    o.resolution = a.rgl_res;
    o.theta_i_count = a.rgl_theta_i;
    o.phi_i_count = a.rgl_phi_i;
    o.ndf_resolution = a.rgl_ndf_res;
    o.source = std::filesystem::path(a.file).filename().string();
    const LookupTable lt = LookupTable::open(a.file, a.table);
    if (lt.is_adaptive())
        throw InputError(a.file + ": table '" + a.table + "' is adaptive (docs/adaptive.md): --rgl reads tensor "
                         "tables (generate this one with --representation tensor)");
    const RglExportReport r = export_rgl(lt, a.rgl, o);
    for (const auto& note : r.notes) std::cerr << "brdftab: note: " << note << "\n";
    std::cout << "RGL " << (a.spectral ? "spectral" : "RGB") << " file: " << r.theta_i_nodes << " theta_i x "
              << r.phi_i_nodes << " phi_i slices" << (r.reduction > 1 ? " (azimuth symmetry 360/" +
                                                                              std::to_string(r.reduction) + ")"
                                                                        : std::string())
              << ", " << r.resolution << " x " << r.resolution << " samples each; microfacet distribution: "
              << r.distribution << "\n"
              << "resampling error against the table (relative, " << r.error.pairs
              << " random direction pairs, theta_i <= " << number_text(r.error.theta_i_max_deg, 6)
              << ", theta_o <= " << number_text(r.error.theta_o_max_deg, 6) << " deg): median "
              << number_text(r.error.median, 3) << ", p99 " << number_text(r.error.p99, 3) << ", max "
              << number_text(r.error.max, 3) << "\n";
}

void run_export(const ExportArgs& a) {
    const int outputs = int(!a.exr.empty()) + int(!a.header.empty()) + int(!a.merl.empty()) +
                        int(!a.png.empty()) + int(!a.rgl.empty());
    if (outputs != 1)
        throw InputError("give exactly one output: --exr FILE.exr, --png FILE.png, --header FILE.h, "
                         "--merl FILE.binary or --rgl FILE.bsdf");
    const bool exr = !a.exr.empty(), header = !a.header.empty(), merl = !a.merl.empty(), png = !a.png.empty();
    const bool rgl = !a.rgl.empty();
    refuse_unless(rgl, a.spectral, "--spectral", "--rgl");
    refuse_unless(exr, a.half, "--half", "--exr");
    refuse_unless(exr, a.layers, "--layers", "--exr");
    refuse_unless(exr, a.no_stderr, "--no-stderr", "--exr");
    refuse_unless(exr || png, !a.axes.empty(), "--axes", "--exr and --png");
    refuse_unless(header, !a.name.empty(), "--name", "--header");
    refuse_unless(header, !a.type.empty(), "--type", "--header");
    refuse_unless(header, !a.layout.empty(), "--layout", "--header");
    refuse_unless(merl || rgl, !a.rgb.empty(), "--rgb", "--merl and --rgl");
    refuse_unless(exr || png || merl, !a.resample.empty(), "--resample", "--exr, --png and --merl");
    refuse_unless(!header, !a.slice.empty(), "--slice", "--exr, --png, --merl and --rgl");
    std::map<std::string, double> slice;
    for (const auto& s : a.slice) {
        auto [name, text] = split_assignment(s);
        if (!slice.emplace(name, parse_number(text, "--slice " + name)).second)
            throw InputError("--slice " + name + " is given twice");
    }
    const std::string out = exr ? a.exr : header ? a.header : png ? a.png : rgl ? a.rgl : a.merl;
    check_output_writable(out);
    const OutputLock lock(out);  // one writer of the output (docs/spec.md)
    guard_table_file(a.file);

    if (rgl) {
        export_rgl_file(a, slice);
    } else if (exr || png) {
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
        if (png) {
            export_png(tensor_table(a, a.table), a.png, o);
        } else {
            // --table R,G: a two-channel texture (G = the second table's values).
            const auto names = split_commas(a.table);
            if (names.size() > 2)
                throw InputError("--table '" + a.table + "': --exr takes one table, or two (R,G)");
            const TableData red = tensor_table(a, names[0]);
            TableData green;
            if (names.size() == 2) {
                green = tensor_table(a, names[1]);
                o.green = &green;
            }
            for (const std::string& note : export_exr_slice(red, a.exr, o))
                std::cerr << "brdftab: note: " << note << "\n";
        }
    } else if (header && !a.layout.empty()) {
        // A renderer's own array (host/io/renderer_layout.h); --table R,G
        // names a two-channel texture's tables.
        RendererExportOptions o;
        o.layout = parse_renderer_layout(a.layout);
        o.name = a.name;
        o.type_given = !a.type.empty();
        if (o.type_given) o.type = parse_header_value_type(a.type);
        o.source = std::filesystem::path(a.file).filename().string();
        std::vector<TableData> channels;
        for (const auto& t : split_commas(a.table)) {
            const LookupTable lt = LookupTable::open(a.file, t);
            if (lt.is_adaptive())
                throw InputError(a.file + ": table '" + t + "' is adaptive (docs/adaptive.md): --layout "
                                 "writes tensor arrays; export it with --header alone (a tree traversal)");
            channels.push_back(lt.table());
        }
        export_renderer_header(channels, a.header, o);
    } else if (header) {
        HeaderExportOptions o;
        o.name = a.name;
        if (!a.type.empty()) o.type = parse_header_value_type(a.type);
        o.source = std::filesystem::path(a.file).filename().string();
        o.certificate = read_stored_certificate(a.file, a.table);
        // Through the lookup library, so a reciprocal-half table is completed
        // exactly as `query` sees it.
        const LookupTable lt = LookupTable::open(a.file, a.table);
        if (lt.is_adaptive())
            export_c_header(*lt.adaptive(), a.header, o);  // the tree traversal
        else
            export_c_header(lt.table(), a.header, o);
    } else {
        MerlExportOptions o;
        o.parameters = slice;
        if (!a.rgb.empty()) {
            o.rgb = true;
            o.rgb_values = parse_rgb(a.rgb);
        }
        const LookupTable lt = is_adaptive_table(a.file, a.table) ? LookupTable(tensor_table(a, a.table))
                                                                    : LookupTable::open(a.file, a.table);
        // The same slice rule as --exr and plot: say which values are
        // interpolated between nodes.
        for (const Axis& ax : lt.axes()) {
            const auto it = slice.find(ax.name);
            if (it == slice.end() || ax.dependent()) continue;
            try {
                const std::string note = slice_note(ax, it->second, axis_position(ax, it->second));
                if (!note.empty()) std::cerr << "brdftab: note: " << note << "\n";
            } catch (const InputError&) {
                // Outside the axis: export_merl's own message follows.
            }
        }
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
        "(R = value, G = stderr), a C99 header with a lookup function, a MERL binary BRDF, or an "
        "RGL .bsdf file (Mitsuba 3's and pbrt-v4's `measured`)");
    auto a = std::make_shared<ExportArgs>();  // owned by the callback
    cmd->add_option("FILE", a->file, "brdftab HDF5 file")->required();
    cmd->add_option("--table", a->table, "table name (see `brdftab info FILE`)")->required();
    cmd->add_option("--exr", a->exr, "output .exr path")->check(non_empty_path());
    cmd->add_option("--header", a->header, "output C header path (.h)")->check(non_empty_path());
    cmd->add_option("--merl", a->merl, "output MERL .binary path (isotropic BRDF tables)")
        ->check(non_empty_path());
    cmd->add_option("--rgl", a->rgl,
                    "output RGL tensor file (.bsdf) of a reflection table, the format of Dupuy & Jakob "
                    "2018 that Mitsuba 3's and pbrt-v4's `measured` BSDF read (docs/format.md); prints "
                    "the resampling error")
        ->check(non_empty_path());
    cmd->add_flag("--spectral", a->spectral,
                  "RGL: a flat spectrum (`spectra`, `wavelengths`: pbrt-v4, Mitsuba's spectral "
                  "variants) instead of `rgb` (Mitsuba's RGB variants)");
    cmd->add_option("--rgl-res", a->rgl_res,
                    "RGL: samples per side of each slice's grid (default 0: 96 for isotropic tables, 64 "
                    "for anisotropic ones)")
        ->check(CLI::Range(0, 512));
    cmd->add_option("--rgl-theta-i", a->rgl_theta_i,
                    "RGL: incidence slices evenly spaced in theta (default 0: the table's own theta_i "
                    "nodes, each interval split into steps of at most 2.5 degrees)")
        ->check(CLI::Range(0, 1024));
    cmd->add_option("--rgl-phi-i", a->rgl_phi_i,
                    "RGL, anisotropic tables: incidence azimuth slices (default 0: the table's count, "
                    "each interval split into steps of at most 3.75 degrees)")
        ->check(CLI::Range(0, 1024));
    cmd->add_option("--rgl-ndf-res", a->rgl_ndf_res,
                    "RGL: nodes per side of the microfacet-distribution grid (default 64)")
        ->check(CLI::Range(2, 1024));
    cmd->add_option("--png", a->png,
                    "output .png path: a 2-D slice as a 16-bit greyscale PNG of the value (q / 65535 "
                    "when every value is in [0, 1], else min + (max - min) q / 65535; the mapping is "
                    "printed and stored in a tEXt chunk)")
        ->check(non_empty_path());
    cmd->add_option("--slice", a->slice,
                    "name=value: with --exr and --png, fix every axis except two (three with "
                    "--layers); with --merl, the value of every non-angle coordinate.  A value "
                    "between nodes is interpolated linearly (a note says so), as in plot");
    cmd->add_flag("--half", a->half, "EXR: 16-bit half channels instead of 32-bit float");
    cmd->add_flag("--layers", a->layers,
                  "EXR: three free axes; one image part per node of the axis not on x or y, "
                  "named axis=value (a multi-part EXR)");
    cmd->add_option("--axes", a->axes,
                    "EXR, PNG: X,Y — the free axes that become image x and y (default: the later "
                    "free axis on x, the earlier on y)");
    cmd->add_flag("--no-stderr", a->no_stderr, "EXR: G = 0 instead of the standard error");
    cmd->add_option("--name", a->name,
                    "header: prefix of its identifiers (a C identifier; default: the table name)");
    cmd->add_option("--type", a->type,
                    "header: value storage, float (default), half or uint16 (see docs/format.md "
                    "for each one's error)");
    cmd->add_option("--layout", a->layout,
                    "header: a renderer's own array, order and type (docs/renderer-luts.md): "
                    "cycles (one table, float), filament or ue4 (--table R,G: a two-channel "
                    "texture, filament also R,G,B with its cloth channel: half or float; ue4: "
                    "uint16 = 16-bit unorm as UE4 stores it, float or half)");
    cmd->add_option("--rgb", a->rgb,
                    "MERL, RGL: R,G,B values of a factored table's parameter (e.g. rho) for the red, "
                    "green and blue channels (default: the same value in all three)");
    cmd->add_option("--resample", a->resample,
                    "EXR, PNG, MERL of an adaptive table: N (nodes per axis) or NAME=N (one axis; "
                    "repeatable) of the tensor grid it is resampled onto (default 65 per axis, fewer "
                    "above 3 axes so that the grid holds at most 2^22 values); the resampling error "
                    "is measured and printed");
    cmd->callback([a] { run_export(*a); });
}

}  // namespace brdftab::cli
