#include "common/estimator.h"
#include "models/rough_dielectric.h"

BT_DEFINE_ESTIMATE_KERNEL(rough_dielectric_estimate, rough_dielectric_sample)
