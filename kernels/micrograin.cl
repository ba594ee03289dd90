#include "common/estimator.h"
#include "models/micrograin.h"

BT_DEFINE_ESTIMATE_KERNEL(micrograin_estimate, micrograin_sample)
