// Registration of the test-only toy-lambert model (kernel math in
// tests/toy_model/kernels/models/toy_lambert.h), written by following
// docs/adding-a-model.md step by step.  Linked only into test_toy_model and
// brdftab_toy (tests/CMakeLists.txt).
#include "host/models/registry.h"
#include "models/toy_lambert.h"

namespace brdftab::detail {

namespace {

ModelInfo toy_lambert_model() {
    ModelBuilder b("toy-lambert", 1000);
    b.citation("J. H. Lambert. Photometria, 1760 (test-only model).");
    b.description("Test-only Lambertian reflector proving docs/adding-a-model.md.");
    b.kernel("models/toy_lambert.h", "toy_lambert_sample", &toy_lambert_sample);
    b.counts(TL_PARAM_COUNT, TL_OPT_COUNT, TL_Q_COUNT);
    b.parameter(TL_PARAM_ALBEDO, parameter_info("albedo", "1", "reflectance", 0, 1, 0.5));
    b.option(TL_OPT_SAMPLING, {"sampling",
                               "albedo: outgoing directions uniform on the hemisphere or "
                               "cosine-distributed",
                               {"uniform", "cosine"},
                               "uniform"});
    b.quantity(QuantityInfo{"brdf", TL_Q_BRDF, "albedo / pi above the surface", "1/sr",
                            QuantityKind::ClosedForm,
                            {"theta_i", "phi_i", "theta_o", "phi_o"}, {}, "f = albedo / pi",
                            Method::ClosedForm, 0});
    b.quantity(QuantityInfo{"albedo", TL_Q_ALBEDO, "directional albedo (equals the parameter)",
                            "1", QuantityKind::Integral, {"theta_i"}, {"sampling"},
                            "int f cos(theta_o) dw_o", Method::MonteCarlo, 1});
    return b.build();
}

BRDFTAB_REGISTER_MODEL(toy_lambert_model);

}  // namespace

}  // namespace brdftab::detail
