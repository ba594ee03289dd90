// opencl_runtime.h — OpenCL platforms/devices, context and program building
// with errors that carry the failing call, the error code, and for builds the
// options and the full build log.
#pragma once

#define CL_HPP_TARGET_OPENCL_VERSION 120
#define CL_HPP_MINIMUM_OPENCL_VERSION 120
#define CL_HPP_ENABLE_EXCEPTIONS
#include <CL/opencl.hpp>

#include <cstdint>
#include <string>
#include <vector>

#include "host/core/error.h"

namespace brdftab {

class OpenCLError : public Error {
public:
    OpenCLError(const std::string& call, int code, const std::string& detail = "",
                const std::string& build_log = "", const std::string& build_options = "");
    const std::string& call() const { return call_; }
    int code() const { return code_; }
    const std::string& build_log() const { return build_log_; }
    const std::string& build_options() const { return build_options_; }

private:
    std::string call_;
    int code_;
    std::string build_log_, build_options_;
};

// Symbolic name of an OpenCL error code ("CL_OUT_OF_RESOURCES").
const char* cl_error_name(int code);

struct DeviceInfo {
    std::size_t index = 0;  // position in list_devices()
    std::size_t platform_index = 0;
    std::string platform_name, name, vendor, version, driver_version;
    bool is_cpu = false, is_gpu = false, has_fp64 = false;
    std::uint64_t global_mem_bytes = 0, max_alloc_bytes = 0;
    unsigned compute_units = 0;
    std::size_t max_work_group_size = 0;
    cl::Device device;
};

// All devices of all platforms.  Throws Error with an install hint
// ("apt-get install pocl-opencl-icd") when no platform or device exists.
std::vector<DeviceInfo> list_devices();

// selector: "" -> $BRDFTAB_DEVICE if set, else first CPU device, else first
// device; a number -> that index; otherwise a case-insensitive substring of the
// device or platform name.  Throws InputError naming the available devices.
DeviceInfo select_device(const std::string& selector);

// A context + in-order queue on one device.
class ClRuntime {
public:
    explicit ClRuntime(const DeviceInfo& device);
    const DeviceInfo& device_info() const { return info_; }
    cl::Context& context() { return context_; }
    cl::CommandQueue& queue() { return queue_; }
    // Build `source` (already include-resolved) with `options`.  On failure
    // throws OpenCLError with the build log and options.
    cl::Program build_program(const std::string& source, const std::string& options);

private:
    DeviceInfo info_;
    cl::Context context_;
    cl::CommandQueue queue_;
};

}  // namespace brdftab
