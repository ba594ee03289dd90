// kernel_sources.h — kernel sources embedded in the binary at build time.
//
// The build (cmake/EmbedKernels.cmake) stores every file under kernels/ in a
// generated translation unit.  load_kernel_source() resolves `#include "..."`
// directives recursively (relative to the including file, each file included
// once), emitting `#line N "kernels/<path>"` markers so compiler messages name
// the real file and line.  With a non-empty kernel_dir the files are read from
// disk instead (development: edit kernels without rebuilding).
#pragma once

#include <string>
#include <vector>

namespace brdftab {

std::vector<std::string> embedded_kernel_files();  // paths relative to kernels/
std::string load_kernel_source(const std::string& relative_path,
                               const std::string& kernel_dir = "");

}  // namespace brdftab
