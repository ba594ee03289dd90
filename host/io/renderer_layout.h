// renderer_layout.h — tables written as the C arrays renderers ship, in each
// renderer's own element order and type (`brdftab export --layout`,
// docs/renderer-luts.md):
//   cycles    one table, `static const float table_<name>[N]`, index
//             z nx ny + y nx + x with x = roughness, y = mu, z = IOR: the
//             table's axes must be (eta,) (mu_i | theta_i,) alpha, outermost
//             first, so the file's row-major order is Cycles' order.
//   filament  two or three tables (the texture's R, G and B, the cloth
//             channel) on the same 2-D grid (alpha outer, mu_i inner):
//             `const uint16_t DFG_LUT[]`, binary16 bits, channels interleaved
//             per texel, rows in GL order (first row = first alpha node),
//             NoV fastest.
//   ue4       the same two-channel grid: R = scale A, G = bias B of the
//             split sum, as UE4's PreintegratedGF texture stores them
//             (PF_G16R16, SystemTextures.cpp): 16-bit unsigned normalised,
//             `static const uint16_t`, q = round(65535 clamp(v, 0, 1)), read
//             as q / 65535 (type = uint16, the default), or `float`, or
//             binary16 (type = half).
// Library code: no printing.
#pragma once

#include <string>
#include <vector>

#include "host/core/table.h"
#include "host/io/header_export.h"

namespace brdftab {

enum class RendererLayout { Cycles, Filament, Ue4 };

// "cycles" | "filament" | "ue4"; InputError otherwise.
RendererLayout parse_renderer_layout(const std::string& name);
const char* renderer_layout_name(RendererLayout layout);

struct RendererExportOptions {
    RendererLayout layout = RendererLayout::Cycles;
    // Storage: cycles: float only; filament: half (default) or float;
    // ue4: uint16 (16-bit unorm, the default), float or half.  `type_given`
    // false takes the default.
    HeaderValueType type = HeaderValueType::Float;
    bool type_given = false;
    std::string name;    // array identifier; empty: the layout's default
    std::string source;  // e.g. the input file name, written in the comment
};

// 16-bit unsigned normalised storage of v (UNORM16, UE4's G16R16):
// round(65535 clamp(v, 0, 1)), ties upwards; it reads back as q / 65535,
// within 0.5/65535 = 7.6e-6 of clamp(v, 0, 1).
unsigned renderer_unorm16(double v);

// The element sequence of the layout (channel values interleaved per texel
// for two-channel layouts), as doubles before storage rounding; checks the
// tables against the layout (InputError naming the table and what differs).
std::vector<double> renderer_layout_values(const std::vector<TableData>& channels,
                                           const RendererExportOptions& options);

// Writes the header atomically (InputError as above, or for a storage type
// the layout does not take).
void export_renderer_header(const std::vector<TableData>& channels, const std::string& out_path,
                            const RendererExportOptions& options);

}  // namespace brdftab
