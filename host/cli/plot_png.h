// plot_png.h — a small raster canvas (lines, rectangles, a built-in 5x8 bitmap
// font) and two chart layouts (line plot with legend, colour map with colour
// bar), written as 8-bit RGB PNG through libpng.  Used by `brdftab plot`.
//
// Deliberately minimal: no anti-aliasing, one font, integer scaling.  Charts
// are meant to be read by people checking a table, not to be published.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace brdftab::cli {

struct Rgb {
    std::uint8_t r = 0, g = 0, b = 0;
};

class Canvas {
public:
    Canvas(int width, int height, Rgb background);
    int width() const { return w_; }
    int height() const { return h_; }

    void pixel(int x, int y, Rgb c);  // clipped
    // Filled rectangle covering x0 <= x < x1, y0 <= y < y1 (clipped).
    void fill_rect(int x0, int y0, int x1, int y1, Rgb c);
    // Outline of the same rectangle, 1 px.
    void rect(int x0, int y0, int x1, int y1, Rgb c);
    // Straight line (Bresenham) drawn with a square pen `thickness` px wide.
    void line(double x0, double y0, double x1, double y1, Rgb c, int thickness = 1);

    // Text with the built-in font; (x, y) is the top-left corner.  Glyph cells
    // are 6x9 px (5x8 glyph + spacing) times `scale`.  Characters outside the
    // font are drawn as '?'.  Returns the width drawn.
    int text(int x, int y, const std::string& s, Rgb c, int scale = 1);
    // Text turned 90 degrees counter-clockwise (reads bottom to top); (x, y)
    // is the bottom-left corner of the turned text.
    void text_up(int x, int y, const std::string& s, Rgb c, int scale = 1);
    static int text_width(const std::string& s, int scale = 1);
    static int text_height(int scale = 1);

    // Writes an 8-bit RGB PNG to a temporary file beside `path` and renames it
    // over `path` only when complete.  Throws brdftab::Error.
    void write_png(const std::string& path) const;

private:
    int w_, h_;
    std::vector<std::uint8_t> rgb_;
};

// A 16-bit greyscale PNG (one sample per pixel, row 0 first) with tEXt
// chunks (key, text; Latin-1 keys of 1-79 characters), written to a temporary
// file and renamed over `path`.  Throws brdftab::Error.  Used by `export --png`.
void write_png_gray16(const std::string& path, int width, int height, const std::vector<std::uint16_t>& pixels,
                      const std::vector<std::pair<std::string, std::string>>& text);

// Perceptually ordered colour ramp (dark blue -> teal -> yellow), t in [0, 1].
Rgb colour_ramp(double t);
// Distinct colours for curves; cycles after 10.
Rgb curve_colour(std::size_t k);

// "Nice" tick positions (1, 2, 5 x 10^k steps) covering [lo, hi], about
// `target` of them, all within [lo, hi].
std::vector<double> nice_ticks(double lo, double hi, int target = 6);
// Short number label (%g with up to 4 significant digits, no trailing noise).
std::string tick_label(double v);

struct Curve {
    std::string label;          // legend entry (empty: no legend entry)
    std::vector<double> x, y;   // polyline; a NaN y breaks the line
    std::vector<double> mx, my; // optional markers (e.g. table nodes)
};

struct LinePlot {
    std::string title, subtitle, xlabel, ylabel, legend_title;
    std::vector<Curve> curves;
    int width = 960, height = 620;
};

// Throws brdftab::InputError when no curve has a finite point.
void render_line_plot(const LinePlot& plot, const std::string& path);

struct MapPlot {
    std::string title, subtitle, xlabel, ylabel, zlabel;
    double x0 = 0, x1 = 1, y0 = 0, y1 = 1;  // data ranges of the axes
    // Value at (x, y); called once per pixel of the plot area.  NaN = no data
    // (drawn grey).
    std::function<double(double x, double y)> value;
    int width = 900, height = 660;
};

void render_map_plot(const MapPlot& plot, const std::string& path);

}  // namespace brdftab::cli
