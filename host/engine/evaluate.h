// evaluate.h — estimate a model quantity at points given by name: the inputs
// of `brdftab eval` (name=value arguments, a CSV point file) turned into
// kernel points, and one engine run over all of them.  The caller prints.
#pragma once

#include <cstddef>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "host/engine/engine.h"
#include "host/io/point_file.h"
#include "host/models/registry.h"

namespace brdftab {

// Named inputs gathered one name=value at a time: a name of one of the
// model's options takes the text as its choice; any other name needs a
// number within that coordinate's or parameter's range.  `what` names the
// source in messages: "argument 'alpha': '-1' is not a finite number",
// "argument 'alpha=9': <range problem>".
class NamedInputs {
public:
    NamedInputs(const ModelInfo& model, const QuantityInfo& quantity, std::string what);
    // Throws InputError.
    void add(const std::string& name, const std::string& text);
    const std::map<std::string, double>& values() const { return values_; }
    // Chosen options as kernel ints, defaults for those not given (throws
    // InputError on an unknown choice).
    std::vector<int> options() const;

private:
    const ModelInfo& model_;
    PointBuilder builder_;
    std::string what_;
    std::map<std::string, double> values_;
    nlohmann::json option_values_ = nlohmann::json::object();
};

// A point file whose columns are direction coordinates or parameters of
// `model`, every value within its range (messages: point_file.h).
PointFile read_model_point_file(const std::string& path, const ModelInfo& model,
                                const QuantityInfo& quantity);

// Kernel points, model.point_stride() numbers per point, of named points
// (PointBuilder::build: defaults filled in, cross-parameter checks).  An
// InputError about point k is prefixed with label(k) + ": ".
std::vector<double> build_kernel_points(const ModelInfo& model, const QuantityInfo& quantity,
                                        const std::vector<std::map<std::string, double>>& points,
                                        const std::function<std::string(std::size_t)>& label);

// One estimate() over kernel points from build_kernel_points: one cell each.
EstimateResult estimate_at(Backend& backend, const ModelInfo& model,
                           const QuantityInfo& quantity, const std::vector<int>& options,
                           const std::vector<double>& kernel_points,
                           const IntegrationSettings& settings,
                           const ProgressFn& progress = nullptr);

}  // namespace brdftab
