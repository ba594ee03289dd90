// test_opencl_runtime.cpp — device discovery/selection, include resolution
// with #line markers (checked end to end through the OpenCL compiler's own
// diagnostics), program building and errors, and double precision on device.
//
// Oracles: the OpenCL headers' own error-code macros, the kernel files on
// disk, expected sources written out by hand from the include rules, the
// compiler's file:line in its build log, host libm results, and the closed
// form sum_{k>=1} 1/k^2 = pi^2/6.
#include <doctest/doctest.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include "host/engine/kernel_sources.h"
#include "host/engine/opencl_runtime.h"
#include "test_support.h"

using namespace brdftab;
namespace fs = std::filesystem;

namespace {

// PoCL crashes on an unwritable cache directory.  CTest
// sets POCL_CACHE_DIR; when the binary is run by hand, point it at the build
// tree before the first OpenCL call.
const bool pocl_cache_ready = test::default_pocl_cache(BT_BINARY_DIR);

std::string read_file(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::ostringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

void write_file(const fs::path& p, const std::string& text) {
    fs::create_directories(p.parent_path());
    std::ofstream out(p, std::ios::binary);
    out << text;
}

std::string lower(std::string s) {
    for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return s;
}
std::string upper(std::string s) {
    for (auto& c : s) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    return s;
}

std::size_t count_of(const std::string& hay, const std::string& needle) {
    std::size_t n = 0;
    for (std::size_t p = hay.find(needle); p != std::string::npos; p = hay.find(needle, p + 1)) ++n;
    return n;
}

// A fresh directory under the build tree, removed at scope exit.
struct TempDir {
    fs::path path;
    explicit TempDir(const std::string& tag) {
        path = fs::path(BT_BINARY_DIR) / "test-tmp" /
               (tag + "-" + std::to_string(static_cast<long>(::getpid())));
        fs::remove_all(path);
        fs::create_directories(path);
    }
    ~TempDir() {
        std::error_code ec;
        fs::remove_all(path, ec);
    }
};

// Restores BRDFTAB_DEVICE when a test that changes it ends.
struct EnvGuard {
    bool had;
    std::string old;
    EnvGuard() {
        const char* v = std::getenv("BRDFTAB_DEVICE");
        had = v != nullptr;
        if (had) old = v;
    }
    ~EnvGuard() {
        if (had)
            setenv("BRDFTAB_DEVICE", old.c_str(), 1);
        else
            unsetenv("BRDFTAB_DEVICE");
    }
};

DeviceInfo cpu_device() {
    for (const auto& d : list_devices())
        if (d.is_cpu) return d;
    FAIL("no CPU OpenCL device");
    return {};
}

// Builds `source`, expecting failure; returns the error.
OpenCLError build_failure(ClRuntime& rt, const std::string& source, const std::string& options) {
    try {
        rt.build_program(source, options);
    } catch (const OpenCLError& e) {
        return e;
    }
    FAIL("build unexpectedly succeeded");
    return OpenCLError("none", 0);
}

}  // namespace

TEST_CASE("cl_error_name matches the names in CL/cl.h") {
    REQUIRE(pocl_cache_ready);
    // Stringising the header macros gives an oracle independent of our table.
#define BT_CODE(x) std::make_pair(static_cast<int>(x), std::string(#x))
    const std::vector<std::pair<int, std::string>> codes = {
        BT_CODE(CL_SUCCESS), BT_CODE(CL_DEVICE_NOT_FOUND), BT_CODE(CL_DEVICE_NOT_AVAILABLE),
        BT_CODE(CL_COMPILER_NOT_AVAILABLE), BT_CODE(CL_MEM_OBJECT_ALLOCATION_FAILURE),
        BT_CODE(CL_OUT_OF_RESOURCES), BT_CODE(CL_OUT_OF_HOST_MEMORY),
        BT_CODE(CL_PROFILING_INFO_NOT_AVAILABLE), BT_CODE(CL_MEM_COPY_OVERLAP),
        BT_CODE(CL_IMAGE_FORMAT_MISMATCH), BT_CODE(CL_IMAGE_FORMAT_NOT_SUPPORTED),
        BT_CODE(CL_BUILD_PROGRAM_FAILURE), BT_CODE(CL_MAP_FAILURE),
        BT_CODE(CL_MISALIGNED_SUB_BUFFER_OFFSET),
        BT_CODE(CL_EXEC_STATUS_ERROR_FOR_EVENTS_IN_WAIT_LIST),
        BT_CODE(CL_COMPILE_PROGRAM_FAILURE), BT_CODE(CL_LINKER_NOT_AVAILABLE),
        BT_CODE(CL_LINK_PROGRAM_FAILURE), BT_CODE(CL_DEVICE_PARTITION_FAILED),
        BT_CODE(CL_KERNEL_ARG_INFO_NOT_AVAILABLE), BT_CODE(CL_INVALID_VALUE),
        BT_CODE(CL_INVALID_DEVICE_TYPE), BT_CODE(CL_INVALID_PLATFORM), BT_CODE(CL_INVALID_DEVICE),
        BT_CODE(CL_INVALID_CONTEXT), BT_CODE(CL_INVALID_QUEUE_PROPERTIES),
        BT_CODE(CL_INVALID_COMMAND_QUEUE), BT_CODE(CL_INVALID_HOST_PTR),
        BT_CODE(CL_INVALID_MEM_OBJECT), BT_CODE(CL_INVALID_IMAGE_FORMAT_DESCRIPTOR),
        BT_CODE(CL_INVALID_IMAGE_SIZE), BT_CODE(CL_INVALID_SAMPLER), BT_CODE(CL_INVALID_BINARY),
        BT_CODE(CL_INVALID_BUILD_OPTIONS), BT_CODE(CL_INVALID_PROGRAM),
        BT_CODE(CL_INVALID_PROGRAM_EXECUTABLE), BT_CODE(CL_INVALID_KERNEL_NAME),
        BT_CODE(CL_INVALID_KERNEL_DEFINITION), BT_CODE(CL_INVALID_KERNEL),
        BT_CODE(CL_INVALID_ARG_INDEX), BT_CODE(CL_INVALID_ARG_VALUE), BT_CODE(CL_INVALID_ARG_SIZE),
        BT_CODE(CL_INVALID_KERNEL_ARGS), BT_CODE(CL_INVALID_WORK_DIMENSION),
        BT_CODE(CL_INVALID_WORK_GROUP_SIZE), BT_CODE(CL_INVALID_WORK_ITEM_SIZE),
        BT_CODE(CL_INVALID_GLOBAL_OFFSET), BT_CODE(CL_INVALID_EVENT_WAIT_LIST),
        BT_CODE(CL_INVALID_EVENT), BT_CODE(CL_INVALID_OPERATION), BT_CODE(CL_INVALID_GL_OBJECT),
        BT_CODE(CL_INVALID_BUFFER_SIZE), BT_CODE(CL_INVALID_MIP_LEVEL),
        BT_CODE(CL_INVALID_GLOBAL_WORK_SIZE), BT_CODE(CL_INVALID_PROPERTY),
        BT_CODE(CL_INVALID_IMAGE_DESCRIPTOR), BT_CODE(CL_INVALID_COMPILER_OPTIONS),
        BT_CODE(CL_INVALID_LINKER_OPTIONS), BT_CODE(CL_INVALID_DEVICE_PARTITION_COUNT),
        BT_CODE(CL_PLATFORM_NOT_FOUND_KHR),
    };
#undef BT_CODE
    for (const auto& [code, name] : codes) {
        CAPTURE(code);
        CHECK(std::string(cl_error_name(code)) == name);
    }
    CHECK(std::string(cl_error_name(-12345)) == "CL_UNKNOWN_ERROR");
}

TEST_CASE("OpenCLError message format") {
    OpenCLError plain("clFinish", CL_OUT_OF_RESOURCES, "while waiting for slab 3");
    CHECK(std::string(plain.what()) ==
          "clFinish failed: CL_OUT_OF_RESOURCES (-5): while waiting for slab 3");
    CHECK(plain.call() == "clFinish");
    CHECK(plain.code() == -5);
    CHECK(std::string(OpenCLError("clFlush", -36).what()) ==
          "clFlush failed: CL_INVALID_COMMAND_QUEUE (-36)");

    // A huge log is trimmed in what() but kept whole in build_log().
    std::string log(200 * 1024, 'x');
    log += "THE-END";
    OpenCLError big("clBuildProgram", CL_BUILD_PROGRAM_FAILURE, "", log, "-D A=1");
    const std::string what = big.what();
    CHECK(what.find("-D A=1") != std::string::npos);
    CHECK(what.size() < 70 * 1024);
    CHECK(what.size() > 64 * 1024);
    CHECK(what.find("THE-END") == std::string::npos);
    CHECK(what.find("trimmed") != std::string::npos);
    CHECK(big.build_log() == log);
    CHECK(big.build_options() == "-D A=1");
}

TEST_CASE("list_devices finds a CPU device") {
    const auto devices = list_devices();
    REQUIRE(!devices.empty());
    bool any_cpu = false;
    for (std::size_t i = 0; i < devices.size(); ++i) {
        const auto& d = devices[i];
        CAPTURE(d.name);
        CHECK(d.index == i);
        CHECK(!d.name.empty());
        CHECK(!d.platform_name.empty());
        CHECK(d.device() != nullptr);
        CHECK(d.compute_units >= 1);
        CHECK(d.max_work_group_size >= 1);
        CHECK(d.max_alloc_bytes > 0);
        CHECK(d.max_alloc_bytes <= d.global_mem_bytes);
        // Cross-check the type flag with a direct C API query.
        cl_device_type type = 0;
        REQUIRE(clGetDeviceInfo(d.device(), CL_DEVICE_TYPE, sizeof type, &type, nullptr) ==
                CL_SUCCESS);
        CHECK(d.is_cpu == ((type & CL_DEVICE_TYPE_CPU) != 0));
        any_cpu = any_cpu || d.is_cpu;
    }
    CHECK(any_cpu);
    // PoCL's CPU device has doubles; the double precision
    // test below proves it by computing with them.
    CHECK(cpu_device().has_fp64);
}

TEST_CASE("no OpenCL platform gives the install hint") {
    // The ICD loader reads its vendor list once per process, so the check
    // runs in a child copy of this binary with an empty vendor directory.
    if (std::getenv("BT_CHILD_EXPECT_NO_DEVICE")) {
        try {
            list_devices();
            FAIL("expected Error");
        } catch (const Error& e) {
            std::string msg = e.what();
            CAPTURE(msg);
            CHECK(msg.find("no OpenCL device was found") != std::string::npos);
            CHECK(msg.find("apt-get install pocl-opencl-icd") != std::string::npos);
            CHECK(msg.find("/etc/OpenCL/vendors") != std::string::npos);
        }
        CHECK_THROWS_AS(select_device(""), Error);
        return;
    }
    TempDir empty("no-vendors");
    const std::string cmd = "BT_CHILD_EXPECT_NO_DEVICE=1 OCL_ICD_VENDORS='" +
                            empty.path.string() + "' '" +
                            fs::read_symlink("/proc/self/exe").string() +
                            "' --test-case='no OpenCL platform*' --no-intro=1 >/dev/null 2>&1";
    CHECK(std::system(cmd.c_str()) == 0);
}

TEST_CASE("select_device") {
    EnvGuard guard;
    unsetenv("BRDFTAB_DEVICE");
    const auto devices = list_devices();
    const DeviceInfo cpu = cpu_device();

    SUBCASE("empty selector picks the first CPU device") {
        DeviceInfo d = select_device("");
        CHECK(d.is_cpu);
        CHECK(d.index == cpu.index);
        CHECK(select_device("   ").index == cpu.index);
    }
    SUBCASE("by index") {
        CHECK(select_device("0").index == 0);
        CHECK(select_device(" 0 ").index == 0);
        CHECK(select_device(std::to_string(devices.size() - 1)).index == devices.size() - 1);
    }
    SUBCASE("by case-insensitive substring of device or platform name") {
        // Part of the CPU device's own name, in a different case.
        std::string part = upper(cpu.name.substr(0, std::min<std::size_t>(7, cpu.name.size())));
        DeviceInfo d = select_device(part);
        CHECK(lower(d.name).find(lower(part)) != std::string::npos);
        DeviceInfo p = select_device(upper(cpu.platform_name));
        CHECK(lower(p.platform_name) == lower(cpu.platform_name));
        bool have_pthread = false;
        for (const auto& dev : devices)
            have_pthread = have_pthread || lower(dev.name).find("pthread") != std::string::npos;
        if (have_pthread) {  // PoCL's CPU device is "pthread-<cpu>"
            CHECK(lower(select_device("PThread").name).find("pthread") != std::string::npos);
            CHECK(select_device("pthread").is_cpu);
        }
    }
    SUBCASE("no match lists the devices") {
        try {
            select_device("no-such-device-qzx");
            FAIL("expected InputError");
        } catch (const InputError& e) {
            std::string msg = e.what();
            CHECK(msg.find("no-such-device-qzx") != std::string::npos);
            for (const auto& dev : devices)
                CHECK(msg.find("[" + std::to_string(dev.index) + "] " + dev.name + " (" +
                               dev.platform_name + ")") != std::string::npos);
        }
    }
    SUBCASE("index out of range lists the devices") {
        for (std::string sel : {std::to_string(devices.size()), std::string("123456789012345678901")}) {
            CAPTURE(sel);
            try {
                select_device(sel);
                FAIL("expected InputError");
            } catch (const InputError& e) {
                std::string msg = e.what();
                CHECK(msg.find("out of range") != std::string::npos);
                CHECK(msg.find("[0] " + devices[0].name) != std::string::npos);
            }
        }
    }
}

TEST_CASE("BRDFTAB_DEVICE is honoured only for an empty selector") {
    EnvGuard guard;
    const auto devices = list_devices();
    setenv("BRDFTAB_DEVICE", "no-such-device-qzx", 1);
    try {
        select_device("");
        FAIL("expected InputError");
    } catch (const InputError& e) {
        std::string msg = e.what();
        CHECK(msg.find("BRDFTAB_DEVICE") != std::string::npos);
        CHECK(msg.find("no-such-device-qzx") != std::string::npos);
    }
    // An explicit selector wins over the environment.
    CHECK(select_device("0").index == 0);

    const std::string last = std::to_string(devices.size() - 1);
    setenv("BRDFTAB_DEVICE", last.c_str(), 1);
    CHECK(select_device("").index == devices.size() - 1);
    setenv("BRDFTAB_DEVICE", std::to_string(devices.size()).c_str(), 1);
    CHECK_THROWS_AS(select_device(""), InputError);
}

TEST_CASE("embedded kernel sources mirror kernels/ on disk") {
    const fs::path kernels = fs::path(BT_SOURCE_DIR) / "kernels";
    const auto files = embedded_kernel_files();
    CHECK(std::find(files.begin(), files.end(), "common/compat.h") != files.end());
    CHECK(std::find(files.begin(), files.end(), "common/estimator.h") != files.end());
    for (const auto& f : files) {
        CAPTURE(f);
        CHECK(fs::is_regular_file(kernels / f));
    }
    // compat.h has only <...> includes, which are left alone: the result is
    // the file itself under one marker.
    CHECK(load_kernel_source("common/compat.h") ==
          "#line 1 \"kernels/common/compat.h\"\n" + read_file(kernels / "common/compat.h"));
    // estimator.h includes compat.h and sampler.h (which includes compat.h
    // again): the embedded table and the directory give the same text, and
    // compat.h appears once.
    const std::string est = load_kernel_source("common/estimator.h");
    CHECK(est == load_kernel_source("common/estimator.h", kernels.string()));
    CHECK(count_of(est, "#line 1 \"kernels/common/compat.h\"") == 1);
    CHECK(count_of(est, "#line 1 \"kernels/common/sampler.h\"") == 1);
    CHECK(count_of(est, "#define BRDFTAB_COMPAT_H") == 1);
    CHECK(est.rfind("#line 1 \"kernels/common/estimator.h\"\n", 0) == 0);

    CHECK_THROWS_AS(load_kernel_source("common/no_such_file.h"), Error);
}

TEST_CASE("load_kernel_source resolves quoted includes with #line markers") {
    TempDir dir("includes");
    write_file(dir.path / "a.cl",
               "/* a.cl */\n"
               "#include \"sub/b.h\"\n"
               "#include <untouched.h>\n"
               "  #  include \"c.h\"\n"
               "int a_fn(void) { return 1; }\n");
    write_file(dir.path / "sub/b.h",
               "/* b.h */\n"
               "#include \"../c.h\"\n"
               "#include \"d.h\"\n"
               "#include \"e.h\"\n"
               "int b_fn(void) { return 2; }");  // no final newline
    write_file(dir.path / "c.h", "int c_fn(void) { return 3; }\n");
    write_file(dir.path / "d.h", "int d_fn(void) { return 4; }\n");  // found from the root
    write_file(dir.path / "e.h", "ROOT E\n");                         // shadowed by sub/e.h
    write_file(dir.path / "sub/e.h", "int e_fn(void) { return 5; }\n");

    // Written out by hand from the rules: includer's directory first, then
    // the root; each file once; after an include, resume at the next line.
    const std::string expected =
        "#line 1 \"kernels/a.cl\"\n"
        "/* a.cl */\n"
        "#line 1 \"kernels/sub/b.h\"\n"
        "/* b.h */\n"
        "#line 1 \"kernels/c.h\"\n"
        "int c_fn(void) { return 3; }\n"
        "#line 3 \"kernels/sub/b.h\"\n"
        "#line 1 \"kernels/d.h\"\n"
        "int d_fn(void) { return 4; }\n"
        "#line 4 \"kernels/sub/b.h\"\n"
        "#line 1 \"kernels/sub/e.h\"\n"
        "int e_fn(void) { return 5; }\n"
        "#line 5 \"kernels/sub/b.h\"\n"
        "int b_fn(void) { return 2; }\n"
        "#line 3 \"kernels/a.cl\"\n"
        "#include <untouched.h>\n"
        "/* #include \"c.h\": already included */\n"
        "int a_fn(void) { return 1; }\n";
    CHECK(load_kernel_source("a.cl", dir.path.string()) == expected);
    // A trailing slash on the directory and "./" in the path change nothing.
    CHECK(load_kernel_source("./a.cl", dir.path.string() + "/") == expected);
}

TEST_CASE("include cycles terminate and missing files are reported") {
    TempDir dir("errors");
    write_file(dir.path / "p.h", "P1\n#include \"q.h\"\nP3\n");
    write_file(dir.path / "q.h", "#include \"p.h\"\nQ2\n");
    CHECK(load_kernel_source("p.h", dir.path.string()) ==
          "#line 1 \"kernels/p.h\"\nP1\n#line 1 \"kernels/q.h\"\n"
          "/* #include \"p.h\": already included */\nQ2\n#line 3 \"kernels/p.h\"\nP3\n");

    write_file(dir.path / "x.cl", "// x\n\n#include \"missing.h\"\n");
    try {
        load_kernel_source("x.cl", dir.path.string());
        FAIL("expected an error");
    } catch (const Error& e) {
        std::string msg = e.what();
        CHECK(msg.find("kernels/x.cl:3") != std::string::npos);
        CHECK(msg.find("missing.h") != std::string::npos);
    }
    // Includes cannot climb out of the kernel root, even to a real file.
    write_file(dir.path / "inner/y.cl", "#include \"../../escape.h\"\n");
    write_file(dir.path.parent_path() / "escape.h", "int escaped;\n");
    CHECK_THROWS_AS(load_kernel_source("inner/y.cl", dir.path.string()), Error);
    fs::remove(dir.path.parent_path() / "escape.h");

    CHECK_THROWS_AS(load_kernel_source("nope.cl", dir.path.string()), InputError);
    CHECK_THROWS_AS(load_kernel_source("x.cl", (dir.path / "no-such-dir").string()), InputError);
}

TEST_CASE("#line markers make compiler diagnostics name the real file and line") {
    ClRuntime rt(cpu_device());
    TempDir dir("line");
    // An error on line 3 of an included header.
    write_file(dir.path / "main.cl",
               "// main.cl\n"
               "#include \"inc/bad.h\"\n"
               "__kernel void k(__global int* x) { x[0] = helper(); }\n");
    write_file(dir.path / "inc/bad.h",
               "// bad.h\n"
               "int helper(void) {\n"
               "    return 1 + ;\n"
               "}\n");
    OpenCLError e1 = build_failure(rt, load_kernel_source("main.cl", dir.path.string()), "");
    CAPTURE(e1.build_log());
    CHECK(e1.build_log().find("kernels/inc/bad.h:3:") != std::string::npos);
    CHECK(e1.build_log().find("kernels/main.cl:") == std::string::npos);

    // An error in the includer after a nested include: line 5 of main2.cl.
    write_file(dir.path / "main2.cl",
               "// main2.cl\n"
               "#include \"inc/good.h\"\n"
               "\n"
               "__kernel void k(__global int* x) {\n"
               "    x[0] = good() + undeclared_name_qzx;\n"
               "}\n");
    write_file(dir.path / "inc/good.h",
               "#include \"more.h\"\n"
               "int good(void) { return more(); }\n");
    write_file(dir.path / "inc/more.h", "int more(void) {\n return 7;\n}\n");
    OpenCLError e2 = build_failure(rt, load_kernel_source("main2.cl", dir.path.string()), "");
    CAPTURE(e2.build_log());
    CHECK(e2.build_log().find("kernels/main2.cl:5:") != std::string::npos);
    CHECK(e2.build_log().find("undeclared_name_qzx") != std::string::npos);
}

TEST_CASE("build failure carries call, code, options and log") {
    ClRuntime rt(cpu_device());
    const std::string options = "-D BT_MARKER_QZX=42 -cl-std=CL1.2";
    OpenCLError e = build_failure(rt, "__kernel void k(__global int* x) { x[0] = ; }", options);
    const std::string what = e.what();
    CAPTURE(what);
    CHECK(e.call() == "clBuildProgram");
    CHECK(e.code() == CL_BUILD_PROGRAM_FAILURE);
    CHECK(what.rfind("clBuildProgram failed: CL_BUILD_PROGRAM_FAILURE (-11)", 0) == 0);
    CHECK(what.find(options) != std::string::npos);
    CHECK(e.build_options() == options);
    CHECK(e.build_log().find("error") != std::string::npos);
    CHECK(what.find(e.build_log()) != std::string::npos);

    // Options the compiler rejects are reported the same way.
    OpenCLError bad = build_failure(rt, "__kernel void k(__global int* x) { x[0] = 1; }",
                                    "-this-is-not-an-option-qzx");
    CHECK(bad.call() == "clBuildProgram");
    CHECK(bad.code() != CL_SUCCESS);
    CHECK(std::string(bad.what()).find("-this-is-not-an-option-qzx") != std::string::npos);
}

TEST_CASE("cl.hpp errors surface as OpenCLError") {
    DeviceInfo none;  // no device handle: context creation must fail
    CHECK_THROWS_AS(ClRuntime{none}, OpenCLError);
}

TEST_CASE("a kernel including common/compat.h computes like the host") {
    ClRuntime rt(cpu_device());
    const std::string source = load_kernel_source("common/compat.h") +
                               "__kernel void twice_sqrt(__global const REAL* x,\n"
                               "                         __global REAL* y, uint n) {\n"
                               "    uint i = (uint)get_global_id(0);\n"
                               "    if (i < n) y[i] = sqrt(x[i]) * R(2.0);\n"
                               "}\n";
    cl::Program program = rt.build_program(source, "-D BT_HAS_FP64=1");
    const cl_uint n = 1000;
    std::vector<double> x(n), y(n, -1.0);
    for (cl_uint i = 0; i < n; ++i) x[i] = 0.001 + 3.7 * i + 1e-3 * std::sin(double(i));
    cl::Buffer bx(rt.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, n * sizeof(double),
                  x.data());
    cl::Buffer by(rt.context(), CL_MEM_WRITE_ONLY, n * sizeof(double));
    cl::Kernel kernel(program, "twice_sqrt");
    kernel.setArg(0, bx);
    kernel.setArg(1, by);
    kernel.setArg(2, n);
    rt.queue().enqueueNDRangeKernel(kernel, cl::NullRange, cl::NDRange(n));
    rt.queue().enqueueReadBuffer(by, CL_TRUE, 0, n * sizeof(double), y.data());
    double worst = 0;
    for (cl_uint i = 0; i < n; ++i)
        worst = std::max(worst, std::fabs(y[i] - 2.0 * std::sqrt(x[i])) / (2.0 * std::sqrt(x[i])));
    MESSAGE("max relative difference sqrt(x)*2 device vs host: " << worst);
    // OpenCL requires a correctly rounded double sqrt; *2 is exact.
    CHECK(worst <= 2.3e-16);
}

namespace {
// Sums 1/k^2 for k = n..1 on the device in REAL; returns sizeof(REAL) and the
// sum as double.
std::pair<int, double> device_basel_sum(ClRuntime& rt, const std::string& options,
                                        unsigned n) {
    const std::string source = load_kernel_source("common/compat.h") +
                               "__kernel void basel(uint n, __global REAL* out,\n"
                               "                    __global int* size) {\n"
                               "    REAL s = R(0.0);\n"
                               "    for (uint k = n; k >= 1; --k) s += R(1.0) / ((REAL)k * (REAL)k);\n"
                               "    out[0] = s;\n"
                               "    size[0] = (int)sizeof(REAL);\n"
                               "}\n";
    cl::Program program = rt.build_program(source, options);
    cl::Buffer out(rt.context(), CL_MEM_WRITE_ONLY, sizeof(double));
    cl::Buffer size(rt.context(), CL_MEM_WRITE_ONLY, sizeof(int));
    cl::Kernel kernel(program, "basel");
    kernel.setArg(0, static_cast<cl_uint>(n));
    kernel.setArg(1, out);
    kernel.setArg(2, size);
    rt.queue().enqueueNDRangeKernel(kernel, cl::NullRange, cl::NDRange(1));
    int real_size = 0;
    rt.queue().enqueueReadBuffer(size, CL_TRUE, 0, sizeof(int), &real_size);
    double result = 0;
    if (real_size == 8) {
        rt.queue().enqueueReadBuffer(out, CL_TRUE, 0, sizeof(double), &result);
    } else {
        float f = 0;
        rt.queue().enqueueReadBuffer(out, CL_TRUE, 0, sizeof(float), &f);
        result = f;
    }
    return {real_size, result};
}
}  // namespace

TEST_CASE("REAL is double on device with BT_HAS_FP64=1") {
    ClRuntime rt(cpu_device());
    const unsigned n = 100000;
    // Oracle: sum_{k=1}^{n} 1/k^2 = pi^2/6 - psi'(n+1), with the asymptotic
    // series psi'(m) = 1/m + 1/(2m^2) + 1/(6m^3) - 1/(30m^5) + ...
    // (error < 1/(42 m^7), far below double rounding for m = 1e5+1).
    const double m = n + 1.0;
    const double pi = test::kPi;
    const double exact =
        pi * pi / 6 - (1 / m + 1 / (2 * m * m) + 1 / (6 * m * m * m) - 1 / (30 * m * m * m * m * m));

    auto [size_d, sum_d] = device_basel_sum(rt, "-D BT_HAS_FP64=1", n);
    CHECK(size_d == 8);
    const double err_d = std::fabs(sum_d - exact) / exact;
    MESSAGE("double: relative error of sum 1/k^2 (k<=1e5) = " << err_d);
    CHECK(err_d < 2e-15);

    // The same kernel with REAL = float cannot get close: shows the check
    // above really distinguishes the precisions.
    auto [size_f, sum_f] = device_basel_sum(rt, "-D BT_REAL_IS_FLOAT=1", n);
    CHECK(size_f == 4);
    const double err_f = std::fabs(sum_f - exact) / exact;
    MESSAGE("float:  relative error of sum 1/k^2 (k<=1e5) = " << err_f);
    CHECK(err_f > 1e-9);
    CHECK(err_f < 1e-5);
}
