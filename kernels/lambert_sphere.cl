#include "common/estimator.h"
#include "models/lambert_sphere.h"

BT_DEFINE_ESTIMATE_KERNEL(lambert_sphere_estimate, lambert_sphere_sample)
