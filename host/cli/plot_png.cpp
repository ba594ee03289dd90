#include "host/cli/plot_png.h"

#include "host/core/atomic_file.h"

#include <png.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "host/core/error.h"

namespace brdftab::cli {

namespace {

// 5x8 bitmap font, drawn for this project: 8 rows of 5 columns, '#' = ink.
// Rows 0-6 hold capitals and digits, row 7 is the descender.
struct Glyph {
    char c;
    char rows[41];  // 8 rows x 5 columns; a longer literal does not compile
};

// clang-format off
const Glyph kFont[] = {
    {' ', "........................................"},
    {'0', ".###.#...##..###.#.###..##...#.###......"},
    {'1', "..#...##....#....#....#....#...###......"},
    {'2', ".###.#...#....#...#...#...#...#####....."},
    {'3', "#####...#...#.....#.....##...#.###......"},
    {'4', "...#...##..#.#.#..#.#####...#....#......"},
    {'5', "######....####.....#....##...#.###......"},
    {'6', "..##..#...#....####.#...##...#.###......"},
    {'7', "#####....#...#...#...#....#....#........"},
    {'8', ".###.#...##...#.###.#...##...#.###......"},
    {'9', ".###.#...##...#.####....#...#..##......."},
    {'A', ".###.#...##...#######...##...##...#....."},
    {'B', "####.#...##...#####.#...##...#####......"},
    {'C', ".###.#...##....#....#....#...#.###......"},
    {'D', "####.#...##...##...##...##...#####......"},
    {'E', "######....#....####.#....#....#####....."},
    {'F', "######....#....####.#....#....#........."},
    {'G', ".###.#...##....#.####...##...#.####....."},
    {'H', "#...##...##...#######...##...##...#....."},
    {'I', ".###...#....#....#....#....#...###......"},
    {'J', "..###...#....#....#....#.#..#..##......."},
    {'K', "#...##..#.#.#..##...#.#..#..#.#...#....."},
    {'L', "#....#....#....#....#....#....#####....."},
    {'M', "#...###.###.#.##.#.##...##...##...#....."},
    {'N', "#...##...###..##.#.##..###...##...#....."},
    {'O', ".###.#...##...##...##...##...#.###......"},
    {'P', "####.#...##...#####.#....#....#........."},
    {'Q', ".###.#...##...##...##.#.##..#..##.#....."},
    {'R', "####.#...##...#####.#.#..#..#.#...#....."},
    {'S', ".#####....#.....###.....#....#####......"},
    {'T', "#####..#....#....#....#....#....#......."},
    {'U', "#...##...##...##...##...##...#.###......"},
    {'V', "#...##...##...##...##...#.#.#...#......."},
    {'W', "#...##...##...##.#.##.#.##.#.#.#.#......"},
    {'X', "#...##...#.#.#...#...#.#.#...##...#....."},
    {'Y', "#...##...#.#.#...#....#....#....#......."},
    {'Z', "#####....#...#...#...#...#....#####....."},
    {'a', "...........###.....#.#####...#.####....."},
    {'b', "#....#....#.##.##..##...##...#####......"},
    {'c', "...........###.#....#....#...#.###......"},
    {'d', "....#....#.##.##..###...##...#.####....."},
    {'e', "...........###.#...#######.....###......"},
    {'f', "..##..#..#.#...###...#....#....#........"},
    {'g', "...........#####...##...#.####....#.###."},
    {'h', "#....#....#.##.##..##...##...##...#....."},
    {'i', "..#........##....#....#....#...###......"},
    {'j', "...#........##....#....#....#.#..#..##.."},
    {'k', "#....#....#..#.#.#..##...#.#..#..#......"},
    {'l', ".##....#....#....#....#....#...###......"},
    {'m', "..........##.#.#.#.##.#.##...##...#....."},
    {'n', "..........#.##.##..##...##...##...#....."},
    {'o', "...........###.#...##...##...#.###......"},
    {'p', "..........####.#...##...#####.#....#...."},
    {'q', "...........#####...##...#.####....#....#"},
    {'r', "..........#.##.##..##....#....#........."},
    {'s', "...........#####.....###.....#####......"},
    {'t', ".#....#...###...#....#....#..#..##......"},
    {'u', "..........#...##...##...##..##.##.#....."},
    {'v', "..........#...##...##...#.#.#...#......."},
    {'w', "..........#...##...##.#.##.#.#.#.#......"},
    {'x', "..........#...#.#.#...#...#.#.#...#....."},
    {'y', "..........#...##...##...#.####....#.###."},
    {'z', "..........#####...#...#...#...#####....."},
    {'.', "..........................##...##......."},
    {',', "..........................##....#...#..."},
    {'-', "................###....................."},
    {'+', ".......#....#..#####..#....#............"},
    {'_', "...................................#####"},
    {'=', "..........#####.....#####..............."},
    {'(', "...#...#...#....#....#.....#.....#......"},
    {')', ".#.....#.....#....#....#...#...#........"},
    {'[', ".###..#....#....#....#....#....###......"},
    {']', ".###....#....#....#....#....#..###......"},
    {'/', ".........#...#...#...#...#.............."},
    {':', "......##...##........##...##............"},
    {'%', "##..###..#...#...#...#...#..###..##....."},
    {'*', ".......#..#.#.#.###.#.#.#..#............"},
    {'^', "..#...#.#.#...#........................."},
    {'|', "..#....#....#....#....#....#....#......."},
    {'\'', "..#....#...#............................"},
    {'<', "...#...#...#...#.....#.....#.....#......"},
    {'>', ".#.....#.....#.....#...#...#...#........"},
    {'?', ".###.#...#....#...#...#.........#......."},
};
// clang-format on

const Glyph* find_glyph(char c) {
    static const Glyph* table[128] = {};
    static bool init = [] {
        for (const Glyph& g : kFont) table[static_cast<unsigned char>(g.c)] = &g;
        return true;
    }();
    (void)init;
    const unsigned char u = static_cast<unsigned char>(c);
    if (u < 128 && table[u]) return table[u];
    return table[static_cast<unsigned char>('?')];
}

bool ink(const Glyph* g, int row, int col) { return g->rows[row * 5 + col] == '#'; }

constexpr int kCellW = 6, kCellH = 9;

const Rgb kBlack{0, 0, 0}, kWhite{255, 255, 255}, kGrid{225, 225, 225}, kGrey{90, 90, 90},
    kNoData{170, 170, 170};

}  // namespace

Canvas::Canvas(int width, int height, Rgb bg)
    : w_(width), h_(height), rgb_(static_cast<std::size_t>(width) * height * 3) {
    for (std::size_t k = 0; k < rgb_.size(); k += 3) {
        rgb_[k] = bg.r;
        rgb_[k + 1] = bg.g;
        rgb_[k + 2] = bg.b;
    }
}

void Canvas::pixel(int x, int y, Rgb c) {
    if (x < 0 || y < 0 || x >= w_ || y >= h_) return;
    std::uint8_t* p = &rgb_[(static_cast<std::size_t>(y) * w_ + x) * 3];
    p[0] = c.r;
    p[1] = c.g;
    p[2] = c.b;
}

void Canvas::fill_rect(int x0, int y0, int x1, int y1, Rgb c) {
    x0 = std::max(x0, 0), y0 = std::max(y0, 0);
    x1 = std::min(x1, w_), y1 = std::min(y1, h_);
    for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x) pixel(x, y, c);
}

void Canvas::rect(int x0, int y0, int x1, int y1, Rgb c) {
    fill_rect(x0, y0, x1, y0 + 1, c);
    fill_rect(x0, y1 - 1, x1, y1, c);
    fill_rect(x0, y0, x0 + 1, y1, c);
    fill_rect(x1 - 1, y0, x1, y1, c);
}

void Canvas::line(double fx0, double fy0, double fx1, double fy1, Rgb c, int thickness) {
    if (!std::isfinite(fx0) || !std::isfinite(fy0) || !std::isfinite(fx1) || !std::isfinite(fy1))
        return;
    // Keep coordinates in int range; anything far outside is clipped anyway.
    auto cl = [](double v) { return static_cast<int>(std::lround(std::clamp(v, -1e6, 1e6))); };
    int x0 = cl(fx0), y0 = cl(fy0), x1 = cl(fx1), y1 = cl(fy1);
    const int dx = std::abs(x1 - x0), sx = x0 < x1 ? 1 : -1;
    const int dy = -std::abs(y1 - y0), sy = y0 < y1 ? 1 : -1;
    const int lo = -(thickness - 1) / 2, hi = thickness / 2;
    int err = dx + dy;
    for (;;) {
        fill_rect(x0 + lo, y0 + lo, x0 + hi + 1, y0 + hi + 1, c);
        if (x0 == x1 && y0 == y1) break;
        const int e2 = 2 * err;
        if (e2 >= dy) err += dy, x0 += sx;
        if (e2 <= dx) err += dx, y0 += sy;
    }
}

int Canvas::text(int x, int y, const std::string& s, Rgb c, int scale) {
    int cx = x;
    for (char ch : s) {
        const Glyph* g = find_glyph(ch);
        for (int r = 0; r < 8; ++r)
            for (int k = 0; k < 5; ++k)
                if (ink(g, r, k))
                    fill_rect(cx + k * scale, y + r * scale, cx + (k + 1) * scale,
                              y + (r + 1) * scale, c);
        cx += kCellW * scale;
    }
    return cx - x;
}

void Canvas::text_up(int x, int y, const std::string& s, Rgb c, int scale) {
    // Glyph pixel (col k, row r) of the n-th character goes to
    // (x + r, y - n*cell - k): the text baseline runs upward.
    int n = 0;
    for (char ch : s) {
        const Glyph* g = find_glyph(ch);
        for (int r = 0; r < 8; ++r)
            for (int k = 0; k < 5; ++k)
                if (ink(g, r, k)) {
                    const int px = x + r * scale;
                    const int py = y - (n * kCellW + k + 1) * scale;
                    fill_rect(px, py, px + scale, py + scale, c);
                }
        ++n;
    }
}

int Canvas::text_width(const std::string& s, int scale) {
    return static_cast<int>(s.size()) * kCellW * scale;
}
int Canvas::text_height(int scale) { return kCellH * scale; }

namespace {

// Writes rows (each width samples of bit_depth bits, big-endian) as a PNG of
// colour_type through a temporary file renamed over `path` when complete.
void write_png_rows(const std::string& path, int width, int height, int bit_depth, int colour_type,
                    const std::vector<png_bytep>& rows, std::vector<png_text>& chunks) {
    AtomicOutput out(path);
    const std::string& tmp = out.path();
    FILE* f = std::fopen(tmp.c_str(), "wb");
    if (!f) throw Error("cannot create '" + tmp + "'");
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
    png_infop info = png ? png_create_info_struct(png) : nullptr;
    if (!png || !info) {
        png_destroy_write_struct(&png, &info);
        std::fclose(f);
        throw Error("libpng: out of memory");
    }
    // libpng reports errors by longjmp; nothing with a destructor lives
    // between here and the end of the write.
    volatile bool failed = false;  // survives the longjmp
    if (setjmp(png_jmpbuf(png))) {
        failed = true;
    } else {
        png_init_io(png, f);
        png_set_IHDR(png, info, width, height, bit_depth, colour_type, PNG_INTERLACE_NONE,
                     PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
        if (!chunks.empty()) png_set_text(png, info, chunks.data(), static_cast<int>(chunks.size()));
        png_write_info(png, info);
        png_write_image(png, const_cast<png_bytepp>(rows.data()));
        png_write_end(png, nullptr);
    }
    png_destroy_write_struct(&png, &info);
    const bool close_failed = std::fclose(f) != 0;
    if (failed || close_failed) throw Error("cannot write PNG '" + tmp + "'");
    out.commit();
}

}  // namespace

void Canvas::write_png(const std::string& path) const {
    std::vector<png_bytep> rows(h_);
    for (int y = 0; y < h_; ++y)
        rows[y] = const_cast<png_bytep>(&rgb_[static_cast<std::size_t>(y) * w_ * 3]);
    std::vector<png_text> no_text;
    write_png_rows(path, w_, h_, 8, PNG_COLOR_TYPE_RGB, rows, no_text);
}

void write_png_gray16(const std::string& path, int width, int height, const std::vector<std::uint16_t>& pixels,
                      const std::vector<std::pair<std::string, std::string>>& text) {
    if (width < 1 || height < 1 || pixels.size() != static_cast<std::size_t>(width) * height)
        throw Error("write_png_gray16: " + std::to_string(pixels.size()) + " pixels for " + std::to_string(width) +
                    " x " + std::to_string(height));
    // PNG samples are big-endian.
    std::vector<png_byte> bytes(pixels.size() * 2);
    for (std::size_t i = 0; i < pixels.size(); ++i) {
        bytes[2 * i] = static_cast<png_byte>(pixels[i] >> 8);
        bytes[2 * i + 1] = static_cast<png_byte>(pixels[i] & 0xff);
    }
    std::vector<png_text> chunks(text.size());
    for (std::size_t i = 0; i < text.size(); ++i) {
        chunks[i] = png_text{};
        chunks[i].compression = PNG_TEXT_COMPRESSION_NONE;
        chunks[i].key = const_cast<char*>(text[i].first.c_str());
        chunks[i].text = const_cast<char*>(text[i].second.c_str());
        chunks[i].text_length = text[i].second.size();
    }
    std::vector<png_bytep> rows(height);
    for (int y = 0; y < height; ++y) rows[y] = &bytes[static_cast<std::size_t>(y) * width * 2];
    write_png_rows(path, width, height, 16, PNG_COLOR_TYPE_GRAY, rows, chunks);
}

Rgb colour_ramp(double t) {
    // Control points chosen for monotone lightness: dark indigo, violet, teal,
    // green, yellow.
    static const double stops[5][3] = {{0.07, 0.04, 0.28},
                                       {0.35, 0.16, 0.55},
                                       {0.12, 0.52, 0.58},
                                       {0.45, 0.78, 0.33},
                                       {0.99, 0.91, 0.22}};
    if (!std::isfinite(t)) return kNoData;
    t = std::clamp(t, 0.0, 1.0) * 4;
    const int k = std::min(static_cast<int>(t), 3);
    const double f = t - k;
    auto ch = [&](int c) {
        return static_cast<std::uint8_t>(
            std::lround(255 * ((1 - f) * stops[k][c] + f * stops[k + 1][c])));
    };
    return {ch(0), ch(1), ch(2)};
}

Rgb curve_colour(std::size_t k) {
    static const Rgb palette[10] = {{31, 100, 180},  {230, 110, 20}, {40, 150, 60},
                                    {210, 40, 45},   {140, 90, 190}, {130, 80, 60},
                                    {220, 100, 180}, {100, 100, 100}, {170, 170, 20},
                                    {20, 170, 190}};
    return palette[k % 10];
}

std::vector<double> nice_ticks(double lo, double hi, int target) {
    std::vector<double> out;
    if (!(hi > lo) || !std::isfinite(lo) || !std::isfinite(hi)) {
        if (std::isfinite(lo)) out.push_back(lo);
        return out;
    }
    const double raw = (hi - lo) / std::max(target, 1);
    const double mag = std::pow(10.0, std::floor(std::log10(raw)));
    double step = mag;
    for (double m : {1.0, 2.0, 5.0, 10.0})
        if (m * mag >= raw) {
            step = m * mag;
            break;
        }
    const double eps = 1e-9 * (hi - lo);
    for (double v = std::ceil((lo - eps) / step) * step; v <= hi + eps; v += step)
        out.push_back(std::abs(v) < 1e-12 * step ? 0.0 : v);
    return out;
}

std::string tick_label(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.4g", v);
    return buf;
}

namespace {

// Maps data to pixels for one axis.
struct Scale {
    double d0, d1;  // data range
    double p0, p1;  // pixel range
    double operator()(double v) const { return p0 + (v - d0) / (d1 - d0) * (p1 - p0); }
};

// Widen a degenerate range so scales never divide by zero.
void widen(double& lo, double& hi) {
    if (hi > lo) return;
    const double pad = lo == 0 ? 1 : 0.05 * std::abs(lo);
    lo -= pad;
    hi += pad;
}

void draw_titles(Canvas& c, const std::string& title, const std::string& subtitle) {
    c.text(20, 12, title, kBlack, 2);
    if (!subtitle.empty()) c.text(20, 12 + Canvas::text_height(2) + 4, subtitle, kGrey, 1);
}

// Frame, grid, ticks and labels of a plot area [x0, x1) x [y0, y1).
void draw_axes(Canvas& c, int x0, int y0, int x1, int y1, const Scale& sx, const Scale& sy,
               const std::string& xlabel, const std::string& ylabel, bool grid) {
    const auto xt = nice_ticks(sx.d0, sx.d1, 7), yt = nice_ticks(sy.d0, sy.d1, 6);
    if (grid) {
        for (double v : xt) {
            const int px = static_cast<int>(std::lround(sx(v)));
            c.fill_rect(px, y0, px + 1, y1, kGrid);
        }
        for (double v : yt) {
            const int py = static_cast<int>(std::lround(sy(v)));
            c.fill_rect(x0, py, x1, py + 1, kGrid);
        }
    }
    c.rect(x0 - 1, y0 - 1, x1 + 1, y1 + 1, kBlack);
    int widest = 0;
    for (double v : xt) {
        const int px = static_cast<int>(std::lround(sx(v)));
        c.fill_rect(px, y1, px + 1, y1 + 5, kBlack);
        const std::string s = tick_label(v);
        c.text(px - Canvas::text_width(s) / 2, y1 + 8, s, kBlack);
    }
    for (double v : yt) {
        const int py = static_cast<int>(std::lround(sy(v)));
        c.fill_rect(x0 - 5, py, x0, py + 1, kBlack);
        const std::string s = tick_label(v);
        widest = std::max(widest, Canvas::text_width(s));
        c.text(x0 - 8 - Canvas::text_width(s), py - 4, s, kBlack);
    }
    c.text((x0 + x1) / 2 - Canvas::text_width(xlabel, 2) / 2, y1 + 24, xlabel, kBlack, 2);
    c.text_up(x0 - 14 - widest - Canvas::text_height(2),
              (y0 + y1) / 2 + Canvas::text_width(ylabel, 2) / 2, ylabel, kBlack, 2);
}

}  // namespace

void render_line_plot(const LinePlot& plot, const std::string& path) {
    double xlo = std::numeric_limits<double>::infinity(), xhi = -xlo, ylo = xlo, yhi = -xlo;
    for (const Curve& cv : plot.curves) {
        for (std::size_t k = 0; k < cv.x.size(); ++k) {
            if (!std::isfinite(cv.x[k]) || !std::isfinite(cv.y[k])) continue;
            xlo = std::min(xlo, cv.x[k]), xhi = std::max(xhi, cv.x[k]);
            ylo = std::min(ylo, cv.y[k]), yhi = std::max(yhi, cv.y[k]);
        }
    }
    if (!std::isfinite(xlo)) throw InputError("plot '" + path + "': nothing finite to plot");
    widen(xlo, xhi);
    widen(ylo, yhi);
    const double ypad = 0.04 * (yhi - ylo);
    ylo -= ypad;
    yhi += ypad;

    bool legend = false;
    std::size_t longest = plot.legend_title.size();
    for (const Curve& cv : plot.curves)
        if (!cv.label.empty()) legend = true, longest = std::max(longest, cv.label.size());
    const int legend_w = legend ? 40 + static_cast<int>(longest) * kCellW : 0;

    Canvas c(plot.width, plot.height, kWhite);
    const int x0 = 100, y0 = 60, x1 = plot.width - 30 - legend_w, y1 = plot.height - 70;
    const Scale sx{xlo, xhi, double(x0), double(x1 - 1)};
    const Scale sy{ylo, yhi, double(y1 - 1), double(y0)};
    draw_titles(c, plot.title, plot.subtitle);
    draw_axes(c, x0, y0, x1, y1, sx, sy, plot.xlabel, plot.ylabel, true);

    for (std::size_t k = 0; k < plot.curves.size(); ++k) {
        const Curve& cv = plot.curves[k];
        const Rgb col = curve_colour(k);
        for (std::size_t i = 1; i < cv.x.size(); ++i)
            if (std::isfinite(cv.y[i - 1]) && std::isfinite(cv.y[i]))
                c.line(sx(cv.x[i - 1]), sy(cv.y[i - 1]), sx(cv.x[i]), sy(cv.y[i]), col, 2);
        for (std::size_t i = 0; i < cv.mx.size(); ++i) {
            if (!std::isfinite(cv.my[i])) continue;
            const int px = static_cast<int>(std::lround(sx(cv.mx[i])));
            const int py = static_cast<int>(std::lround(sy(cv.my[i])));
            c.rect(px - 3, py - 3, px + 4, py + 4, col);
        }
    }
    if (legend) {
        int ly = y0 + 4;
        const int lx = x1 + 16;
        if (!plot.legend_title.empty()) {
            c.text(lx, ly, plot.legend_title, kBlack);
            ly += kCellH + 6;
        }
        for (std::size_t k = 0; k < plot.curves.size(); ++k) {
            if (plot.curves[k].label.empty()) continue;
            c.fill_rect(lx, ly + 3, lx + 20, ly + 5, curve_colour(k));
            c.text(lx + 26, ly, plot.curves[k].label, kBlack);
            ly += kCellH + 5;
        }
    }
    c.write_png(path);
}

void render_map_plot(const MapPlot& plot, const std::string& path) {
    Canvas c(plot.width, plot.height, kWhite);
    const int x0 = 100, y0 = 60, x1 = plot.width - 170, y1 = plot.height - 70;
    const int nx = x1 - x0, ny = y1 - y0;
    // Pixel centres sample the data ranges; the first and last pixel of each
    // row/column sit exactly on the range ends.
    std::vector<double> z(static_cast<std::size_t>(nx) * ny);
    double zlo = std::numeric_limits<double>::infinity(), zhi = -zlo;
    for (int j = 0; j < ny; ++j) {
        const double y = plot.y1 + (plot.y0 - plot.y1) * j / std::max(ny - 1, 1);
        for (int i = 0; i < nx; ++i) {
            const double x = plot.x0 + (plot.x1 - plot.x0) * i / std::max(nx - 1, 1);
            const double v = plot.value(x, y);
            z[static_cast<std::size_t>(j) * nx + i] = v;
            if (std::isfinite(v)) zlo = std::min(zlo, v), zhi = std::max(zhi, v);
        }
    }
    if (!std::isfinite(zlo)) throw InputError("plot '" + path + "': nothing finite to plot");
    widen(zlo, zhi);
    for (int j = 0; j < ny; ++j)
        for (int i = 0; i < nx; ++i) {
            const double v = z[static_cast<std::size_t>(j) * nx + i];
            c.pixel(x0 + i, y0 + j, colour_ramp((v - zlo) / (zhi - zlo)));
        }
    const Scale sx{plot.x0, plot.x1, double(x0), double(x1 - 1)};
    const Scale sy{plot.y0, plot.y1, double(y1 - 1), double(y0)};
    draw_titles(c, plot.title, plot.subtitle);
    draw_axes(c, x0, y0, x1, y1, sx, sy, plot.xlabel, plot.ylabel, false);

    // Colour bar with its own ticks.
    const int bx0 = x1 + 30, bx1 = bx0 + 24;
    for (int j = y0; j < y1; ++j)
        c.fill_rect(bx0, j, bx1, j + 1, colour_ramp(double(y1 - 1 - j) / (y1 - y0 - 1)));
    c.rect(bx0 - 1, y0 - 1, bx1 + 1, y1 + 1, kBlack);
    const Scale sz{zlo, zhi, double(y1 - 1), double(y0)};
    for (double v : nice_ticks(zlo, zhi, 6)) {
        const int py = static_cast<int>(std::lround(sz(v)));
        c.fill_rect(bx1, py, bx1 + 5, py + 1, kBlack);
        c.text(bx1 + 8, py - 4, tick_label(v), kBlack);
    }
    c.text(bx0 - 10, y0 - 16, plot.zlabel, kBlack);
    c.write_png(path);
}

}  // namespace brdftab::cli
