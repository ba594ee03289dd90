// merl_export.cpp — isotropic BRDF table -> MERL binary (see merl_export.h
// and docs/format.md, "MERL export").
//
// Layout: three little-endian int32 (90, 90, 180), then three blocks of
// 90*90*180 little-endian float64, red, green, blue.  Within a block the bin
// (ih, id, ip) is at ip + 180 (id + 90 ih).  A standard reader finds the bin
// of (theta_h, theta_d, phi_d) by truncation: ih = floor(sqrt(theta_h /
// (pi/2)) 90), id = floor(theta_d / (pi/2) 90), ip = floor(phi_d / pi 180)
// with phi_d taken into [0, pi) (phi_d and phi_d + pi swap wi and wo, the
// same value by reciprocity), and multiplies the stored number by the
// channel's scale.  So each bin holds f / scale at the bin's lower edge.
#include "host/io/merl_export.h"

#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>

#include "host/core/atomic_file.h"
#include "host/core/error.h"
#include "host/core/text.h"

namespace brdftab {

namespace {

constexpr double kPi = 3.14159265358979323846;

void put_le(std::vector<unsigned char>& out, std::uint64_t bits, int bytes) {
    for (int b = 0; b < bytes; ++b) out.push_back(static_cast<unsigned char>(bits >> (8 * b)));
}

std::string num(double v) { return number_text(v, 6); }

}  // namespace

void merl_bin_directions(int ih, int id, int ip, Vec3& wi, Vec3& wo) {
    const double ratio = double(ih) / kMerlThetaH;
    const double theta_h = ratio * ratio * (kPi / 2);
    const double theta_d = double(id) / kMerlThetaD * (kPi / 2);
    const double phi_d = double(ip) / kMerlPhiD * kPi;
    // Rusinkiewicz's parametrisation: the "difference" vector d is wi seen
    // in the frame of the half vector h.  With phi_h = 0, h = (sin th, 0,
    // cos th) and wi = R_y(theta_h) d (rotation about the binormal y).
    const double dx = std::sin(theta_d) * std::cos(phi_d);
    const double dy = std::sin(theta_d) * std::sin(phi_d);
    const double dz = std::cos(theta_d);
    const double ch = std::cos(theta_h), sh = std::sin(theta_h);
    wi = {dx * ch + dz * sh, dy, -dx * sh + dz * ch};
    const Vec3 h = {sh, 0, ch};
    const double dot = wi.x * h.x + wi.y * h.y + wi.z * h.z;  // = cos theta_d
    wo = {2 * dot * h.x - wi.x, 2 * dot * h.y - wi.y, 2 * dot * h.z - wi.z};
}

MerlExportReport export_merl(const LookupTable& table, const std::string& out_path,
                             const MerlExportOptions& options) {
    const TableData& t = table.table();
    const std::string where = "MERL export of table '" + t.name + "': ";
    MerlExportReport report;

    // Isotropic BRDF only.
    int axis_i = -1, axis_o = -1;
    std::string axes_text;
    for (std::size_t d = 0; d < t.axes.size(); ++d) {
        const std::string& n = t.axes[d].name;
        axes_text += (axes_text.empty() ? "" : ", ") + n;
        if (n == "phi_i" || n == "phi_o")
            throw InputError(where + "the table is anisotropic (axis '" + n +
                             "'); the MERL format holds isotropic BRDFs only");
        if (n == "theta_i" || n == "mu_i") axis_i = int(d);
        if (n == "theta_o" || n == "mu_o") axis_o = int(d);
    }
    if (axis_i < 0 || axis_o < 0)
        throw InputError(where + "the MERL format holds isotropic BRDFs: the table needs axes "
                         "theta_i|mu_i, theta_o|mu_o and optionally phi_d (it has " +
                         (axes_text.empty() ? std::string("none") : axes_text) + ")");
    if (t.units != "1/sr")
        throw InputError(where + "the table's units are '" + t.units +
                         "'; the MERL format holds a BRDF (units 1/sr)");
    for (int d : {axis_i, axis_o}) {
        const Axis& a = t.axes[d];
        const bool mu = a.name[0] == 'm';
        const double scale = a.unit == "rad" ? 1.0 : kPi / 180.0;
        const bool normal = mu ? a.max >= 1 - 1e-12 : a.min * scale <= 1e-12;
        if (!normal)
            throw InputError(where + "axis '" + a.name + "' covers [" + num(a.min) + ", " +
                             num(a.max) + "]" + unit_suffix(a.unit) +
                             "; a MERL file holds reflection of light from outside, so the "
                             "table must start at normal incidence");
        const double grazing = mu ? a.min : a.max * scale - kPi / 2;
        if (grazing > 1e-12)
            report.notes.push_back("axis '" + a.name + "' stops at " +
                                   num(mu ? a.min : a.max) + unit_suffix(a.unit) +
                                   " before grazing; directions beyond it use the value at its "
                                   "last node (clamped)");
    }

    // Parameters per channel.
    std::array<std::map<std::string, double>, 3> params;
    const auto names = table.coordinate_names();
    const std::string rparam = table.has_recombination() ? names.back() : "";
    for (int c = 0; c < 3; ++c) {
        params[c] = options.parameters;
        if (options.rgb) {
            if (rparam.empty())
                throw InputError(where + "--rgb needs a factored table (one recombined with a "
                                 "parameter such as rho at lookup time); this table has none");
            if (options.parameters.count(rparam))
                throw InputError(where + "give '" + rparam + "' either with --rgb or as a "
                                 "parameter, not both");
            params[c][rparam] = options.rgb_values[c];
        }
    }
    // Unknown or missing parameters: checked once, with the table's names.
    for (const auto& kv : params[0]) {
        bool known = false;
        for (const auto& n : names) known = known || n == kv.first;
        if (!known || kv.first == t.axes[axis_i].name || kv.first == t.axes[axis_o].name ||
            kv.first == "phi_d")
            throw InputError(where + "'" + kv.first + "' is not a parameter of the table "
                             "(its coordinates: " + [&] {
                                 std::string s;
                                 for (const auto& n : names) s += (s.empty() ? "" : ", ") + n;
                                 return s;
                             }() + "; the angles are the MERL grid's)");
    }
    {
        Vec3 wi{0, 0, 1}, wo{0, 0, 1};
        table.eval_dirs(wi, wo, params[0]);  // throws InputError naming a missing one
    }

    const std::size_t bins = std::size_t(kMerlThetaH) * kMerlThetaD * kMerlPhiD;
    std::vector<double> channel[3];
    for (auto& ch : channel) ch.assign(bins, 0.0);
    const bool same = !options.rgb;
    for (int ih = 0; ih < kMerlThetaH; ++ih)
        for (int id = 0; id < kMerlThetaD; ++id)
            for (int ip = 0; ip < kMerlPhiD; ++ip) {
                Vec3 wi, wo;
                merl_bin_directions(ih, id, ip, wi, wo);
                const std::size_t bin = std::size_t(ip) + kMerlPhiD * (std::size_t(id) +
                                                                       kMerlThetaD * std::size_t(ih));
                // Below the horizon there is no reflection: 0.
                if (!(wi.z > 0) || !(wo.z > 0)) continue;
                for (int c = 0; c < 3; ++c) {
                    if (same && c > 0) {
                        channel[c][bin] = channel[0][bin];
                        continue;
                    }
                    channel[c][bin] = table.eval_dirs(wi, wo, params[c]);
                }
            }

    std::vector<unsigned char> bytes;
    bytes.reserve(12 + 3 * bins * 8);
    for (int dim : {kMerlThetaH, kMerlThetaD, kMerlPhiD})
        put_le(bytes, static_cast<std::uint32_t>(dim), 4);
    for (int c = 0; c < 3; ++c)
        for (double f : channel[c]) {
            const double stored = f / kMerlScale[c];
            std::uint64_t bits;
            std::memcpy(&bits, &stored, sizeof bits);
            put_le(bytes, bits, 8);
        }

    AtomicOutput tmp(out_path);
    std::FILE* f = std::fopen(tmp.path().c_str(), "wb");
    if (!f) throw Error("cannot create '" + tmp.path() + "': " + std::strerror(errno));
    const bool ok = std::fwrite(bytes.data(), 1, bytes.size(), f) == bytes.size();
    if (std::fclose(f) != 0 || !ok)
        throw Error("cannot write MERL file '" + out_path + "': " + std::strerror(errno));
    tmp.commit();
    return report;
}

}  // namespace brdftab
