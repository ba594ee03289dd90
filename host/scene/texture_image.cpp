// texture_image.cpp — the value range of an image texture, so that a material
// parameter driven by a texture becomes a table axis over exactly the values
// the scene uses.
#include <png.h>
#include <sys/stat.h>

#include <ImfRgbaFile.h>
#include <ImfArray.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "host/core/error.h"
#include "host/scene/scene_internal.h"

namespace brdftab::scene_detail {
namespace {

bool file_exists(const std::string& path) {
    struct stat st;
    return ::stat(path.c_str(), &st) == 0;
}

bool ends_with(const std::string& s, const std::string& suffix) {
    if (s.size() < suffix.size()) return false;
    std::string tail = s.substr(s.size() - suffix.size());
    std::transform(tail.begin(), tail.end(), tail.begin(), ::tolower);
    return tail == suffix;
}

// 8-bit code -> value in [0, 1] under the texture's encoding.
double decode(double v, const std::string& encoding, const std::string& file) {
    if (encoding == "linear") return v;
    if (encoding == "sRGB" || encoding == "srgb") {
        // The sRGB transfer function (IEC 61966-2-1).
        return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
    }
    if (encoding.rfind("gamma ", 0) == 0) {
        char* end = nullptr;
        const double g = std::strtod(encoding.c_str() + 6, &end);
        if (g > 0 && std::isfinite(g) && end && *end == '\0') return std::pow(v, g);
    }
    throw InputError(file + ": texture encoding '" + encoding +
                     "' is not one of linear, sRGB, \"gamma G\"");
}

ImageRange png_range(const std::string& file, const std::string& encoding) {
    png_image image{};
    image.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_file(&image, file.c_str()))
        throw InputError("texture '" + file + "' is not a readable PNG image (" + image.message +
                         ")");
    image.format = PNG_FORMAT_RGBA;  // 8 bits per channel; we use the first channel
    std::vector<png_byte> pixels(PNG_IMAGE_SIZE(image));
    if (!png_image_finish_read(&image, nullptr, pixels.data(), 0, nullptr)) {
        std::string msg = image.message;
        png_image_free(&image);
        throw InputError("texture '" + file + "': " + msg);
    }
    int lo = 255, hi = 0;
    for (std::size_t i = 0; i < pixels.size(); i += 4) {
        lo = std::min<int>(lo, pixels[i]);
        hi = std::max<int>(hi, pixels[i]);
    }
    ImageRange r;
    r.min = decode(lo / 255.0, encoding, file);
    r.max = decode(hi / 255.0, encoding, file);
    return r;
}

ImageRange exr_range(const std::string& file) {
    try {
        Imf::RgbaInputFile in(file.c_str());
        const Imath::Box2i dw = in.dataWindow();
        const long width = dw.max.x - dw.min.x + 1, height = dw.max.y - dw.min.y + 1;
        if (width <= 0 || height <= 0 || width * height > (1L << 28))
            throw InputError("texture '" + file + "': image size out of range");
        Imf::Array2D<Imf::Rgba> pixels(height, width);
        in.setFrameBuffer(&pixels[0][0] - dw.min.x - dw.min.y * width, 1, width);
        in.readPixels(dw.min.y, dw.max.y);
        ImageRange r;
        r.min = std::numeric_limits<double>::infinity();
        r.max = -r.min;
        for (long y = 0; y < height; ++y)
            for (long x = 0; x < width; ++x) {
                const double v = pixels[y][x].r;
                if (!std::isfinite(v)) continue;
                r.min = std::min(r.min, v);
                r.max = std::max(r.max, v);
            }
        if (!(r.min <= r.max)) throw InputError("texture '" + file + "' holds no finite value");
        return r;
    } catch (const InputError&) {
        throw;
    } catch (const std::exception& e) {
        throw InputError("texture '" + file + "' is not a readable OpenEXR image: " + e.what());
    }
}

}  // namespace

ImageRange image_value_range(const std::string& file, const std::string& encoding) {
    if (!file_exists(file)) {
        ImageRange r;
        r.missing = true;
        return r;
    }
    if (ends_with(file, ".exr")) return exr_range(file);
    if (ends_with(file, ".png")) return png_range(file, encoding);
    throw InputError("texture '" + file + "': only PNG and OpenEXR images are read");
}

}  // namespace brdftab::scene_detail
