// exr_export.cpp — one 2-D slice of a table as a scanline OpenEXR image.
//
// Scanline + ZIP + R/G/B/A in HALF or FLOAT is the combination every EXR
// loader reads (tinyexr included); DWA/B44 would be lossy and are not used.
#include "host/io/exr_export.h"

#include "host/core/atomic_file.h"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfPartType.h>
#include <ImfMultiPartOutputFile.h>
#include <ImfOutputPart.h>
#include <ImfOutputFile.h>
#include <ImfStringAttribute.h>
#include <Imath/half.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <exception>
#include <unistd.h>
#include <vector>

#include "host/core/error.h"
#include "host/core/text.h"

#ifndef BRDFTAB_VERSION
#define BRDFTAB_VERSION "unknown"
#endif

namespace brdftab {
namespace {

// 12 digits: enough to paste back within the 1e-9 node tolerance.
std::string num(double v) { return number_text(v, 12); }

std::string axis_label(const Axis& a) {
    std::string unit = a.unit.empty() || a.unit == "1" ? "" : " " + a.unit;
    return a.name + " [" + num(a.min) + ", " + num(a.max) + "]" + unit + ", " +
           std::to_string(a.count) + " nodes, " + spacing_name(a.spacing);
}

// Index of the node equal to `v`.  "Equal" is within 1e-9 of the larger of
// the node's magnitude and the axis span, so nodes at 0 can be matched too.
std::size_t find_node(const Axis& a, double v) {
    const double span = std::fabs(a.max - a.min);
    for (std::size_t k = 0; k < a.values.size(); ++k) {
        const double node = a.values[k];
        if (std::fabs(node - v) <= 1e-9 * std::max({std::fabs(node), span, 1e-300})) return k;
    }
    // Not a node: name the bracketing nodes (or the end node when outside).
    std::string near;
    auto hi = std::lower_bound(a.values.begin(), a.values.end(), v);
    if (hi == a.values.begin())
        near = num(a.values.front());
    else if (hi == a.values.end())
        near = num(a.values.back());
    else
        near = num(*(hi - 1)) + " and " + num(*hi);
    throw InputError("slice " + a.name + "=" + num(v) + " is not a node of axis '" + a.name +
                     "' (" + num(a.min) + " to " + num(a.max) +
                     (a.unit.empty() ? "" : " " + a.unit) + ", " + std::to_string(a.count) +
                     " nodes); nearest node" + (near.find(" and ") != std::string::npos ? "s: " : ": ") +
                     near);
}

std::string join_names(const std::vector<std::size_t>& idx, const std::vector<Axis>& axes) {
    std::string s;
    for (std::size_t i : idx) s += (s.empty() ? "" : ", ") + axes[i].name;
    return s.empty() ? "none" : s;
}

}  // namespace

void export_exr_slice(const TableData& table, const std::string& out_path,
                      const ExrExportOptions& options) {
    const std::vector<Axis>& axes = table.axes;
    const std::string where = "EXR export of table '" + table.name + "': ";
    // A 0-node axis has no node to slice at (and would make the table empty).
    for (const Axis& a : axes)
        if (a.count == 0) throw InputError(where + "axis '" + a.name + "' has no nodes");
    const std::size_t cells = checked_cell_count(axes, where);
    if (table.value.size() != cells)
        throw Error(where + "value has " + std::to_string(table.value.size()) +
                    " entries, the axes need " + std::to_string(cells));
    for (const Axis& a : axes)
        if (a.values.size() != a.count)
            throw Error(where + "axis '" + a.name + "' has count " + std::to_string(a.count) +
                        " but " + std::to_string(a.values.size()) + " node values");

    // Every slice key must name an axis.
    for (const auto& entry : options.slice) {
        const std::string& key = entry.first;  // (C++17 lambdas cannot capture a structured binding)
        bool known = std::any_of(axes.begin(), axes.end(),
                                 [&](const Axis& a) { return a.name == key; });
        if (!known) {
            std::string all;
            for (const Axis& a : axes) all += (all.empty() ? "" : ", ") + a.name;
            throw InputError(where + "--slice names unknown axis '" + key + "' (axes: " + all +
                             ")");
        }
    }

    // Fixed index per axis; free axes are those of count > 1 not in the slice.
    std::vector<std::size_t> index(axes.size(), 0);
    std::vector<std::size_t> free_axes;
    for (std::size_t i = 0; i < axes.size(); ++i) {
        auto it = options.slice.find(axes[i].name);
        if (it != options.slice.end())
            index[i] = find_node(axes[i], it->second);
        else if (axes[i].count > 1)
            free_axes.push_back(i);
    }
    const std::size_t want = options.layers ? 3 : 2;
    if (free_axes.size() != want) {
        std::vector<std::size_t> multi;
        for (std::size_t i = 0; i < axes.size(); ++i)
            if (axes[i].count > 1) multi.push_back(i);
        throw InputError(where + (options.layers ? "a layered image needs exactly three free axes, got "
                                                 : "an image needs exactly two free axes, got ") +
                         std::to_string(free_axes.size()) + " (" +
                         join_names(free_axes, axes) + "); fix all but " +
                         (options.layers ? "three" : "two") + " of the axes " +
                         join_names(multi, axes) + " with axis=value");
    }
    // Image axes: as asked, or the last free axis on x and the one before on y.
    auto free_axis_named = [&](const std::string& name, const char* role) {
        for (std::size_t i : free_axes)
            if (axes[i].name == name) return i;
        throw InputError(where + "--axes: '" + name + "' (image " + role +
                         ") is not a free axis; free axes: " + join_names(free_axes, axes));
    };
    std::size_t ax = free_axes[free_axes.size() - 1], ay = free_axes[free_axes.size() - 2];
    if (options.x_axis.empty() != options.y_axis.empty())
        throw InputError(where + "--axes needs two names, x and y");
    if (!options.x_axis.empty()) {
        ax = free_axis_named(options.x_axis, "x");
        ay = free_axis_named(options.y_axis, "y");
        if (ax == ay)
            throw InputError(where + "--axes names '" + options.x_axis + "' twice");
    }
    std::size_t al = axes.size();  // layer axis (none: axes.size())
    for (std::size_t i : free_axes)
        if (i != ax && i != ay) al = i;

    const int width = static_cast<int>(axes[ax].count);
    const int height = static_cast<int>(axes[ay].count);
    const TableData* green = options.green;
    if (green) {
        bool same = green->axes.size() == axes.size() && green->value.size() == table.value.size();
        for (std::size_t i = 0; same && i < axes.size(); ++i)
            same = green->axes[i].name == axes[i].name && green->axes[i].values == axes[i].values;
        if (!same)
            throw InputError("tables '" + table.name + "' and '" + green->name +
                             "' differ in their axes or nodes; the two channels of an EXR "
                             "texture must share one grid");
    }
    const bool have_stderr = !green && options.with_stderr && !table.stderr_.empty() &&
                             table.stderr_.size() == table.value.size();
    const std::size_t npix = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
    const std::size_t nlayers = al < axes.size() ? axes[al].count : 1;
    const Imf::PixelType pt = options.half ? Imf::HALF : Imf::FLOAT;

    // One part per layer: its header and pixel data (float or half).
    struct Part {
        std::vector<float> f[4];
        std::vector<Imath::half> h[4];
    };
    std::vector<Imf::Header> headers;
    std::vector<Part> parts(nlayers);
    for (std::size_t layer = 0; layer < nlayers; ++layer) {
        if (al < axes.size()) index[al] = layer;
        // Gather the slice (y rows, x fastest) in double first.
        std::vector<double> r(npix), g(npix, 0.0);
        for (int y = 0; y < height; ++y)
            for (int x = 0; x < width; ++x) {
                index[ay] = static_cast<std::size_t>(y);
                index[ax] = static_cast<std::size_t>(x);
                const std::size_t c = table.flat_index(index);
                const std::size_t p = static_cast<std::size_t>(y) * width + x;
                r[p] = table.value[c];
                if (have_stderr) g[p] = table.stderr_[c];
                if (green) g[p] = green->value[c];
            }

        Imf::Header header(width, height);
        header.compression() = Imf::ZIP_COMPRESSION;
        for (const char* ch : {"R", "G", "B", "A"}) header.channels().insert(ch, Imf::Channel(pt));

        std::string slice_desc;
        for (std::size_t i = 0; i < axes.size(); ++i) {
            if (i == ax || i == ay) continue;
            slice_desc += (slice_desc.empty() ? "" : ", ") + axes[i].name + "=" +
                          num(axes[i].values[index[i]]) +
                          (axes[i].unit.empty() || axes[i].unit == "1" ? "" : " " + axes[i].unit);
        }
        auto put = [&](const char* key, const std::string& v) {
            header.insert(key, Imf::StringAttribute(v));
        };
        put("brdftab_table", table.name);
        put("brdftab_model", table.model);
        put("brdftab_quantity", table.quantity);
        put("brdftab_units", table.units);
        put("brdftab_x_axis", axis_label(axes[ax]));
        put("brdftab_y_axis", axis_label(axes[ay]) + " (row 0 = first node)");
        put("brdftab_slice", slice_desc.empty() ? "none" : slice_desc);
        put("brdftab_channels",
            green ? "R=" + table.name + " G=" + green->name + " B=0 A=1"
                  : std::string("R=value G=") + (have_stderr ? "stderr" : "0") + " B=0 A=1");
        put("brdftab_version", BRDFTAB_VERSION);
        if (al < axes.size()) {
            put("brdftab_layer_axis", axis_label(axes[al]));
            header.setName(axes[al].name + "=" + num(axes[al].values[layer]));
            header.setType(Imf::SCANLINEIMAGE);
        }
        headers.push_back(header);

        // The frame-buffer slice type must equal the channel type, so HALF
        // channels get half data converted here (round to nearest via float).
        Part& part = parts[layer];
        const std::vector<double>* src[4] = {&r, &g, nullptr, nullptr};
        for (int ch = 0; ch < 4; ++ch) {
            if (options.half) {
                part.h[ch].assign(npix, Imath::half(ch == 3 ? 1.0f : 0.0f));
                if (src[ch])
                    std::transform(src[ch]->begin(), src[ch]->end(), part.h[ch].begin(),
                                   [](double v) { return Imath::half(static_cast<float>(v)); });
            } else {
                part.f[ch].assign(npix, ch == 3 ? 1.0f : 0.0f);
                if (src[ch]) part.f[ch].assign(src[ch]->begin(), src[ch]->end());
            }
        }
    }

    auto frame_buffer = [&](Part& part) {
        Imf::FrameBuffer fbuf;
        const char* names[4] = {"R", "G", "B", "A"};
        const std::size_t elem = options.half ? sizeof(Imath::half) : sizeof(float);
        for (int ch = 0; ch < 4; ++ch) {
            char* base = options.half ? reinterpret_cast<char*>(part.h[ch].data())
                                      : reinterpret_cast<char*>(part.f[ch].data());
            fbuf.insert(names[ch],
                        Imf::Slice(pt, base, elem, elem * static_cast<std::size_t>(width)));
        }
        return fbuf;
    };

    AtomicOutput tmp(out_path);
    try {
        if (al < axes.size()) {
            Imf::MultiPartOutputFile file(tmp.path().c_str(), headers.data(),
                                          static_cast<int>(headers.size()));
            for (std::size_t layer = 0; layer < nlayers; ++layer) {
                Imf::OutputPart part(file, static_cast<int>(layer));
                part.setFrameBuffer(frame_buffer(parts[layer]));
                part.writePixels(height);
            }
        } else {
            Imf::OutputFile file(tmp.path().c_str(), headers.front());
            file.setFrameBuffer(frame_buffer(parts.front()));
            file.writePixels(height);
        }
    } catch (const std::exception& e) {
        throw Error("cannot write EXR '" + out_path + "': " + e.what());
    }
    tmp.commit();
}

}  // namespace brdftab
