// scene_internal.h — the readers behind read_scene_materials() (scene.h).
#pragma once

#include <string>
#include <vector>

#include "host/scene/scene.h"

namespace brdftab::scene_detail {

// The text of a scene file, or InputError naming it; `depth` counts the
// includes that led here (more than 32: an include cycle, refused).
std::string read_scene_text(const std::string& path, int depth, const char* include_directive);

std::vector<SceneMaterial> read_pbrt_scene(const std::string& path);
std::vector<SceneMaterial> read_mitsuba_scene(const std::string& path);
std::vector<SceneMaterial> read_native_materials(const std::string& path);

// The range of values an image texture holds (first channel; 8- and 16-bit
// PNG, or OpenEXR).  `encoding`: "linear", "sRGB" or "gamma G" (how 8/16-bit
// values map to [0, 1]; EXR values are used as stored).  A file that does not
// exist gives missing = true; an unreadable one throws InputError.
struct ImageRange {
    bool missing = false;
    double min = 0, max = 0;
};
ImageRange image_value_range(const std::string& file, const std::string& encoding);

}  // namespace brdftab::scene_detail
