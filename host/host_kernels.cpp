// host_kernels.cpp — compiles the models' kernel math as C++ for the serial
// reference path.  Each wrapper has external linkage so the registry can take
// its address; the math itself is the very code the OpenCL kernels run.
#include "../kernels/common/compat.h"
#include "../kernels/common/sampler.h"

#if __has_include("../kernels/models/rough_dielectric.h")
#include "../kernels/models/rough_dielectric.h"
#define BT_HAVE_ROUGH_DIELECTRIC 1
#endif

#include "error.h"

namespace brdftab::detail {

REAL host_rough_dielectric_sample(const REAL* point, const int* options, int quantity,
                                  const bt_sampler* sampler) {
#ifdef BT_HAVE_ROUGH_DIELECTRIC
    return rough_dielectric_sample(point, options, quantity, sampler);
#else
    (void)point, (void)options, (void)quantity, (void)sampler;
    throw Error("rough-dielectric kernel math not built");
#endif
}

}  // namespace brdftab::detail
