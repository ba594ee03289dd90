// opencl_runtime.cpp — device discovery/selection, context + queue, and
// program building with errors that carry everything needed to act on them.
//
// Discovery and program building use the C API directly: cl.hpp turns a
// missing ICD (-1001) into an anonymous cl::Error and hides the build log in
// a per-device vector, while here we want a specific message for each case.
// Whatever cl.hpp still throws is translated into OpenCLError by guarded().
#include "host/engine/opencl_runtime.h"

#include "host/engine/engine_tuning.h"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <sstream>

namespace brdftab {

namespace {

constexpr std::size_t kMaxLogInMessage = 64 * 1024;

std::string compose_message(const std::string& call, int code, const std::string& detail,
                            const std::string& build_log, const std::string& build_options) {
    std::string msg = call + " failed: " + cl_error_name(code) + " (" + std::to_string(code) + ")";
    if (!detail.empty()) msg += ": " + detail;
    if (!build_options.empty()) msg += "\nbuild options: " + build_options;
    if (!build_log.empty()) {
        msg += "\nbuild log:\n";
        if (build_log.size() > kMaxLogInMessage) {
            // The first diagnostics are the ones that explain the failure;
            // later ones are usually consequences.  build_log() keeps it all.
            msg += build_log.substr(0, kMaxLogInMessage);
            msg += "\n[build log trimmed: " + std::to_string(build_log.size()) +
                   " bytes in total, first " + std::to_string(kMaxLogInMessage) + " shown]";
        } else {
            msg += build_log;
        }
    }
    return msg;
}

// Runs f(), turning a cl::Error from the C++ bindings into OpenCLError.
template <class F>
auto guarded(const std::string& context, F&& f) -> decltype(f()) {
    try {
        return f();
    } catch (const cl::Error& e) {
        throw OpenCLError(e.what() ? e.what() : "OpenCL call", e.err(), context);
    }
}

std::string lower(std::string s) {
    std::transform(s.begin(), s.end(), s.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    return s;
}

std::string trim(const std::string& s) {
    std::size_t b = s.find_first_not_of(" \t\r\n");
    if (b == std::string::npos) return "";
    std::size_t e = s.find_last_not_of(" \t\r\n");
    return s.substr(b, e - b + 1);
}

// OpenCL info strings may carry a trailing NUL and padding.
std::string clean(std::string s) {
    while (!s.empty() && (s.back() == '\0' || s.back() == ' ')) s.pop_back();
    return s;
}

bool has_extension(const std::string& extensions, const std::string& name) {
    std::istringstream in(extensions);
    std::string token;
    while (in >> token)
        if (token == name) return true;
    return false;
}

std::string no_device_message(const std::string& why) {
    return "no OpenCL device was found (" + why +
           "). On Debian/Ubuntu, `apt-get install pocl-opencl-icd` provides a CPU device; "
           "also check that /etc/OpenCL/vendors contains an .icd file for an installed driver "
           "(OCL_ICD_VENDORS overrides that directory).";
}

std::string device_listing(const std::vector<DeviceInfo>& devices) {
    std::string s;
    for (const auto& d : devices)
        s += "\n  [" + std::to_string(d.index) + "] " + d.name + " (" + d.platform_name + ")";
    return s;
}

}  // namespace

OpenCLError::OpenCLError(const std::string& call, int code, const std::string& detail,
                         const std::string& build_log, const std::string& build_options)
    : Error(compose_message(call, code, detail, build_log, build_options)),
      call_(call),
      code_(code),
      build_log_(build_log),
      build_options_(build_options) {}

const char* cl_error_name(int code) {
    switch (code) {
        // OpenCL 1.2 runtime and compiler errors (cl.h).
        case 0: return "CL_SUCCESS";
        case -1: return "CL_DEVICE_NOT_FOUND";
        case -2: return "CL_DEVICE_NOT_AVAILABLE";
        case -3: return "CL_COMPILER_NOT_AVAILABLE";
        case -4: return "CL_MEM_OBJECT_ALLOCATION_FAILURE";
        case -5: return "CL_OUT_OF_RESOURCES";
        case -6: return "CL_OUT_OF_HOST_MEMORY";
        case -7: return "CL_PROFILING_INFO_NOT_AVAILABLE";
        case -8: return "CL_MEM_COPY_OVERLAP";
        case -9: return "CL_IMAGE_FORMAT_MISMATCH";
        case -10: return "CL_IMAGE_FORMAT_NOT_SUPPORTED";
        case -11: return "CL_BUILD_PROGRAM_FAILURE";
        case -12: return "CL_MAP_FAILURE";
        case -13: return "CL_MISALIGNED_SUB_BUFFER_OFFSET";
        case -14: return "CL_EXEC_STATUS_ERROR_FOR_EVENTS_IN_WAIT_LIST";
        case -15: return "CL_COMPILE_PROGRAM_FAILURE";
        case -16: return "CL_LINKER_NOT_AVAILABLE";
        case -17: return "CL_LINK_PROGRAM_FAILURE";
        case -18: return "CL_DEVICE_PARTITION_FAILED";
        case -19: return "CL_KERNEL_ARG_INFO_NOT_AVAILABLE";
        case -30: return "CL_INVALID_VALUE";
        case -31: return "CL_INVALID_DEVICE_TYPE";
        case -32: return "CL_INVALID_PLATFORM";
        case -33: return "CL_INVALID_DEVICE";
        case -34: return "CL_INVALID_CONTEXT";
        case -35: return "CL_INVALID_QUEUE_PROPERTIES";
        case -36: return "CL_INVALID_COMMAND_QUEUE";
        case -37: return "CL_INVALID_HOST_PTR";
        case -38: return "CL_INVALID_MEM_OBJECT";
        case -39: return "CL_INVALID_IMAGE_FORMAT_DESCRIPTOR";
        case -40: return "CL_INVALID_IMAGE_SIZE";
        case -41: return "CL_INVALID_SAMPLER";
        case -42: return "CL_INVALID_BINARY";
        case -43: return "CL_INVALID_BUILD_OPTIONS";
        case -44: return "CL_INVALID_PROGRAM";
        case -45: return "CL_INVALID_PROGRAM_EXECUTABLE";
        case -46: return "CL_INVALID_KERNEL_NAME";
        case -47: return "CL_INVALID_KERNEL_DEFINITION";
        case -48: return "CL_INVALID_KERNEL";
        case -49: return "CL_INVALID_ARG_INDEX";
        case -50: return "CL_INVALID_ARG_VALUE";
        case -51: return "CL_INVALID_ARG_SIZE";
        case -52: return "CL_INVALID_KERNEL_ARGS";
        case -53: return "CL_INVALID_WORK_DIMENSION";
        case -54: return "CL_INVALID_WORK_GROUP_SIZE";
        case -55: return "CL_INVALID_WORK_ITEM_SIZE";
        case -56: return "CL_INVALID_GLOBAL_OFFSET";
        case -57: return "CL_INVALID_EVENT_WAIT_LIST";
        case -58: return "CL_INVALID_EVENT";
        case -59: return "CL_INVALID_OPERATION";
        case -60: return "CL_INVALID_GL_OBJECT";
        case -61: return "CL_INVALID_BUFFER_SIZE";
        case -62: return "CL_INVALID_MIP_LEVEL";
        case -63: return "CL_INVALID_GLOBAL_WORK_SIZE";
        case -64: return "CL_INVALID_PROPERTY";
        case -65: return "CL_INVALID_IMAGE_DESCRIPTOR";
        case -66: return "CL_INVALID_COMPILER_OPTIONS";
        case -67: return "CL_INVALID_LINKER_OPTIONS";
        case -68: return "CL_INVALID_DEVICE_PARTITION_COUNT";
        // OpenCL 2.x codes a newer ICD loader or driver may still return.
        case -69: return "CL_INVALID_PIPE_SIZE";
        case -70: return "CL_INVALID_DEVICE_QUEUE";
        case -71: return "CL_INVALID_SPEC_ID";
        case -72: return "CL_MAX_SIZE_RESTRICTION_EXCEEDED";
        // Extensions seen in practice.
        case -1000: return "CL_INVALID_GL_SHAREGROUP_REFERENCE_KHR";
        case -1001: return "CL_PLATFORM_NOT_FOUND_KHR";
        case -1057: return "CL_DEVICE_PARTITION_FAILED_EXT";
        case -1058: return "CL_INVALID_PARTITION_COUNT_EXT";
        case -1059: return "CL_INVALID_PARTITION_NAME_EXT";
        default: return "CL_UNKNOWN_ERROR";
    }
}

std::vector<DeviceInfo> list_devices() {
    cl_uint n_platforms = 0;
    cl_int err = clGetPlatformIDs(0, nullptr, &n_platforms);
    if (err == CL_PLATFORM_NOT_FOUND_KHR || (err == CL_SUCCESS && n_platforms == 0))
        throw Error(no_device_message("no OpenCL platform is installed"));
    if (err != CL_SUCCESS) throw OpenCLError("clGetPlatformIDs", err);

    std::vector<cl_platform_id> platform_ids(n_platforms);
    err = clGetPlatformIDs(n_platforms, platform_ids.data(), nullptr);
    if (err != CL_SUCCESS) throw OpenCLError("clGetPlatformIDs", err);

    std::vector<DeviceInfo> result;
    for (std::size_t p = 0; p < platform_ids.size(); ++p) {
        // retainObject=false: platform ids are not reference counted.
        cl::Platform platform(platform_ids[p]);
        std::string platform_name = guarded("platform name", [&] {
            return clean(platform.getInfo<CL_PLATFORM_NAME>());
        });

        cl_uint n_devices = 0;
        err = clGetDeviceIDs(platform_ids[p], CL_DEVICE_TYPE_ALL, 0, nullptr, &n_devices);
        if (err == CL_DEVICE_NOT_FOUND || (err == CL_SUCCESS && n_devices == 0)) continue;
        if (err != CL_SUCCESS)
            throw OpenCLError("clGetDeviceIDs", err, "platform '" + platform_name + "'");
        std::vector<cl_device_id> device_ids(n_devices);
        err = clGetDeviceIDs(platform_ids[p], CL_DEVICE_TYPE_ALL, n_devices, device_ids.data(),
                             nullptr);
        if (err != CL_SUCCESS)
            throw OpenCLError("clGetDeviceIDs", err, "platform '" + platform_name + "'");

        for (cl_device_id id : device_ids) {
            DeviceInfo info;
            info.index = result.size();
            info.platform_index = p;
            info.platform_name = platform_name;
            // Root devices from clGetDeviceIDs are not reference counted.
            info.device = cl::Device(id);
            guarded("querying device information", [&] {
                const cl::Device& d = info.device;
                info.name = clean(d.getInfo<CL_DEVICE_NAME>());
                info.vendor = clean(d.getInfo<CL_DEVICE_VENDOR>());
                info.version = clean(d.getInfo<CL_DEVICE_VERSION>());
                info.driver_version = clean(d.getInfo<CL_DRIVER_VERSION>());
                cl_device_type type = d.getInfo<CL_DEVICE_TYPE>();
                info.is_cpu = (type & CL_DEVICE_TYPE_CPU) != 0;
                info.is_gpu = (type & CL_DEVICE_TYPE_GPU) != 0;
                info.global_mem_bytes = d.getInfo<CL_DEVICE_GLOBAL_MEM_SIZE>();
                info.max_alloc_bytes = d.getInfo<CL_DEVICE_MAX_MEM_ALLOC_SIZE>();
                info.compute_units = d.getInfo<CL_DEVICE_MAX_COMPUTE_UNITS>();
                info.max_work_group_size = d.getInfo<CL_DEVICE_MAX_WORK_GROUP_SIZE>();
                info.has_fp64 = has_extension(d.getInfo<CL_DEVICE_EXTENSIONS>(), "cl_khr_fp64");
                return 0;
            });
            if (!info.has_fp64) {
                // OpenCL 1.2 devices report doubles through the FP config even
                // when the extension string omits cl_khr_fp64.  The query is
                // optional before 1.2, so an error just means "no fp64".
                cl_device_fp_config fp = 0;
                if (clGetDeviceInfo(id, CL_DEVICE_DOUBLE_FP_CONFIG, sizeof fp, &fp, nullptr) ==
                    CL_SUCCESS)
                    info.has_fp64 = fp != 0;
            }
            result.push_back(std::move(info));
        }
    }
    if (result.empty())
        throw Error(no_device_message(std::to_string(n_platforms) +
                                      " OpenCL platform(s) installed, but none has a device"));
    return result;
}

DeviceInfo select_device(const std::string& selector_in) {
    std::vector<DeviceInfo> devices = list_devices();

    std::string selector = trim(selector_in);
    std::string source = "device selector";
    if (selector.empty()) {
        const char* env = environment_setting("BRDFTAB_DEVICE");
        if (env && !trim(env).empty()) {
            selector = trim(env);
            source = "BRDFTAB_DEVICE";
        } else {
            for (const auto& d : devices)
                if (d.is_cpu) return d;
            return devices.front();
        }
    }

    if (std::all_of(selector.begin(), selector.end(),
                    [](unsigned char c) { return std::isdigit(c) != 0; })) {
        // More than 9 digits cannot be a valid index; checking the length
        // first keeps stoul from throwing out_of_range on absurd numbers.
        const bool overflow = selector.size() > 9;
        std::size_t index = overflow ? 0 : std::stoul(selector);
        if (overflow || index >= devices.size())
            throw InputError(source + " '" + selector + "': device index out of range (0.." +
                             std::to_string(devices.size() - 1) + "); available devices:" +
                             device_listing(devices));
        return devices[index];
    }

    const std::string needle = lower(selector);
    for (const auto& d : devices)
        if (lower(d.name).find(needle) != std::string::npos ||
            lower(d.platform_name).find(needle) != std::string::npos)
            return d;
    throw InputError(source + " '" + selector +
                     "' matches no OpenCL device (give an index or a case-insensitive part of "
                     "the device or platform name); available devices:" +
                     device_listing(devices));
}

ClRuntime::ClRuntime(const DeviceInfo& device) : info_(device) {
    guarded("creating a context and queue on '" + device.name + "'", [&] {
        context_ = cl::Context(info_.device);
        queue_ = cl::CommandQueue(context_, info_.device, 0);
        return 0;
    });
}

cl::Program ClRuntime::build_program(const std::string& source, const std::string& options) {
    const char* text = source.c_str();
    const std::size_t length = source.size();
    cl_int err = CL_SUCCESS;
    cl_program raw = clCreateProgramWithSource(context_(), 1, &text, &length, &err);
    if (err != CL_SUCCESS) throw OpenCLError("clCreateProgramWithSource", err, "", "", options);
    // Owns `raw` from here on (retainObject=false), so every exit releases it.
    cl::Program program(raw);

    cl_device_id dev = info_.device();
    err = clBuildProgram(raw, 1, &dev, options.c_str(), nullptr, nullptr);
    if (err != CL_SUCCESS) {
        std::string log;
        std::size_t log_size = 0;
        if (clGetProgramBuildInfo(raw, dev, CL_PROGRAM_BUILD_LOG, 0, nullptr, &log_size) ==
                CL_SUCCESS &&
            log_size > 0) {
            log.resize(log_size);
            if (clGetProgramBuildInfo(raw, dev, CL_PROGRAM_BUILD_LOG, log_size, &log[0],
                                      nullptr) != CL_SUCCESS)
                log.clear();
        }
        log = trim(clean(log));
        if (log.empty()) log = "(the driver returned no build log)";
        throw OpenCLError("clBuildProgram", err, "device '" + info_.name + "'", log,
                          options.empty() ? "(none)" : options);
    }
    return program;
}

}  // namespace brdftab
