// derived.h — the tables generate_tables() forms from already computed tables
// of the same spec (internal to host/generate; the spec side is
// host/spec/derived.cpp).
#pragma once

#include <vector>

#include "host/generate/generate.h"

namespace brdftab::generate_detail {

// Each reads its source tables from `done` (the spec's tables generated so
// far) and returns the new table; the spec supplies the storage settings.
GeneratedTable recombine(const RecombinedSpec& rs, const std::vector<GeneratedTable>& done,
                         const Spec& spec);
GeneratedTable compare(const ErrorTableSpec& es, const std::vector<GeneratedTable>& done,
                       const Spec& spec);
GeneratedTable invert(const InvertedSpec& is, const std::vector<GeneratedTable>& done,
                      const Spec& spec);

}  // namespace brdftab::generate_detail
