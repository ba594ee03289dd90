// renderer_layout.cpp — see renderer_layout.h.
#include "host/io/renderer_layout.h"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "host/core/atomic_file.h"
#include "host/core/error.h"
#include "host/io/half_float.h"

namespace brdftab {

namespace {

std::string axis_list(const TableData& t) {
    std::string s;
    for (const auto& a : t.axes) s += (s.empty() ? "" : ", ") + a.name;
    return "(" + s + ")";
}

// Cycles: (alpha), (mu_i|theta_i, alpha), (eta, alpha) or (eta, mu_i|theta_i, alpha).
void check_cycles(const TableData& t) {
    const auto& ax = t.axes;
    const auto bad = [&] {
        throw InputError("table '" + t.name + "' has axes " + axis_list(t) +
                         "; --layout cycles needs, outermost first, [eta,] [mu_i or theta_i,] "
                         "alpha (Cycles' index z nx ny + y nx + x: x = roughness, y = mu, "
                         "z = IOR)");
    };
    if (ax.empty() || ax.size() > 3 || ax.back().name != "alpha") bad();
    if (ax.size() == 2 && !(ax[0].name == "eta" || ax[0].name == "mu_i" || ax[0].name == "theta_i"))
        bad();
    if (ax.size() == 3 && !(ax[0].name == "eta" && (ax[1].name == "mu_i" || ax[1].name == "theta_i")))
        bad();
}

// Textures: two tables (three for Filament: its cloth channel) on one
// (alpha, mu_i) grid.
void check_texture(const std::vector<TableData>& ch, const char* layout, bool rgb) {
    if (ch.size() != 2 && !(rgb && ch.size() == 3))
        throw InputError(std::string("--layout ") + layout + " takes two tables, the texture's R and G channels: " +
                         (rgb ? "--table R,G (or three, --table R,G,B)" : "--table R,G"));
    for (const auto& t : ch)
        if (t.axes.size() != 2 || t.axes[0].name != "alpha" || t.axes[1].name != "mu_i")
            throw InputError("table '" + t.name + "' has axes " + axis_list(t) + "; --layout " +
                             layout + " needs (alpha, mu_i): rows of roughness, NoV fastest");
    for (std::size_t c = 1; c < ch.size(); ++c)
        for (std::size_t d = 0; d < 2; ++d)
            if (ch[0].axes[d].values != ch[c].axes[d].values)
                throw InputError("tables '" + ch[0].name + "' and '" + ch[c].name +
                                 "' differ in the nodes of axis '" + ch[0].axes[d].name +
                                 "'; the channels must share one grid");
}

}  // namespace

RendererLayout parse_renderer_layout(const std::string& name) {
    if (name == "cycles") return RendererLayout::Cycles;
    if (name == "filament") return RendererLayout::Filament;
    if (name == "ue4") return RendererLayout::Ue4;
    throw InputError("--layout '" + name + "': allowed: cycles, filament, ue4");
}

const char* renderer_layout_name(RendererLayout layout) {
    switch (layout) {
        case RendererLayout::Cycles: return "cycles";
        case RendererLayout::Filament: return "filament";
        case RendererLayout::Ue4: return "ue4";
    }
    return "?";
}

unsigned renderer_unorm16(double v) {
    const double c = v > 0 ? (v < 1 ? v : 1.0) : 0.0;  // NaN -> 0 (the export refuses NaN)
    return unsigned(std::floor(c * 65535.0 + 0.5));
}

std::vector<double> renderer_layout_values(const std::vector<TableData>& channels,
                                           const RendererExportOptions& o) {
    if (o.layout == RendererLayout::Cycles) {
        if (channels.size() != 1)
            throw InputError("--layout cycles takes one table (--table T)");
        check_cycles(channels[0]);
        return channels[0].value;  // row-major = Cycles' order
    }
    check_texture(channels, renderer_layout_name(o.layout), o.layout == RendererLayout::Filament);
    std::vector<double> out;
    out.reserve(channels.size() * channels[0].value.size());
    for (std::size_t k = 0; k < channels[0].value.size(); ++k)
        for (const TableData& c : channels) out.push_back(c.value[k]);
    return out;
}

void export_renderer_header(const std::vector<TableData>& channels, const std::string& out_path,
                            const RendererExportOptions& o) {
    HeaderValueType type = o.layout == RendererLayout::Filament ? HeaderValueType::Half
                           : o.layout == RendererLayout::Ue4    ? HeaderValueType::Uint16
                                                                : HeaderValueType::Float;
    if (o.type_given) type = o.type;
    if ((o.layout == RendererLayout::Cycles && type != HeaderValueType::Float) ||
        (o.layout == RendererLayout::Filament && type == HeaderValueType::Uint16))
        throw InputError(std::string("--type: --layout ") + renderer_layout_name(o.layout) +
                         " stores " +
                         (o.layout == RendererLayout::Cycles ? "float only" : "half or float"));
    const std::vector<double> v = renderer_layout_values(channels, o);
    for (std::size_t k = 0; k < v.size(); ++k)
        if (!std::isfinite(v[k]) || (type == HeaderValueType::Half && std::fabs(v[k]) > 65504.0))
            throw InputError("element " + std::to_string(k) + " (" + std::to_string(v[k]) +
                             ") cannot be stored as " +
                             (type == HeaderValueType::Half     ? "half"
                              : type == HeaderValueType::Uint16 ? "16-bit unorm"
                                                                : "float"));
    std::string name = o.name;
    if (name.empty())
        name = o.layout == RendererLayout::Cycles     ? "table_" + channels[0].name
               : o.layout == RendererLayout::Filament ? std::string("DFG_LUT")
                                                      : std::string("ue4_split_sum_lut");
    if (!is_c_identifier(name))
        throw InputError("--name '" + name + "' is not a C identifier");

    std::ostringstream h;
    h << "/* Generated by brdftab export --layout " << renderer_layout_name(o.layout);
    if (!o.source.empty()) h << " from " << o.source;
    h << ".\n";
    for (const auto& t : channels) {
        h << " * table '" << t.name << "' (" << t.quantity << "), axes";
        for (const auto& a : t.axes) h << " " << a.name << "[" << a.count << "]";
        h << "\n";
    }
    if (o.layout == RendererLayout::Cycles) {
        h << " * Cycles order: index z nx ny + y nx + x, x = roughness, y = mu, z = IOR. */\n";
        h << "static const float " << name << "[" << v.size() << "] = {\n";
        const std::size_t nx = channels[0].axes.back().count;
        for (std::size_t k = 0; k < v.size(); ++k) {
            if (k % nx == 0) h << "  ";
            h << c_float_literal(static_cast<float>(v[k])) << (k + 1 < v.size() ? "," : "");
            h << ((k + 1) % nx == 0 || k + 1 == v.size() ? "\n" : " ");
        }
        h << "};\n";
    } else {
        const std::size_t width = channels[0].axes[1].count, height = channels[0].axes[0].count;
        h << " * " << width << " x " << height << " texels, " << channels.size() << " channels (R = table '"
          << channels[0].name << "', G = table '" << channels[1].name << "'";
        if (channels.size() > 2) h << ", B = table '" << channels[2].name << "'";
        h << ") interleaved; row r = alpha node r (GL order, first row first), NoV fastest. */\n";
        h << "#define " << name << "_WIDTH " << width << "\n#define " << name << "_HEIGHT "
          << height << "\n";
        if (type == HeaderValueType::Uint16) {
            // UE4's PF_G16R16: two 16-bit unorm channels per texel.
            std::size_t clamped = 0;
            for (double x : v) clamped += x < 0 || x > 1;
            h << "#include <stdint.h>\n/* 16-bit unsigned normalised (UNORM): q = round(65535 "
                 "clamp(v, 0, 1)), read as q / 65535; "
              << clamped << " elements outside [0, 1] clamped */\nstatic const uint16_t " << name << "["
              << v.size() << "] = {";
            char buf[16];
            for (std::size_t k = 0; k < v.size(); ++k) {
                if (k % 8 == 0) h << "\n   ";
                std::snprintf(buf, sizeof buf, " %u", renderer_unorm16(v[k]));
                h << buf << (k + 1 < v.size() ? "," : "");
            }
            h << "\n};\n";
        } else if (type == HeaderValueType::Half) {
            h << "#include <stdint.h>\n/* IEEE binary16 bits */\nconst uint16_t " << name << "[] = {";
            char buf[16];
            for (std::size_t k = 0; k < v.size(); ++k) {
                if (k % 8 == 0) h << "\n   ";
                std::snprintf(buf, sizeof buf, " 0x%04x,", unsigned(half_bits(v[k])));
                h << buf;
            }
            h << "\n};\n";
        } else {
            h << "static const float " << name << "[" << v.size() << "] = {";
            for (std::size_t k = 0; k < v.size(); ++k) {
                if (k % 8 == 0) h << "\n   ";
                h << " " << c_float_literal(static_cast<float>(v[k])) << (k + 1 < v.size() ? "," : "");
            }
            h << "\n};\n";
        }
    }
    write_text_atomically(out_path, h.str());
}

}  // namespace brdftab
