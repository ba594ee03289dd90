// Registry entry and host compilation of the lambert_sphere model(s).
// (Not yet implemented: registers nothing.)
#include <vector>

#include "model_registry.h"

namespace brdftab::detail {

void register_lambert_sphere(std::vector<ModelInfo>& models) { (void)models; }

}  // namespace brdftab::detail
