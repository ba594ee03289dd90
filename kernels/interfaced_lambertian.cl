#include "common/estimator.h"
#include "models/interfaced_lambertian.h"

BT_DEFINE_ESTIMATE_KERNEL(interfaced_lambertian_estimate, interfaced_lambertian_sample)
