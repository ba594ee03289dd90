// evaluate.cpp — named points to kernel points and one engine run
// (evaluate.h).
#include "host/engine/evaluate.h"

#include <algorithm>
#include <utility>

#include "host/core/error.h"

namespace brdftab {

NamedInputs::NamedInputs(const ModelInfo& model, const QuantityInfo& quantity, std::string what)
    : model_(model), builder_(model, quantity), what_(std::move(what)) {}

void NamedInputs::add(const std::string& name, const std::string& text) {
    if (model_.find_option(name)) {
        option_values_[name] = text;
        return;
    }
    const double v = parse_number(text, what_ + " '" + name + "'");
    const std::string problem = builder_.check(name, v);
    if (!problem.empty()) throw InputError(what_ + " '" + name + "=" + text + "': " + problem);
    values_[name] = v;
}

std::vector<int> NamedInputs::options() const {
    return resolve_options(model_, option_values_, what_);
}

PointFile read_model_point_file(const std::string& path, const ModelInfo& model,
                                const QuantityInfo& quantity) {
    const PointBuilder builder(model, quantity);
    PointFileRules rules;
    rules.column_problem = [&](const std::string& column) {
        if (is_direction_coordinate(column) || model.find_parameter(column)) return std::string();
        return "is not a coordinate or parameter of '" + model.name + "'";
    };
    rules.value_problem = [&](const std::string& column, double value) {
        return builder.check(column, value);
    };
    return read_point_file(path, rules);
}

std::vector<double> build_kernel_points(const ModelInfo& model, const QuantityInfo& quantity,
                                        const std::vector<std::map<std::string, double>>& points,
                                        const std::function<std::string(std::size_t)>& label) {
    const PointBuilder builder(model, quantity);
    const std::size_t stride = model.point_stride();
    std::vector<double> out(points.size() * stride);
    for (std::size_t k = 0; k < points.size(); ++k) {
        try {
            builder.build(points[k], &out[k * stride]);
        } catch (const InputError& e) {
            throw InputError(label(k) + ": " + e.what());
        }
    }
    return out;
}

EstimateResult estimate_at(Backend& backend, const ModelInfo& model,
                           const QuantityInfo& quantity, const std::vector<int>& options,
                           const std::vector<double>& kernel_points,
                           const IntegrationSettings& settings, const ProgressFn& progress) {
    const std::size_t stride = model.point_stride();
    const PointsFn points_of = [&](std::size_t first, std::size_t count, double* out) {
        std::copy_n(kernel_points.data() + first * stride, count * stride, out);
    };
    return estimate(backend, model, quantity, options, kernel_points.size() / stride, points_of,
                    settings, progress);
}

}  // namespace brdftab
