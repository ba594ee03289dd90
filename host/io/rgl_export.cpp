// rgl_export.cpp — reflection table -> RGL tensor file (see rgl_export.h and
// docs/format.md, "RGL export").
//
// The file's BRDF, as both `measured` plugins evaluate it (wi: the direction
// whose angles select the slice; all directions unit, z = normal):
//   m = normalize(wi + wo),  u(theta) = sqrt(2 theta / pi),
//   u(phi) = (phi + pi) / (2 pi),
//   u_m  = (u(theta_m), u(phi_m - phi_i))   (isotropic; phi_m when not),
//   s    = R^-1(u_m | phi_i, theta_i)       (inverse of the vndf warp),
//   f cos theta_o = rgb(s | phi_i, theta_i, channel) * ndf(u_m) / (4 sigma(u_wi)).
// R is the continuous marginal-conditional warp of the bilinear density
// `vndf` over the (u_theta, u_phi) square; `ndf`, `sigma` and `rgb` are
// bilinear interpolants, and every field is interpolated linearly between
// its (phi_i, theta_i) slices (in radians).  So the file holds, at the
// nodes s of a square grid, rgb = f cos theta_o 4 sigma / ndf for the wo
// that R maps s to: the sampling weight of visible-normal sampling, smooth
// wherever the distribution follows the lobe.  This file builds those
// fields and evaluates the result the same way to measure the error.
#include "host/io/rgl_export.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "host/core/atomic_file.h"
#include "host/core/error.h"
#include "host/core/splitmix.h"
#include "host/core/text.h"

#ifndef BRDFTAB_VERSION
#define BRDFTAB_VERSION "unknown"
#endif

namespace brdftab {

namespace {

constexpr double kPi = 3.14159265358979323846;

double u2theta(double u) { return u * u * (kPi / 2); }
double u2phi(double u) { return (2 * u - 1) * kPi; }
double theta2u(double theta) { return std::sqrt(std::max(0.0, theta) * (2 / kPi)); }
double phi2u(double phi) { return (phi + kPi) / (2 * kPi); }
double clamp01(double x) { return std::min(1.0, std::max(0.0, x)); }
double lerp(double a, double b, double t) { return a + (b - a) * t; }
double dot(const Vec3& a, const Vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

Vec3 normalized(const Vec3& v) {
    const double n = std::sqrt(dot(v, v));
    return {v.x / n, v.y / n, v.z / n};
}

Vec3 spherical(double theta, double phi) {
    return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}

// Polar angle, accurate near the normal (as the plugins compute it).
double elevation(const Vec3& d) {
    const double dist = std::sqrt(d.x * d.x + d.y * d.y + (d.z - 1) * (d.z - 1));
    return 2 * std::asin(std::min(1.0, 0.5 * dist));
}

// Bilinear interpolation of a w x h node grid over [0, 1]^2 (row-major,
// x fastest).
double bilinear(const float* v, int w, int h, double x, double y) {
    x = clamp01(x) * (w - 1);
    y = clamp01(y) * (h - 1);
    const int ix = std::min(int(x), w - 2), iy = std::min(int(y), h - 2);
    const double fx = x - ix, fy = y - iy;
    const float* r0 = v + std::size_t(iy) * w + ix;
    const float* r1 = r0 + w;
    return (1 - fy) * ((1 - fx) * r0[0] + fx * r0[1]) + fy * ((1 - fx) * r1[0] + fx * r1[1]);
}

// One slice of a continuous marginal-conditional warp of a bilinear
// density: the density normalised to integrate to 1 over [0, 1]^2, per row
// the cumulative integral along x at each node, and the cumulative integral
// of the row integrals along y (trapezoid rule, exact for the bilinear
// density along each row and for the row integrals' linear interpolant).
struct WarpSlice {
    std::vector<double> data;  // h * w
    std::vector<double> cond;  // h * (w - 1)
    std::vector<double> marg;  // h - 1
};

WarpSlice build_warp_slice(const float* density, int w, int h) {
    WarpSlice s;
    s.data.assign(density, density + std::size_t(w) * h);
    s.cond.resize(std::size_t(h) * (w - 1));
    s.marg.resize(std::size_t(h) - 1);
    std::vector<double> row(h);
    for (int y = 0; y < h; ++y) {
        double acc = 0;
        for (int x = 0; x < w - 1; ++x) {
            acc += 0.5 / (w - 1) * (s.data[std::size_t(y) * w + x] + s.data[std::size_t(y) * w + x + 1]);
            s.cond[std::size_t(y) * (w - 1) + x] = acc;
        }
        row[y] = acc;
    }
    double acc = 0;
    for (int y = 0; y < h - 1; ++y) {
        acc += 0.5 / (h - 1) * (row[y] + row[y + 1]);
        s.marg[y] = acc;
    }
    const double norm = acc > 0 ? 1 / acc : 0;
    for (double& v : s.data) v *= norm;
    for (double& v : s.cond) v *= norm;
    for (double& v : s.marg) v *= norm;
    return s;
}

// A linear blend of up to four slices (the parameter interpolation).
struct Mix {
    const WarpSlice* slice[4] = {};
    double weight[4] = {};
    int n = 0;
    double data(std::size_t i) const { return sum(&WarpSlice::data, i); }
    double cond(std::size_t i) const { return sum(&WarpSlice::cond, i); }
    double marg(std::size_t i) const { return sum(&WarpSlice::marg, i); }
    double sum(std::vector<double> WarpSlice::*field, std::size_t i) const {
        double v = 0;
        for (int k = 0; k < n; ++k) v += weight[k] * (slice[k]->*field)[i];
        return v;
    }
};

// Solves the integral of the linear density lerp(v0, v1, t) over [0, t],
// times `width` (in units of the grid cell), equal to `sample`, for t.
double sample_segment(double sample, double inv_width, double v0, double v1) {
    const bool non_const = std::abs(v0 - v1) > 1e-4 * (v0 + v1);
    const double divisor = non_const ? v0 - v1 : v0 + v1;
    sample *= 2 * inv_width;
    if (non_const) sample = v0 - std::sqrt(std::max(0.0, v0 * v0 + sample * (v1 - v0)));
    if (divisor != 0) sample /= divisor;
    return sample;
}

double invert_segment(double t, double width, double v0, double v1) { return t * lerp(v0, v1, 0.5 * t) * width; }

struct Point2 {
    double x = 0, y = 0;
};

// Uniform point -> warped point (rows from the marginal, then the column).
Point2 warp_sample(const Mix& m, int w, int h, Point2 s) {
    const double eps = 5.96e-8;
    s.x = std::min(1 - eps, std::max(eps, s.x));
    s.y = std::min(1 - eps, std::max(eps, s.y));
    int row = 0;
    while (row < h - 2 && m.marg(row) < s.y) ++row;
    if (row > 0) s.y -= m.marg(row - 1);
    const std::size_t c0 = std::size_t(row) * (w - 1), c1 = c0 + (w - 1);
    const double r0 = m.cond(c0 + w - 2), r1 = m.cond(c1 + w - 2);
    const double ty = sample_segment(s.y, h - 1, r0, r1);
    s.x *= lerp(r0, r1, ty);
    auto fetch = [&](int i) { return lerp(m.cond(c0 + i), m.cond(c1 + i), ty); };
    int col = 0;
    while (col < w - 2 && fetch(col) < s.x) ++col;
    if (col > 0) s.x -= fetch(col - 1);
    const std::size_t d = std::size_t(row) * w + col;
    const double a0 = lerp(m.data(d), m.data(d + w), ty), a1 = lerp(m.data(d + 1), m.data(d + w + 1), ty);
    const double tx = sample_segment(s.x, w - 1, a0, a1);
    return {(col + tx) / (w - 1), (row + ty) / (h - 1)};
}

// Warped point -> uniform point (the inverse of warp_sample).
Point2 warp_invert(const Mix& m, int w, int h, Point2 p) {
    const double x = clamp01(p.x) * (w - 1), y = clamp01(p.y) * (h - 1);
    const int ix = std::min(int(x), w - 2), iy = std::min(int(y), h - 2);
    const double fx = x - ix, fy = y - iy;
    const std::size_t d = std::size_t(iy) * w + ix;
    const double a0 = lerp(m.data(d), m.data(d + w), fy), a1 = lerp(m.data(d + 1), m.data(d + w + 1), fy);
    double sx = invert_segment(fx, 1.0 / (w - 1), a0, a1);
    const std::size_t c0 = std::size_t(iy) * (w - 1), c1 = c0 + (w - 1);
    if (ix > 0) sx += lerp(m.cond(c0 + ix - 1), m.cond(c1 + ix - 1), fy);
    const double r0 = m.cond(c0 + w - 2), r1 = m.cond(c1 + w - 2);
    const double total = lerp(r0, r1, fy);
    sx = total > 0 ? sx / total : 0;
    double sy = invert_segment(fy, 1.0 / (h - 1), r0, r1);
    if (iy > 0) sy += m.marg(iy - 1);
    return {sx, sy};
}

// The plugins' interpolation weight along one parameter: the interval
// [v[i], v[i+1]] holding p (clamped to the ends) and the weight of v[i+1].
std::pair<std::size_t, double> param_interval(const std::vector<float>& v, double p) {
    if (v.size() == 1) return {0, 0.0};
    std::size_t i = 0;
    while (i + 2 < v.size() && v[i + 1] <= p) ++i;
    const double w1 = std::min(1.0, std::max(0.0, (p - v[i]) / (double(v[i + 1]) - v[i])));
    return {i, w1};
}

std::string num(double v) { return number_text(v, 6); }

// How the table is read at a pair of directions in the file's frame.
struct TableView {
    const LookupTable* lt = nullptr;
    bool anisotropic = false;
    int reduction = 1;
    int axis_i = -1, axis_o = -1, axis_phi_i = -1, axis_phi_o = -1;
    std::array<std::map<std::string, double>, 3> params;
    int channels = 1;

    // The plugins fold wi into the slice range: with reduction 4 by the
    // mirrors x -> -x and y -> -y (to phi_i in [-pi, -pi/2]), with 2 by the
    // rotation by pi (to [-pi, 0]); wo goes with it.
    void reduce(Vec3& wi, Vec3& wo) const {
        if (reduction < 2) return;
        const double sy = wi.y, sx = reduction == 4 ? wi.x : sy;
        if (sx >= 0) wi.x = -wi.x, wo.x = -wo.x;
        if (sy >= 0) wi.y = -wi.y, wo.y = -wo.y;
    }

    // The table value at directions of the file's (reduced) frame: a table
    // over phi_i in [0, 360 / reduction] is the file's slice range turned by
    // pi (the symmetry that the reduction declares).
    double eval(Vec3 wi, Vec3 wo, int c) const {
        if (!anisotropic) return lt->eval_dirs(wi, wo, params[c]);
        if (reduction >= 2) wi = {-wi.x, -wi.y, wi.z}, wo = {-wo.x, -wo.y, wo.z};
        return eval_table_frame(wi, wo, c);
    }

    double eval_table_frame(const Vec3& wi, const Vec3& wo, int c) const {
        const std::vector<Axis>& axes = lt->axes();
        std::vector<double> coords;
        const auto names = lt->coordinate_names();
        for (std::size_t k = 0; k < names.size(); ++k) {
            if (k < axes.size() && (int(k) == axis_i || int(k) == axis_o || int(k) == axis_phi_i ||
                                    int(k) == axis_phi_o)) {
                const Axis& a = axes[k];
                const Vec3& d = (int(k) == axis_i || int(k) == axis_phi_i) ? wi : wo;
                const double scale = a.unit == "rad" ? 1.0 : 180.0 / kPi;
                if (int(k) == axis_i || int(k) == axis_o) {
                    const double z = std::min(1.0, std::max(-1.0, d.z));
                    coords.push_back(a.name[0] == 'm' ? z : std::acos(z) * scale);
                } else {
                    const double full = 2 * kPi * scale;
                    double phi = std::atan2(d.y, d.x) * scale;
                    phi = a.min + std::fmod(std::fmod(phi - a.min, full) + full, full);
                    // Just below the range's start (round-off of a node at
                    // its first value) is the start, not the far end.
                    if (phi > a.max && phi - full > a.min - 1e-6 * full) phi -= full;
                    coords.push_back(phi);
                }
            } else {
                const auto it = params[c].find(names[k]);
                coords.push_back(it == params[c].end() ? 0.0 : it->second);
            }
        }
        return lt->eval(coords);
    }
};

// Projected area sigma(wi) = integral of D(m) max(0, wi . m) over m, at the
// sigma grid's nodes (u_theta_i along x, u_phi_i along y).
std::vector<float> sigma_grid(const std::vector<float>& ndf, int n, int n_phi, bool anisotropic) {
    const int q = 128;
    std::vector<Vec3> m(std::size_t(q) * q);
    std::vector<double> wd(m.size());
    for (int j = 0; j < q; ++j)
        for (int i = 0; i < q; ++i) {
            const double u = (i + 0.5) / q, v = (j + 0.5) / q, theta = u2theta(u);
            m[std::size_t(j) * q + i] = spherical(theta, u2phi(v));
            wd[std::size_t(j) * q + i] =
                bilinear(ndf.data(), n, n_phi, u, v) * 2 * kPi * kPi * u * std::sin(theta) / (double(q) * q);
        }
    std::vector<float> out(std::size_t(n) * n_phi);
    for (int y = 0; y < n_phi; ++y)
        for (int x = 0; x < n; ++x) {
            if (!anisotropic && y > 0) {
                out[std::size_t(y) * n + x] = out[x];
                continue;
            }
            const Vec3 wi = spherical(u2theta(double(x) / (n - 1)), u2phi(double(y) / (n_phi - 1)));
            double s = 0;
            for (std::size_t k = 0; k < m.size(); ++k) s += wd[k] * std::max(0.0, dot(wi, m[k]));
            out[std::size_t(y) * n + x] = float(s);
        }
    return out;
}

// The microfacet distribution D(m) at the ndf grid's nodes (u_theta along
// x, u_phi along y): the model's own for a rough dielectric with a GGX or
// Beckmann distribution, else derived from back-scattering (below).
std::vector<float> ndf_grid(const TableView& view, int n, int n_phi, std::string& how) {
    const LookupTable& lt = *view.lt;
    std::string dist;
    double alpha = 0;
    if (lt.model() == "rough-dielectric") {
        const auto& p = lt.parameters();
        if (p.contains("distribution") && p["distribution"].is_string()) dist = p["distribution"];
        const auto it = view.params[0].find("alpha");
        if (it != view.params[0].end()) alpha = it->second;
        else if (p.contains("alpha") && p["alpha"].is_number()) alpha = p["alpha"];
    }
    const bool known = (dist == "ggx" || dist == "beckmann") && alpha > 0;
    how = known ? "the model's own " + std::string(dist == "ggx" ? "GGX" : "Beckmann") +
                      " distribution, alpha = " + num(alpha)
                : "derived from back-scattering, D(m) ~ f(m, m) cos theta_m sigma(m)";
    std::vector<double> d(std::size_t(n) * n_phi);
    for (int y = 0; y < n_phi; ++y)
        for (int x = 0; x < n; ++x) {
            const double theta = u2theta(double(x) / (n - 1));
            const double c = std::cos(theta), s = std::sin(theta);
            double v;
            if (known && dist == "ggx") {
                const double a2 = alpha * alpha, t = a2 * c * c + s * s;
                v = a2 / (kPi * t * t);
            } else if (known) {
                v = c > 1e-6 ? std::exp(-(s * s) / (c * c * alpha * alpha)) / (kPi * alpha * alpha * c * c * c * c) : 0;
            } else if (view.anisotropic || y == 0) {
                Vec3 m = spherical(std::min(theta, kPi / 2 * (1 - 1e-6)), u2phi(double(y) / (n_phi - 1)));
                Vec3 m2 = m;
                view.reduce(m, m2);
                double f = 0;
                for (int ch = 0; ch < view.channels; ++ch) f += view.eval(m, m2, ch);
                v = std::max(0.0, f / view.channels) * c * c;
            } else {
                v = d[x];  // isotropic: every row the same
            }
            d[std::size_t(y) * n + x] = v;
        }
    // A floor keeps the warp invertible where D vanishes (grazing Beckmann),
    // and D is normalised: the integral of D cos theta over the hemisphere is
    // 1 (midpoint rule over the u square, d omega = 2 pi^2 u sin theta du dv).
    auto finish = [&](const std::vector<double>& raw) {
        double peak = 0;
        for (double v : raw) peak = std::max(peak, v);
        if (!(peak > 0) || !std::isfinite(peak))
            throw InputError("RGL export of table '" + lt.table().name +
                             "': the back-scattering values f(m, m) are not positive, so no microfacet "
                             "distribution can be derived");
        std::vector<float> tmp(raw.size());
        for (std::size_t k = 0; k < raw.size(); ++k) tmp[k] = float(std::max(raw[k], 1e-4 * peak));
        const int q = 256;
        double integral = 0;
        for (int j = 0; j < q; ++j)
            for (int i = 0; i < q; ++i) {
                const double u = (i + 0.5) / q, v = (j + 0.5) / q, theta = u2theta(u);
                integral += bilinear(tmp.data(), n, n_phi, u, v) * std::cos(theta) * 2 * kPi * kPi * u *
                            std::sin(theta) / (double(q) * q);
            }
        for (float& v : tmp) v = float(v / integral);
        return tmp;
    };
    if (known) return finish(d);
    // Back-scattering of a microfacet BRDF: f(m, m) = F D(m) G1(m) / (4 cos^2),
    // with G1(m) = cos theta_m / sigma(m) (the projected area of D), so
    // D(m) ~ f(m, m) cos theta_m sigma(m): a fixed point, found by iterating
    // from D ~ f(m, m) cos^2 theta_m (sigma ~ cos theta) with F constant.
    std::vector<float> cur = finish(d);
    for (int it = 0; it < 6; ++it) {
        const std::vector<float> sg = sigma_grid(cur, n, n_phi, view.anisotropic);
        std::vector<double> next(d.size());
        for (int y = 0; y < n_phi; ++y)
            for (int x = 0; x < n; ++x) {
                const std::size_t k = std::size_t(y) * n + x;
                const double c = std::cos(u2theta(double(x) / (n - 1)));
                next[k] = c > 1e-9 ? d[k] / c * sg[k] : 0.0;  // d = f(m, m) cos^2
            }
        cur = finish(next);
    }
    return cur;
}

// Everything the file holds, and its evaluation as the plugins do it.
struct RglData {
    bool anisotropic = false;
    bool derived = false;        // D derived from back-scattering
    int reduction = 1;
    int n = 0;                   // sample grid side
    int nd = 0, nd_phi = 0;      // ndf / sigma grid
    int channels = 3;            // rgb: 3; spectral: wavelengths
    std::vector<float> theta_i, phi_i, wavelengths;
    std::vector<float> ndf, sigma, vndf, luminance, values;  // values: rgb or spectra
    std::vector<WarpSlice> vndf_warp;

    std::size_t slices() const { return theta_i.size() * phi_i.size(); }

    // f(wi, wo) cos theta_o of channel c (wi, wo in the upper hemisphere).
    double eval(Vec3 wi, Vec3 wo, int c, const TableView& view) const {
        view.reduce(wi, wo);
        const Vec3 m = normalized({wi.x + wo.x, wi.y + wo.y, wi.z + wo.z});
        const double th_i = elevation(wi), ph_i = std::atan2(wi.y, wi.x);
        const double th_m = elevation(m), ph_m = std::atan2(m.y, m.x);
        Point2 u_m{theta2u(th_m), phi2u(anisotropic ? ph_m : ph_m - ph_i)};
        u_m.y -= std::floor(u_m.y);
        const auto [ip, wp] = param_interval(phi_i, ph_i);
        const auto [it, wt] = param_interval(theta_i, th_i);
        Mix mix;
        std::size_t idx[4];
        for (int a = 0; a < 2; ++a)
            for (int b = 0; b < 2; ++b) {
                const double w = (a ? wp : 1 - wp) * (b ? wt : 1 - wt);
                if (w == 0) continue;
                idx[mix.n] = (ip + a) * theta_i.size() + it + b;
                mix.slice[mix.n] = &vndf_warp[idx[mix.n]];
                mix.weight[mix.n++] = w;
            }
        const Point2 s = warp_invert(mix, n, n, u_m);
        double spec = 0;
        for (int k = 0; k < mix.n; ++k)
            spec += mix.weight[k] *
                    bilinear(values.data() + (idx[k] * channels + c) * std::size_t(n) * n, n, n, s.x, s.y);
        const double nd_v = bilinear(ndf.data(), nd, nd_phi, u_m.x, u_m.y);
        const double sg = bilinear(sigma.data(), nd, nd_phi, theta2u(th_i), phi2u(ph_i));
        return spec * nd_v / (4 * sg);
    }
};

// The vndf, luminance and value slices at one (phi_i, theta_i) node.
void build_slice(RglData& r, std::size_t slice, const TableView& view, int value_channels) {
    const int n = r.n;
    const std::size_t nn = std::size_t(n) * n;
    const double th_i = r.theta_i[slice % r.theta_i.size()], ph_i = r.phi_i[slice / r.theta_i.size()];
    const Vec3 wi = spherical(th_i, ph_i);
    float* vndf = r.vndf.data() + slice * nn;
    // The vndf field is the sampling density of the half vector, which only
    // has to be positive where it matters: the plugins sample with it and
    // compute its pdf, and the values are made to match.  Its construction
    // also decides how the sample grid is spread over half vectors: near the
    // normal a bounded density gets a share of the grid ~ theta_m^2, so for a
    // broad derived distribution 20 % of a narrow GGX (alpha = 0.1) visible-
    // normal density is mixed in, for resolution around the mirror direction.
    const double bump_w = r.derived ? 0.2 : 0.0, bump_a = 0.1;
    std::vector<double> vt(nn), vb(nn);
    double st = 0, sb = 0;
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
            const double u = double(x) / (n - 1), v = double(y) / (n - 1), theta = u2theta(u);
            const Vec3 m = spherical(theta, u2phi(v) + (r.anisotropic ? 0 : ph_i));
            const double jac = std::max(0.0, dot(wi, m)) * 2 * kPi * kPi * u * std::sin(theta);
            const double a2 = bump_a * bump_a, t = a2 * m.z * m.z + (1 - m.z * m.z);
            vt[std::size_t(y) * n + x] = bilinear(r.ndf.data(), r.nd, r.nd_phi, u, v) * jac;
            vb[std::size_t(y) * n + x] = a2 / (kPi * t * t) * jac;
            st += vt[std::size_t(y) * n + x];
            sb += vb[std::size_t(y) * n + x];
        }
    for (std::size_t k = 0; k < nn; ++k) vndf[k] = float((1 - bump_w) * vt[k] / st + bump_w * vb[k] / sb);
    r.vndf_warp[slice] = build_warp_slice(vndf, n, n);
    Mix mix;
    mix.slice[0] = &r.vndf_warp[slice];
    mix.weight[0] = 1;
    mix.n = 1;
    const double sg = bilinear(r.sigma.data(), r.nd, r.nd_phi, theta2u(th_i), phi2u(ph_i));
    float* lum = r.luminance.data() + slice * nn;
    float* val = r.values.data() + slice * value_channels * nn;
    std::vector<double> g(3 * nn, 0.0);
    std::vector<char> below(nn, 0);
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
            const std::size_t k = std::size_t(y) * n + x;
            const Point2 u_m = warp_sample(mix, n, n, {double(x) / (n - 1), double(y) / (n - 1)});
            const Vec3 m = spherical(u2theta(u_m.x), u2phi(u_m.y) + (r.anisotropic ? 0 : ph_i));
            const double c = dot(wi, m);
            const Vec3 wo = {2 * c * m.x - wi.x, 2 * c * m.y - wi.y, 2 * c * m.z - wi.z};
            // Below the horizon: the odd continuation f(wi, mirror(wo)) cos theta_o
            // (< 0), so that a bilinear cell across the horizon stays linear
            // in cos theta_o instead of being pulled towards zero.
            const Vec3 up = {wo.x, wo.y, std::max(std::abs(wo.z), 1e-9)};
            const double weight = 4 * sg / bilinear(r.ndf.data(), r.nd, r.nd_phi, u_m.x, u_m.y);
            below[k] = wo.z < 0;
            for (int ch = 0; ch < view.channels; ++ch) g[ch * nn + k] = view.eval(wi, up, ch) * wo.z * weight;
            for (int ch = view.channels; ch < 3; ++ch) g[ch * nn + k] = g[k];
        }
    // The continuation only serves the cells across the horizon; far below it
    // the weight 4 sigma / D grows without bound, so a node below the
    // horizon is limited to minus the largest value of its neighbours above
    // it (0 when it has none).
    std::vector<double> limited(g);
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x) {
            const std::size_t k = std::size_t(y) * n + x;
            if (!below[k]) continue;
            for (int ch = 0; ch < 3; ++ch) {
                double bound = 0;
                for (int dy = -1; dy <= 1; ++dy)
                    for (int dx = -1; dx <= 1; ++dx) {
                        const int xx = x + dx, yy = y + dy;
                        if (xx < 0 || yy < 0 || xx >= n || yy >= n) continue;
                        const std::size_t j = std::size_t(yy) * n + xx;
                        if (!below[j]) bound = std::max(bound, std::abs(g[ch * nn + j]));
                    }
                limited[ch * nn + k] = std::max(g[ch * nn + k], -bound);
            }
        }
    for (std::size_t k = 0; k < nn; ++k) {
        const double y_lum = view.channels == 1 ? limited[k]
                                                : 0.2126 * limited[k] + 0.7152 * limited[nn + k] +
                                                      0.0722 * limited[2 * nn + k];
        lum[k] = float(std::max(0.0, y_lum));
        for (int ch = 0; ch < value_channels; ++ch) val[ch * nn + k] = float(limited[(value_channels == 3 ? ch : 0) * nn + k]);
    }
    // A slice with nothing above the horizon (grazing incidence) still needs
    // a density to sample.
    float peak = 0;
    for (std::size_t k = 0; k < nn; ++k) peak = std::max(peak, lum[k]);
    if (!(peak > 0)) std::fill(lum, lum + nn, 1.0f);
}

// --- the tensor file -----------------------------------------------------------

struct Field {
    std::string name;
    std::uint8_t dtype;  // 1 = uint8, 10 = float32 (Mitsuba's Struct type codes)
    std::vector<std::uint64_t> shape;
    std::vector<unsigned char> bytes;
};

Field float_field(const std::string& name, std::vector<std::uint64_t> shape, const std::vector<float>& v) {
    Field f{name, 10, std::move(shape), {}};
    f.bytes.resize(v.size() * 4);
    for (std::size_t i = 0; i < v.size(); ++i) {
        std::uint32_t bits;
        std::memcpy(&bits, &v[i], 4);
        for (int b = 0; b < 4; ++b) f.bytes[4 * i + b] = static_cast<unsigned char>(bits >> (8 * b));
    }
    return f;
}

void put(std::vector<unsigned char>& out, std::uint64_t v, int bytes) {
    for (int b = 0; b < bytes; ++b) out.push_back(static_cast<unsigned char>(v >> (8 * b)));
}

// "tensor_file\0", version 1.0, uint32 field count; per field a uint16
// name length, the name, uint16 rank, uint8 type, uint64 data offset and
// rank uint64 extents; then each field's data, little-endian, C order, at
// an 8-byte-aligned offset.
std::vector<unsigned char> tensor_file(const std::vector<Field>& fields) {
    const char magic[12] = {'t', 'e', 'n', 's', 'o', 'r', '_', 'f', 'i', 'l', 'e', '\0'};
    std::vector<unsigned char> out(magic, magic + 12);
    out.push_back(1);
    out.push_back(0);
    put(out, fields.size(), 4);
    std::vector<std::size_t> offset_at;
    for (const Field& f : fields) {
        put(out, f.name.size(), 2);
        out.insert(out.end(), f.name.begin(), f.name.end());
        put(out, f.shape.size(), 2);
        out.push_back(f.dtype);
        offset_at.push_back(out.size());
        put(out, 0, 8);
        for (std::uint64_t s : f.shape) put(out, s, 8);
    }
    for (std::size_t k = 0; k < fields.size(); ++k) {
        while (out.size() % 8) out.push_back(0);
        const std::uint64_t pos = out.size();
        for (int b = 0; b < 8; ++b) out[offset_at[k] + b] = static_cast<unsigned char>(pos >> (8 * b));
        out.insert(out.end(), fields[k].bytes.begin(), fields[k].bytes.end());
    }
    return out;
}

// --- checks --------------------------------------------------------------------

// The table's layout for the export, or InputError.
TableView check_table(const LookupTable& table, const RglExportOptions& options,
                      RglExportReport& report) {
    const TableData& t = table.table();
    const std::string where = "RGL export of table '" + t.name + "': ";
    TableView view;
    view.lt = &table;
    bool has_phi_d = false;
    std::string axes_text;
    for (std::size_t d = 0; d < t.axes.size(); ++d) {
        const std::string& n = t.axes[d].name;
        axes_text += (axes_text.empty() ? "" : ", ") + n;
        if (n == "theta_i" || n == "mu_i") view.axis_i = int(d);
        if (n == "theta_o" || n == "mu_o") view.axis_o = int(d);
        if (n == "phi_i") view.axis_phi_i = int(d);
        if (n == "phi_o") view.axis_phi_o = int(d);
        if (n == "phi_d") has_phi_d = true;
    }
    view.anisotropic = view.axis_phi_i >= 0 || view.axis_phi_o >= 0;
    if (view.axis_i < 0 || view.axis_o < 0 || (view.anisotropic && (view.axis_phi_i < 0 || view.axis_phi_o < 0)) ||
        (view.anisotropic && has_phi_d))
        throw InputError(where + "an RGL file holds a BRDF over directions: the table needs axes "
                         "theta_i|mu_i, theta_o|mu_o and optionally phi_d (isotropic), or theta_i|mu_i, "
                         "phi_i, theta_o|mu_o, phi_o (anisotropic); it has " +
                         (axes_text.empty() ? std::string("none") : axes_text));
    if (t.units != "1/sr")
        throw InputError(where + "the table's units are '" + t.units +
                         "'; an RGL file holds a BRDF (units 1/sr)");
    for (int d : {view.axis_i, view.axis_o}) {
        const Axis& a = t.axes[d];
        const bool mu = a.name[0] == 'm';
        const double scale = a.unit == "rad" ? 1.0 : kPi / 180.0;
        if (mu ? a.max < 1 - 1e-12 : a.min * scale > 1e-12)
            throw InputError(where + "axis '" + a.name + "' covers [" + num(a.min) + ", " + num(a.max) + "]" +
                             unit_suffix(a.unit) + "; an RGL file holds reflection of light from outside "
                             "from normal incidence on, so the table must start at the normal");
        const double grazing = mu ? a.min : kPi / 2 - a.max * scale;
        if (grazing > 1e-12)
            report.notes.push_back("axis '" + a.name + "' stops at " + num(mu ? a.min : a.max) +
                                   unit_suffix(a.unit) + " before grazing; directions beyond it use the "
                                   "value at its last node (clamped)");
    }
    if (view.anisotropic) {
        const Axis& pi = t.axes[view.axis_phi_i];
        const Axis& po = t.axes[view.axis_phi_o];
        const double scale = pi.unit == "rad" ? 180.0 / kPi : 1.0;
        const double span = (pi.max - pi.min) * scale;
        int r = 0;
        for (int k : {1, 2, 4})
            if (std::abs(span - 360.0 / k) < 1e-6) r = k;
        if (r == 0)
            throw InputError(where + "axis 'phi_i' spans " + num(span) + " degrees; the RGL format "
                             "stores incidence azimuths over 360, 180 or 90 degrees (the table's "
                             "symmetry: none, rotation by 180 degrees, or mirrors in x and y)");
        if (r >= 2 && std::abs(pi.min) > 1e-9)
            throw InputError(where + "axis 'phi_i' starts at " + num(pi.min) + unit_suffix(pi.unit) +
                             "; a reduced azimuth range must start at 0");
        const double span_o = (po.max - po.min) * (po.unit == "rad" ? 180.0 / kPi : 1.0);
        if (std::abs(span_o - 360) > 1e-6)
            throw InputError(where + "axis 'phi_o' spans " + num(span_o) + " degrees; an anisotropic "
                             "export needs the full circle of outgoing azimuths");
        view.reduction = r;
        if (r != 1)
            report.notes.push_back("the table's phi_i covers 360/" + std::to_string(r) +
                                   " degrees: the file declares that symmetry (Mitsuba 3 reads it; "
                                   "pbrt-v4 reads anisotropic files over the full circle only)");
    }
    // Parameters per channel (as the MERL export).
    const auto names = table.coordinate_names();
    const std::string rparam = table.has_recombination() ? names.back() : "";
    view.channels = options.rgb ? 3 : 1;
    for (int c = 0; c < 3; ++c) {
        view.params[c] = options.parameters;
        if (options.rgb) {
            if (rparam.empty())
                throw InputError(where + "--rgb needs a factored table (one recombined with a parameter "
                                 "such as rho at lookup time); this table has none");
            if (options.parameters.count(rparam))
                throw InputError(where + "give '" + rparam + "' either with --rgb or as a parameter, not both");
            view.params[c][rparam] = options.rgb_values[c];
        }
    }
    for (const auto& kv : view.params[0]) {
        bool known = false;
        for (const auto& n : names) known = known || n == kv.first;
        for (int d : {view.axis_i, view.axis_o, view.axis_phi_i, view.axis_phi_o})
            if (d >= 0 && t.axes[d].name == kv.first) known = false;
        if (!known || kv.first == "phi_d") {
            std::string list;
            for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
            throw InputError(where + "'" + kv.first + "' is not a parameter of the table (its coordinates: " +
                             list + "; the angles are the RGL file's)");
        }
    }
    for (const auto& n : names) {
        bool angle = n == "phi_d";
        for (int d : {view.axis_i, view.axis_o, view.axis_phi_i, view.axis_phi_o})
            angle = angle || (d >= 0 && t.axes[d].name == n);
        if (!angle && !view.params[0].count(n))
            throw InputError(where + "give the value of '" + n + "' (--slice " + n + "=VALUE" +
                             (n == rparam ? ", or --rgb R,G,B" : "") + ")");
    }
    return view;
}

// Incidence nodes in radians, ascending.
std::vector<float> theta_i_nodes(const TableView& view, int count) {
    const Axis& a = view.lt->axes()[view.axis_i];
    const bool mu = a.name[0] == 'm';
    const double scale = a.unit == "rad" ? 1.0 : kPi / 180.0;
    const double max = mu ? std::acos(std::max(-1.0, std::min(1.0, a.min))) : a.max * scale;
    std::vector<double> v;
    if (count <= 0 && !a.dependent() && a.values.size() >= 2) {
        // The table's nodes, each interval split evenly into steps of at most
        // 2.5 degrees: the file interpolates between slices at a fixed point
        // of its warped square, not at a fixed wo, so slices much coarser
        // than the lobe's change with theta_i cost accuracy.
        std::vector<double> t;
        for (double x : a.values) t.push_back(mu ? std::acos(std::max(-1.0, std::min(1.0, x))) : x * scale);
        std::sort(t.begin(), t.end());
        const double step = 2.5 * kPi / 180;
        for (std::size_t k = 0; k + 1 < t.size(); ++k) {
            const int parts = std::max(1, int(std::ceil((t[k + 1] - t[k]) / step - 1e-9)));
            for (int j = 0; j < parts; ++j) v.push_back(t[k] + (t[k + 1] - t[k]) * j / parts);
        }
        v.push_back(t.back());
    } else {
        const int n = std::max(2, count <= 0 ? 32 : count);
        for (int k = 0; k < n; ++k) v.push_back(std::min(kPi / 2, max) * k / (n - 1));
    }
    std::sort(v.begin(), v.end());
    std::vector<float> out;
    for (double x : v) {
        const float f = float(std::min(kPi / 2, x));
        if (out.empty() || f > out.back()) out.push_back(f);
    }
    return out;
}

RglResamplingError measure(const RglData& r, const TableView& view, const RglExportOptions& o) {
    const Axis& ai = view.lt->axes()[view.axis_i];
    const Axis& ao = view.lt->axes()[view.axis_o];
    auto top = [](const Axis& a) {
        const double scale = a.unit == "rad" ? 1.0 : kPi / 180.0;
        return a.name[0] == 'm' ? std::acos(std::max(-1.0, std::min(1.0, a.min))) : a.max * scale;
    };
    RglResamplingError e;
    const double ti = std::min(kPi / 2, top(ai)), to = std::min(kPi / 2, top(ao));
    e.theta_i_max_deg = ti * 180 / kPi;
    e.theta_o_max_deg = to * 180 / kPi;
    double phi_lo = 0, phi_span = 2 * kPi;
    if (view.anisotropic) {  // incidence azimuths of the table itself
        const Axis& a = view.lt->axes()[view.axis_phi_i];
        const double scale = a.unit == "rad" ? 1.0 : kPi / 180.0;
        phi_lo = a.min * scale;
        phi_span = (a.max - a.min) * scale;
    }
    SplitMix rng{o.seed};
    std::vector<double> err;
    std::vector<double> ref;
    std::vector<double> got;
    for (std::size_t k = 0; k < o.error_pairs; ++k) {
        // Cosine-weighted (uniform in projected solid angle): the weight each
        // direction has in rendered radiance, cos theta_i cos theta_o.
        const double ci = std::sqrt(1 - rng.uniform() * (1 - std::cos(ti) * std::cos(ti)));
        const double co = std::sqrt(1 - rng.uniform() * (1 - std::cos(to) * std::cos(to)));
        const double pi = phi_lo + rng.uniform() * phi_span, po = rng.uniform() * 2 * kPi;
        const Vec3 wi = spherical(std::acos(ci), pi), wo = spherical(std::acos(co), po);
        if (!(wi.z > 0) || !(wo.z > 0)) continue;
        for (int c = 0; c < view.channels; ++c) {
            // The table's frame: the file's frame folded as the plugin folds it,
            // then turned back by pi (identity inside the table's phi_i range).
            Vec3 a = wi, b = wo;
            view.reduce(a, b);
            ref.push_back(view.eval(a, b, c));
            got.push_back(r.eval(wi, wo, r.channels == 3 ? c : 0, view) / wo.z);
        }
    }
    double mean = 0;
    for (double v : ref) mean += std::abs(v) / double(ref.size());
    for (std::size_t k = 0; k < ref.size(); ++k)
        err.push_back(std::abs(got[k] - ref[k]) / std::max(std::abs(ref[k]), 1e-3 * mean));
    e.pairs = ref.size() / std::size_t(view.channels);
    if (err.empty()) return e;
    std::sort(err.begin(), err.end());
    auto quantile = [&](double q) { return err[std::min(err.size() - 1, std::size_t(q * (err.size() - 1) + 0.5))]; };
    e.median = quantile(0.5);
    e.p99 = quantile(0.99);
    e.max = err.back();
    return e;
}

}  // namespace

RglExportReport export_rgl(const LookupTable& table, const std::string& out_path, const RglExportOptions& options) {
    const TableData& t = table.table();
    const std::string where = "RGL export of table '" + t.name + "': ";
    if (options.resolution != 0 && (options.resolution < 2 || options.resolution > 512))
        throw InputError(where + "--rgl-res " + std::to_string(options.resolution) + " is outside [2, 512] (0: 96 isotropic, 64 anisotropic)");
    if (options.ndf_resolution < 2 || options.ndf_resolution > 1024)
        throw InputError(where + "--rgl-ndf-res " + std::to_string(options.ndf_resolution) +
                         " is outside [2, 1024]");
    if (options.theta_i_count < 0 || options.theta_i_count == 1 || options.theta_i_count > 1024)
        throw InputError(where + "--rgl-theta-i " + std::to_string(options.theta_i_count) +
                         " is outside [2, 1024] (0: the table's own nodes)");
    if (options.phi_i_count < 0 || options.phi_i_count == 1 || options.phi_i_count > 1024)
        throw InputError(where + "--rgl-phi-i " + std::to_string(options.phi_i_count) +
                         " is outside [2, 1024] (0: the table's own count, refined)");
    if (options.spectral && options.rgb)
        throw InputError(where + "--spectral writes one flat spectrum: give the parameter with --slice, "
                         "not --rgb");
    RglExportReport report;
    const TableView view = check_table(table, options, report);
    {
        const Vec3 z{0, 0, 1};
        view.eval(z, z, 0);  // a missing parameter throws here, before any work
    }

    RglData r;
    r.anisotropic = view.anisotropic;
    r.reduction = view.reduction;
    r.n = options.resolution > 0 ? options.resolution : view.anisotropic ? 64 : 96;
    r.nd = options.ndf_resolution;
    r.nd_phi = view.anisotropic ? options.ndf_resolution : 2;
    r.channels = options.spectral ? 2 : 3;
    r.theta_i = theta_i_nodes(view, options.theta_i_count);
    if (view.anisotropic) {
        const Axis& a = t.axes[view.axis_phi_i];
        // Evenly spaced over the reduced range: the table's node count with each
        // interval split into steps of at most 3.75 degrees (a uniform table
        // axis keeps its nodes), or the count asked for.
        std::size_t np = std::size_t(options.phi_i_count);
        if (np == 0) {
            const std::size_t cells = std::max<std::size_t>(1, a.count - 1);
            const double step = 360.0 / view.reduction / double(cells);
            np = cells * std::size_t(std::max(1.0, std::ceil(step / 3.75 - 1e-9))) + 1;
        }
        for (std::size_t k = 0; k < np; ++k)
            r.phi_i.push_back(float(-kPi + 2 * kPi / view.reduction * double(k) / double(np - 1)));
    } else {
        r.phi_i = {0.0f};
    }
    if (options.spectral) r.wavelengths = {360.0f, 830.0f};
    r.ndf = ndf_grid(view, r.nd, r.nd_phi, report.distribution);
    r.derived = report.distribution.rfind("derived", 0) == 0;
    r.sigma = sigma_grid(r.ndf, r.nd, r.nd_phi, view.anisotropic);
    const std::size_t nn = std::size_t(r.n) * r.n;
    r.vndf.assign(r.slices() * nn, 0.0f);
    r.luminance.assign(r.slices() * nn, 0.0f);
    r.values.assign(r.slices() * r.channels * nn, 0.0f);
    r.vndf_warp.resize(r.slices());
    for (std::size_t s = 0; s < r.slices(); ++s) build_slice(r, s, view, r.channels);
    for (float v : r.values)
        if (!std::isfinite(v))
            throw InputError(where + "a resampled value is NaN or infinite (the table holds one, or its "
                             "back-scattering vanishes where it reflects)");

    report.theta_i_nodes = r.theta_i.size();
    report.phi_i_nodes = r.phi_i.size();
    report.reduction = r.reduction;
    report.resolution = r.n;
    report.error = measure(r, view, options);

    std::string desc = "brdftab " BRDFTAB_VERSION ": table '" + t.name + "' (model " + t.model + ")";
    if (!options.source.empty()) desc += " of " + options.source;
    for (const auto& kv : options.parameters) desc += ", " + kv.first + " = " + num(kv.second);
    if (options.rgb) {
        const std::string rp = table.coordinate_names().back();
        desc += ", " + rp + " = " + num(options.rgb_values[0]) + "/" + num(options.rgb_values[1]) + "/" +
                num(options.rgb_values[2]) + " (R/G/B)";
    }
    desc += "; microfacet distribution: " + report.distribution + "; resampling error against the table (" +
            std::to_string(report.error.pairs) + " random direction pairs, theta_i <= " +
            num(report.error.theta_i_max_deg) + ", theta_o <= " + num(report.error.theta_o_max_deg) +
            " deg): median " + num(report.error.median) + ", p99 " + num(report.error.p99) + ", max " +
            num(report.error.max) + " (relative)";
    report.description = desc;

    const std::uint64_t np = r.phi_i.size(), nt = r.theta_i.size(), n = std::uint64_t(r.n);
    std::vector<Field> fields;
    Field d{"description", 1, {desc.size()}, std::vector<unsigned char>(desc.begin(), desc.end())};
    fields.push_back(d);
    fields.push_back(Field{"jacobian", 1, {1}, {1}});
    fields.push_back(float_field("theta_i", {nt}, r.theta_i));
    fields.push_back(float_field("phi_i", {np}, r.phi_i));
    fields.push_back(float_field("ndf", {std::uint64_t(r.nd_phi), std::uint64_t(r.nd)}, r.ndf));
    fields.push_back(float_field("sigma", {std::uint64_t(r.nd_phi), std::uint64_t(r.nd)}, r.sigma));
    fields.push_back(float_field("vndf", {np, nt, n, n}, r.vndf));
    fields.push_back(float_field("luminance", {np, nt, n, n}, r.luminance));
    if (options.spectral) {
        fields.push_back(float_field("wavelengths", {r.wavelengths.size()}, r.wavelengths));
        fields.push_back(float_field("spectra", {np, nt, r.wavelengths.size(), n, n}, r.values));
    } else {
        fields.push_back(float_field("rgb", {np, nt, 3, n, n}, r.values));
    }
    const std::vector<unsigned char> bytes = tensor_file(fields);

    AtomicOutput tmp(out_path);
    std::FILE* f = std::fopen(tmp.path().c_str(), "wb");
    if (!f) throw Error("cannot create '" + tmp.path() + "': " + std::strerror(errno));
    const bool ok = std::fwrite(bytes.data(), 1, bytes.size(), f) == bytes.size();
    if (std::fclose(f) != 0 || !ok) throw Error("cannot write RGL file '" + out_path + "': " + std::strerror(errno));
    tmp.commit();
    return report;
}

}  // namespace brdftab
