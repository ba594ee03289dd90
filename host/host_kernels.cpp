// host_kernels.cpp — compiles the models' kernel math as C++ for the serial
// reference path.  Each wrapper has external linkage so the registry can take
// its address; the math itself is the very code the OpenCL kernels run.
#include "../kernels/common/compat.h"
#include "../kernels/common/sampler.h"

#include "../kernels/models/rough_dielectric.h"

namespace brdftab::detail {

REAL host_rough_dielectric_sample(const REAL* point, const int* options, int quantity,
                                  const bt_sampler* sampler) {
    return rough_dielectric_sample(point, options, quantity, sampler);
}

}  // namespace brdftab::detail
