// merl_export.h — an isotropic BRDF table resampled into the MERL binary
// format (the layout of the MERL 100 measured materials), which BRDF
// Explorer and many renderers read.  The format is described in
// docs/format.md ("MERL export").
#pragma once

#include <array>
#include <map>
#include <string>
#include <vector>

#include "host/lookup/lookup.h"

namespace brdftab {

// Resolution of the format: theta_h, theta_d, phi_d bins.
constexpr int kMerlThetaH = 90, kMerlThetaD = 90, kMerlPhiD = 180;
// A standard reader multiplies the stored red, green and blue values by these.
constexpr std::array<double, 3> kMerlScale = {1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0};

// The angles bin (ih, id, ip) of a MERL file stands for: the lower edge of
// the bin a standard reader maps to it (theta_h = (ih/90)^2 pi/2,
// theta_d = id/90 pi/2, phi_d = ip/180 pi), as directions wi, wo (unit, z =
// normal) with the half vector in the x-z plane (phi_h = 0).
void merl_bin_directions(int ih, int id, int ip, Vec3& wi, Vec3& wo);

struct MerlExportOptions {
    // Every non-angle coordinate of the table (parameter axes, and the
    // recombination parameter unless `rgb` is set), interpolated linearly.
    std::map<std::string, double> parameters;
    // Per-channel value of the table's recombination parameter (e.g. rho of
    // a factored Oren-Nayar table); only for recombined tables.
    bool rgb = false;
    std::array<double, 3> rgb_values = {1, 1, 1};
};

// What the export did that the user should know (e.g. angles clamped to a
// table that stops short of grazing); one line each.
struct MerlExportReport {
    std::vector<std::string> notes;
};

// Throws InputError (exit 2) for a table that is not an isotropic BRDF
// (axes theta_i|mu_i, theta_o|mu_o, optionally phi_d; units 1/sr; both
// angle axes starting at normal incidence), a missing parameter, or --rgb
// on a table without a recombination parameter.  Nothing is written then.
MerlExportReport export_merl(const LookupTable& table, const std::string& out_path,
                             const MerlExportOptions& options);

}  // namespace brdftab
