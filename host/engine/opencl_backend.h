// opencl_backend.h — the OpenCL device backend (engine.h, Backend): the
// launch's inputs written, its kernels enqueued by the first launch strategy
// that applies (host/engine/launch/), its results read; two launches may
// overlap (Backend::start/finish).
#pragma once

#include <memory>
#include <string>

#include "host/engine/engine.h"
#include "host/engine/opencl_runtime.h"

namespace brdftab {

std::unique_ptr<Backend> make_opencl_backend(const DeviceInfo& device, Precision precision,
                                             const std::string& kernel_dir,
                                             const EngineTuning& tuning);

}  // namespace brdftab
