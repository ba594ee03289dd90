// test_kernel_headers.cpp — every header under kernels/common and
// kernels/models compiles on its own, as OpenCL C 1.2 on the device and as
// C++17 on the host, so a header can be included first, alone, by a model, a
// test or the engine.
//
// C++: tests/CMakeLists.txt writes one translation unit per header, holding
// only `#include "kernels/<path>"` and a marker string, into an object library
// linked here; a header that needs something it does not include breaks the
// build.  The test checks that those units cover every header on disk.
// OpenCL: each embedded header, expanded by load_kernel_source as a model
// kernel is, is built with the engine's build options (double and float).
//
// Oracles: the directory listing of kernels/ on disk (not the embedded table
// or the generated list under test), and the OpenCL compiler itself; a
// control source that uses a kernel macro without its header must fail to
// build, so a build check that passes everything would be caught.
#include <doctest/doctest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include "host/engine/kernel_sources.h"
#include "host/engine/opencl_runtime.h"
#include "test_support.h"

// One marker per generated C++ unit, X(symbol); the symbol holds the path of
// the header that unit includes, relative to the repository root.
#define X(symbol) extern const char* const symbol;
#include "kernel_headers_cxx.inc"
#undef X

using namespace brdftab;
namespace fs = std::filesystem;

namespace {

// CTest sets POCL_CACHE_DIR; when the binary is run by hand, point PoCL at
// the build tree (it fails on an unwritable default cache directory).
const bool pocl_cache_ready = test::default_pocl_cache(BT_BINARY_DIR);

// Headers of kernels/common and kernels/models on disk, relative to kernels/.
std::set<std::string> headers_on_disk() {
    std::set<std::string> out;
    const fs::path root = fs::path(BT_SOURCE_DIR) / "kernels";
    for (const char* sub : {"common", "models"})
        for (const auto& entry : fs::directory_iterator(root / sub))
            if (entry.is_regular_file() && entry.path().extension() == ".h")
                out.insert(std::string(sub) + "/" + entry.path().filename().string());
    return out;
}

DeviceInfo cpu_device() {
    for (const auto& d : list_devices())
        if (d.is_cpu) return d;
    FAIL("no CPU OpenCL device");
    return {};
}

// The options the engine builds a model's kernel with (host/engine/launch/resources.cpp,
// LaunchResources::build_options), in double and in float precision.
std::vector<std::string> engine_build_options(const DeviceInfo& device) {
    const std::string base =
        std::string("-cl-std=CL1.2") + (device.has_fp64 ? " -D BT_HAS_FP64=1" : " -D BT_HAS_FP64=0");
    return {base, base + " -D BT_REAL_IS_FLOAT=1"};
}

}  // namespace

TEST_CASE("every kernel header is compiled alone as C++ (generated units cover all)") {
    const std::vector<std::string> compiled = {
#define X(symbol) symbol,
#include "kernel_headers_cxx.inc"
#undef X
    };
    std::set<std::string> covered;
    for (const std::string& path : compiled) {
        CHECK(path.rfind("kernels/", 0) == 0);
        covered.insert(path.substr(std::string("kernels/").size()));
    }
    const std::set<std::string> on_disk = headers_on_disk();
    CHECK(on_disk.size() >= 10);
    for (const std::string& h : on_disk) {
        INFO("header " << h << " (re-run cmake if it is new)");
        CHECK(covered.count(h) == 1);
    }
}

TEST_CASE("every kernel header builds alone as OpenCL C with the engine's options") {
    REQUIRE(pocl_cache_ready);
    const std::set<std::string> on_disk = headers_on_disk();
    std::set<std::string> embedded_headers;
    for (const std::string& f : embedded_kernel_files())
        if (f.size() > 2 && f.compare(f.size() - 2, 2, ".h") == 0) embedded_headers.insert(f);
    // Every header on disk is embedded (so it is built below).
    for (const std::string& h : on_disk) {
        INFO("header " << h);
        CHECK(embedded_headers.count(h) == 1);
    }

    const DeviceInfo device = cpu_device();
    ClRuntime runtime(device);
    const std::vector<std::string> options = engine_build_options(device);

    // Control: a source that uses the kernel vocabulary without including it
    // must fail, or the checks below could not fail either.
    for (const std::string& opt : options)
        CHECK_THROWS_AS(runtime.build_program("BT_INLINE REAL f(void) { return R(1.0); }\n", opt),
                        OpenCLError);

    for (const std::string& h : embedded_headers) {
        const std::string source = load_kernel_source(h);
        for (const std::string& opt : options) {
            INFO("header " << h << ", options " << opt);
            try {
                runtime.build_program(source, opt);
            } catch (const OpenCLError& e) {
                FAIL_CHECK(e.what() << "\n" << e.build_log());
            }
        }
    }
}
