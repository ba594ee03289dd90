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
    const std::string unit = unit_suffix(a.unit);
    return a.name + " [" + num(a.min) + ", " + num(a.max) + "]" + unit + ", " +
           std::to_string(a.count) + " nodes, " + spacing_name(a.spacing);
}

std::string join_names(const std::vector<std::size_t>& idx, const std::vector<Axis>& axes) {
    std::string s;
    for (std::size_t i : idx) s += (s.empty() ? "" : ", ") + axes[i].name;
    return s.empty() ? "none" : s;
}

}  // namespace

ImageSlice image_slice(const TableData& table, const ExrExportOptions& options) {
    const std::vector<Axis>& axes = table.axes;
    const std::string where = "export of table '" + table.name + "': ";
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

    // Fixed axes: at a node, or between two (interpolated; axis_position).
    // Free axes are those of count > 1 not in the slice.
    ImageSlice out;
    std::vector<std::size_t> index(axes.size(), 0);
    std::vector<std::size_t> free_axes, between;  // between: fixed axes off their nodes
    std::vector<AxisPosition> position(axes.size());
    for (std::size_t i = 0; i < axes.size(); ++i) {
        auto it = options.slice.find(axes[i].name);
        if (it == options.slice.end()) {
            if (axes[i].count > 1) free_axes.push_back(i);
            continue;
        }
        double dep = 0;
        if (axes[i].dependent()) {
            auto d = options.slice.find(axes[i].depends_on);
            if (d == options.slice.end())
                throw InputError(where + "--slice " + axes[i].name + " needs --slice " + axes[i].depends_on +
                                 " too (the nodes of '" + axes[i].name + "' move with it)");
            dep = d->second;
        }
        try {
            position[i] = axis_position(axes[i], it->second, dep);
        } catch (const InputError& e) {
            throw InputError(where + "--slice " + e.what());
        }
        index[i] = position[i].node;
        if (!position[i].at_node) {
            between.push_back(i);
            out.notes.push_back(slice_note(axes[i], it->second, position[i]));
        }
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
    out.x_axis = ax;
    out.y_axis = ay;
    out.layer_axis = al;
    out.width = width;
    out.height = height;
    out.has_stderr = have_stderr;
    for (std::size_t layer = 0; layer < nlayers; ++layer) {
        if (al < axes.size()) index[al] = layer;
        ImageSlice::Layer L;
        L.value.assign(npix, 0.0);
        L.stderr_.assign(npix, 0.0);
        // Gather the slice (y rows, x fastest): each pixel the sum over the
        // 2^m corners of the m fixed axes between nodes, with the linear
        // weights (one corner of weight 1 when every fixed axis is at a node).
        const std::size_t corners = std::size_t(1) << between.size();
        for (int y = 0; y < height; ++y)
            for (int x = 0; x < width; ++x) {
                index[ay] = static_cast<std::size_t>(y);
                index[ax] = static_cast<std::size_t>(x);
                const std::size_t p = static_cast<std::size_t>(y) * width + x;
                double v = 0, e = 0;
                for (std::size_t corner = 0; corner < corners; ++corner) {
                    std::vector<std::size_t> at = index;
                    double w = 1;
                    for (std::size_t j = 0; j < between.size(); ++j) {
                        const bool upper = (corner >> j) & 1;
                        at[between[j]] = position[between[j]].node + (upper ? 1 : 0);
                        w *= upper ? position[between[j]].s : 1 - position[between[j]].s;
                    }
                    if (w == 0 && corners > 1) continue;
                    const std::size_t c = table.flat_index(at);
                    v += w * table.value[c];
                    if (have_stderr) e += w * table.stderr_[c];
                    if (green) e += w * green->value[c];
                }
                L.value[p] = v;
                // The second channel: the stderr, or the green table's values.
                if (have_stderr || green) L.stderr_[p] = e;
            }
        for (std::size_t i = 0; i < axes.size(); ++i) {
            if (i == ax || i == ay) continue;
            const bool interpolated = std::find(between.begin(), between.end(), i) != between.end();
            const double v = interpolated ? options.slice.at(axes[i].name) : axes[i].values[index[i]];
            L.slice += (L.slice.empty() ? "" : ", ") + axes[i].name + "=" + num(v) + unit_suffix(axes[i].unit) +
                       (interpolated ? " (interpolated)" : "");
        }
        if (al < axes.size()) L.name = axes[al].name + "=" + num(axes[al].values[layer]);
        out.layers.push_back(std::move(L));
    }
    return out;
}

std::vector<std::string> export_exr_slice(const TableData& table, const std::string& out_path,
                                          const ExrExportOptions& options) {
    const ImageSlice slice = image_slice(table, options);
    const std::vector<Axis>& axes = table.axes;
    const std::size_t ax = slice.x_axis, ay = slice.y_axis, al = slice.layer_axis;
    const int width = slice.width, height = slice.height;
    const bool have_stderr = slice.has_stderr;
    const TableData* green = options.green;
    const std::size_t npix = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
    const std::size_t nlayers = slice.layers.size();
    const Imf::PixelType pt = options.half ? Imf::HALF : Imf::FLOAT;

    // One part per layer: its header and pixel data (float or half).
    struct Part {
        std::vector<float> f[4];
        std::vector<Imath::half> h[4];
    };
    std::vector<Imf::Header> headers;
    std::vector<Part> parts(nlayers);
    for (std::size_t layer = 0; layer < nlayers; ++layer) {
        const std::vector<double>& r = slice.layers[layer].value;
        const std::vector<double>& g = slice.layers[layer].stderr_;

        Imf::Header header(width, height);
        header.compression() = Imf::ZIP_COMPRESSION;
        for (const char* ch : {"R", "G", "B", "A"}) header.channels().insert(ch, Imf::Channel(pt));

        const std::string& slice_desc = slice.layers[layer].slice;
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
            header.setName(slice.layers[layer].name);
            header.setType(Imf::SCANLINEIMAGE);
        }
        headers.push_back(header);

        // The frame-buffer slice type must equal the channel type, so HALF
        // channels get half data converted here (round to nearest via float).
        Part& part = parts[layer];
        const std::vector<double>* src[4] = {&r, have_stderr || green ? &g : nullptr, nullptr, nullptr};
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
    return slice.notes;
}

}  // namespace brdftab
