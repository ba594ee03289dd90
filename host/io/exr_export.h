// exr_export.h — write a 2-D slice of a table as an OpenEXR image.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "host/core/table.h"

namespace brdftab {

struct ExrExportOptions {
    // Fixed values for every axis except two, within each axis' range.  A
    // value at a node (axis_position, host/core/grid.h) takes that node's
    // values; one between nodes is interpolated linearly in the axis' warped
    // coordinate (values and stderr, the weights of the library's linear
    // lookup), and ImageSlice::notes says so.  Axes of size 1 need no entry.
    std::map<std::string, double> slice;
    bool half = false;        // HALF channels instead of FLOAT
    bool with_stderr = true;  // G channel = stderr when the table has it
    // Which free axes become image x and y (both empty: x = the later free
    // axis, y = the earlier one, in the table's axis order).
    std::string x_axis, y_axis;
    // Three free axes: one part per node of the free axis that is not x or y
    // (a multi-part file; each part named "axis=value").
    bool layers = false;
    // Two-channel textures (a renderer's split-sum or DFG LUT): G = this
    // table's values instead of the stderr; it must have the same axes and
    // nodes as `table` (InputError otherwise).  Not owned.
    const TableData* green = nullptr;
};

// Scanline, ZIP compression.  The image's x axis is the last free axis, y the
// first free axis (row 0 = first node), unless x_axis/y_axis say otherwise.
// With `layers`, a multi-part file of one such image per node of the third
// free axis (parts in node order, each part's name "axis=value").  Channels: R = value, G = stderr (or
// 0), B = 0, A = 1, so every loader reads it.  Axis names and ranges go into
// string attributes.  Written to a temporary file, then renamed.
// Returns the notes of ImageSlice (one per fixed axis between nodes).
std::vector<std::string> export_exr_slice(const TableData& table, const std::string& out_path,
                                          const ExrExportOptions& options);

// The image(s) export_exr_slice writes, before any file format: also the
// source of `export --png`.  Throws InputError as export_exr_slice.
struct ImageSlice {
    std::size_t x_axis = 0, y_axis = 0;
    std::size_t layer_axis = 0;  // == the axis count: no layers
    int width = 0, height = 0;
    bool has_stderr = false;
    struct Layer {
        std::vector<double> value, stderr_;  // y rows (row 0 = first node), x fastest
        std::string slice;                   // "eta=1.5 (interpolated), ..." (the fixed axes)
        std::string name;                    // "axis=value" of a layer; empty without layers
    };
    std::vector<Layer> layers;
    std::vector<std::string> notes;  // slice_note() of each fixed axis between nodes
};
ImageSlice image_slice(const TableData& table, const ExrExportOptions& options);

}  // namespace brdftab
