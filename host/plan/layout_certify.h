// layout_certify.h — the certificate of a renderer LUT in the renderer's own
// interpolation (`brdftab certify FILE --table T --layout cycles|filament|ue4`,
// docs/renderer-luts.md "Certificates in the renderers' interpolation").
//
// A renderer does not read a table in its node values: it places node k of
// an axis of n nodes at its own coordinate u_k and interpolates linearly in
// u between them (bilinear, trilinear), whatever point the node's value was
// computed at.  The layout fixes, per axis, u_k and the model input at a
// coordinate u:
//   cycles    u_k = k/(n - 1); alpha = max(u, 1e-4)^2 (u is the roughness),
//             mu = max(u, 1e-4) (theta_i = 180 deg - acos(mu) for light from
//             inside), eta = (1 + z^2)/(1 - z^2) with z = clamp(u, 1e-4, 0.99);
//   filament, ue4  texel centres u_k = (k + 0.5)/n; alpha = u^2 (u the
//             perceptual roughness), mu = u (NoV).
// The certificate compares that interpolation of the stored values with the
// model evaluated directly at the same u, at probes: the centre of every
// cell (every axis at the midpoint between two nodes' u, where multilinear
// interpolation errs most for a smooth function) and every node whose value
// was not computed at the layout's model input for u_k (Filament's rows are
// computed one texel above the coordinate it reads them at), at most
// kMaxLayoutProbes of each kind (evenly spaced when there are more).  The
// direct value uses the table's own quantity, options and integration (its
// error, the direct values' largest error estimate, is reported as
// reference_noise), or fewer quadrature nodes (reference_nodes).  Library code: no printing.
#pragma once

#include <cstddef>
#include <map>
#include <string>
#include <vector>

#include "host/core/table.h"
#include "host/engine/engine.h"
#include "host/io/renderer_layout.h"

namespace brdftab {

constexpr std::size_t kMaxLayoutProbes = 4096;

struct LayoutCertificate {
    std::string table;
    RendererLayout layout = RendererLayout::Cycles;
    std::string interpolation;      // in words, e.g. "trilinear in (z, mu, r), node k at k/(n-1)"
    double max_error = 0;           // max |interpolated - direct| (absolute) over all probes
    double rms_error = 0;           // RMS over the cell-centre probes
    double node_max = 0;            // max over the node probes (0 when there are none)
    std::map<std::string, double> max_at;  // model inputs of the worst probe
    std::size_t cell_probes = 0, node_probes = 0;
    double integration_estimate = 0;  // the stored values' largest error estimate (stderr)
    double reference_noise = 0;       // the direct values' largest error estimate
    double seconds = 0;
};

// The certificate of `table` (as read from a file) in `layout`; throws
// InputError where the table does not fit the layout (its axes, as
// renderer_layout_values checks them, one table at a time) or is not a
// computed model quantity.
// reference_nodes > 0: the direct values take that many quadrature nodes
// (the `nodes` parameter) instead of the table's own: a cheaper reference,
// enough where the interpolation error is orders of magnitude above the
// integration error; its own error estimate is reported as reference_noise.
LayoutCertificate certify_layout(const TableData& table, RendererLayout layout, Backend& backend,
                                 double reference_nodes = 0, const ProgressFn& progress = nullptr);

// Writes it as attributes `layout_certificate_*` of the table's group in the
// file at `path` (the caller replaces the file atomically).
void write_layout_certificate(const std::string& path, const LayoutCertificate& c);

// One line: "max 3.1e-3 at alpha 0.19, mu_i 0.016; RMS 4.0e-4; 961 cell centres, ..."
std::string layout_certificate_text(const LayoutCertificate& c);

}  // namespace brdftab
