#include "common/estimator.h"
#include "models/hfunction.h"

BT_DEFINE_ESTIMATE_KERNEL(hfunction_estimate, hfunction_sample)
