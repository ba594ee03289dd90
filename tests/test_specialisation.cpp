// Specialised kernels (kernels/common/estimator.h, "Specialisation"): the
// engine builds one program per (model, quantity, options, method).  The
// program of every (model, quantity) of every registered model builds, and
// agrees with the serial host path (the same source compiled as C++, no
// specialisation) at points spread over the quantity's directions, with the
// quantity's default method (integrals: both samplers).  The generic program
// (no -D) still builds for every model.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <vector>

#include "host/engine/engine.h"
#include "host/engine/kernel_sources.h"
#include "host/engine/opencl_runtime.h"
#include "host/models/registry.h"
#include "kernels/common/sampler.h"  // BT_METHOD_*

using namespace brdftab;

namespace {

double usable_value(const ParameterInfo& p) {
    if (p.default_value) return *p.default_value;
    return 0.5 * (p.min + p.max);
}

// Three points inside the quantity's domain (upper hemisphere, away from
// grazing) at the model's default parameters.
std::vector<double> test_points(const ModelInfo& m, const QuantityInfo& q) {
    const double thetas[3][3] = {{10, 35, 40}, {45, 60, 135}, {70, 20, -100}};
    const std::size_t stride = m.point_stride();
    std::vector<double> points(3 * stride);
    for (int k = 0; k < 3; ++k) {
        std::map<std::string, double> values;
        for (const ParameterInfo& p : m.parameters) values[p.name] = usable_value(p);
        for (const auto& d : q.directions) {
            if (d == "theta_i") values["theta_i"] = thetas[k][0];
            if (d == "theta_o") values["theta_o"] = thetas[k][1];
            if (d == "phi_o") values["phi_d"] = thetas[k][2];
        }
        PointBuilder(m, q).build(values, &points[k * stride]);
    }
    return points;
}

std::vector<Method> methods_of(const QuantityInfo& q) {
    switch (q.kind) {
        case QuantityKind::ClosedForm: return {Method::ClosedForm};
        case QuantityKind::Quadrature: return {Method::Quadrature, Method::MonteCarlo, Method::Rqmc};
        case QuantityKind::Integral: return {Method::MonteCarlo, Method::Rqmc};
    }
    return {};
}

}  // namespace

TEST_CASE("specialisation options name quantity, method, options and stride") {
    CHECK(specialisation_options(3, {0, 2, 1}, BT_METHOD_RQMC, 7) ==
          " -D BT_SPEC_QUANTITY=3 -D BT_SPEC_METHOD=1 -D BT_SPEC_OPTIONS=0,2,1 -D BT_SPEC_STRIDE=7");
    // No options: the array initialiser still needs an element.
    CHECK(specialisation_options(0, {}, BT_METHOD_CLOSED, 4) ==
          " -D BT_SPEC_QUANTITY=0 -D BT_SPEC_METHOD=2 -D BT_SPEC_OPTIONS=0 -D BT_SPEC_STRIDE=4");
}

TEST_CASE("every (model, quantity, method) specialisation builds and agrees with the host") {
    auto host = make_backend("host", Precision::Double);
    auto device = make_backend("", Precision::Double);
    IntegrationSettings settings;
    settings.samples = 64;
    settings.seed = 11;
    int programs = 0;
    for (const ModelInfo& m : all_models()) {
        const std::vector<int> options = resolve_options(m, nullptr, "test");
        for (const QuantityInfo& q : m.quantities) {
            const std::vector<double> points = test_points(m, q);
            const std::size_t stride = m.point_stride();
            auto point_of = [&](std::size_t cell, double* out) {
                std::copy_n(&points[cell * stride], stride, out);
            };
            // The default method of every quantity, and for integrals the
            // other sampler too (test_engine covers more methods on
            // rough-dielectric); every method of every quantity would double
            // the cold build time of this test.
            std::vector<Method> methods = {q.default_method};
            if (q.kind == QuantityKind::Integral)
                methods = methods_of(q);
            for (Method method : methods) {
                CAPTURE(m.name);
                CAPTURE(q.name);
                CAPTURE(to_string(method));
                settings.method = method;
                const EstimateResult h = estimate(*host, m, q, options, 3, point_of, settings);
                const EstimateResult d = estimate(*device, m, q, options, 3, point_of, settings);
                ++programs;
                for (std::size_t c = 0; c < 3; ++c) {
                    CAPTURE(c);
                    // Same samples, same source: equal up to the rounding of
                    // another compiler (FMA contraction, docs/contributing.md).
                    if (std::isfinite(h.value[c])) {
                        CHECK(d.value[c] ==
                              doctest::Approx(h.value[c]).epsilon(1e-9).scale(1e-12));
                        // Errors that are rounding noise (1e-17) may be 0 on one side.
                        CHECK(std::fabs(d.stderr_[c] - h.stderr_[c]) <=
                              1e-6 * std::fabs(h.stderr_[c]) + 1e-12);
                    } else {
                        CHECK(d.value[c] == h.value[c]);
                    }
                    CHECK(d.samples[c] == h.samples[c]);
                }
            }
        }
    }
    CHECK(programs > 50);  // every model's quantities were reached
}

TEST_CASE("the generic program of every model still builds") {
    const DeviceInfo info = select_device("");
    ClRuntime runtime(info);
    for (const ModelInfo& m : all_models()) {
        CAPTURE(m.name);
        const std::string source = estimate_kernel_source(m.kernel_header, m.sample_function);
        std::string options = "-cl-std=CL1.2";
        options += info.has_fp64 ? " -D BT_HAS_FP64=1" : " -D BT_HAS_FP64=0";
        CHECK_NOTHROW(runtime.build_program(source, options));
    }
}
