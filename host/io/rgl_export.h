// rgl_export.h — a reflection table resampled into the RGL tensor file of
// Dupuy & Jakob (2018, "An Adaptive Parameterization for Efficient Material
// Acquisition and Rendering"), the `.bsdf` file that Mitsuba 3's `measured`
// BSDF and pbrt-v4's `measured` material read natively.  Layout, fields and
// the choice of microfacet distribution: docs/format.md ("RGL export").
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "host/lookup/lookup.h"

namespace brdftab {

struct RglExportOptions {
    // Every non-angle coordinate of the table (parameter axes, and the
    // recombination parameter unless `rgb` is set), interpolated linearly.
    std::map<std::string, double> parameters;
    // Per-channel value of the table's recombination parameter (e.g. rho of
    // a factored Oren-Nayar table); only for recombined tables.
    bool rgb = false;
    std::array<double, 3> rgb_values = {1, 1, 1};
    // Write `spectra` + `wavelengths` (a flat spectrum; pbrt-v4 and Mitsuba's
    // spectral variants) instead of `rgb` (Mitsuba's RGB variants).
    bool spectral = false;
    // Nodes per side of the square grids over the warped sample space
    // (vndf, luminance, rgb/spectra), >= 2; 0: 96 for isotropic tables, 64
    // for anisotropic ones (whose files hold many more slices).
    int resolution = 0;
    // Incidence nodes: 0 = the table's own theta_i (or mu_i) nodes, each
    // interval split into steps of at most 2.5 degrees; else this many
    // nodes evenly spaced in theta over [0, the table's maximum].
    int theta_i_count = 0;
    // Incidence azimuths of an anisotropic table: 0 = the table's count with
    // each interval split into steps of at most 3.75 degrees, else this many,
    // evenly spaced over the range the file declares.
    int phi_i_count = 0;
    // Nodes per side of the microfacet distribution and projected-area grids.
    int ndf_resolution = 64;
    // Random direction pairs at which the resampling error is measured.
    std::size_t error_pairs = 20000;
    std::uint64_t seed = 1;
    // The table's file name, for the `description` field.
    std::string source;
};

// Relative error |f_rgl - f_table| / f_table of the file's BRDF (evaluated
// exactly as the `measured` plugins evaluate it, from the float32 values
// written) against the table's interpolated value, over random direction
// pairs: wi and wo cosine-weighted (uniform in projected solid angle) over
// the angles the table covers.
struct RglResamplingError {
    std::size_t pairs = 0;
    double median = 0, p99 = 0, max = 0;
    double theta_i_max_deg = 90, theta_o_max_deg = 90;  // the sampled domain
};

struct RglExportReport {
    std::vector<std::string> notes;
    std::string distribution;  // how the microfacet distribution was chosen
    std::size_t theta_i_nodes = 0, phi_i_nodes = 0;
    int reduction = 1;  // 1, 2 or 4: the azimuthal symmetry the file declares
    int resolution = 0;  // sample grid side used
    RglResamplingError error;
    std::string description;  // the file's `description` field
};

// Throws InputError (exit 2) for a table that is not a reflection table
// (units 1/sr; axes theta_i|mu_i, theta_o|mu_o and optionally phi_d, or
// anisotropic theta_i|mu_i, phi_i, theta_o|mu_o, phi_o; theta_i from
// normal incidence), a missing parameter, or --rgb on a table without a
// recombination parameter.  Nothing is written then.
RglExportReport export_rgl(const LookupTable& table, const std::string& out_path,
                           const RglExportOptions& options);

}  // namespace brdftab
