#include "common/estimator.h"
#include "models/oren_nayar.h"

BT_DEFINE_ESTIMATE_KERNEL(oren_nayar_estimate, oren_nayar_sample)
