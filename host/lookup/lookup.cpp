// lookup.cpp — interpolation, direction-level evaluation and importance
// sampling of brdftab tables (docs/lookup.md).
#include "host/lookup/lookup.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "host/core/error.h"
#include "host/core/text.h"
#include "host/io/table_io.h"

namespace brdftab {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

std::string fmt_num(double v) { return number_text(v, 10); }

std::string range_text(const Axis& a) {
    std::string r = "[" + fmt_num(a.min) + ", " + fmt_num(a.max) + "]";
    if (!a.unit.empty()) r += " " + a.unit;
    return r;
}

// Validate a coordinate against its axis and apply the out-of-range policy.
// A tolerance of 1e-9 of the span absorbs rounding (e.g. acos at 90 degrees).
double resolve(const Axis& a, double x, OutOfRange mode, const std::string& table) {
    if (std::isnan(x))
        throw InputError("table '" + table + "': axis '" + a.name + "' value is NaN");
    const double tol = 1e-9 * (a.max - a.min);
    if (x < a.min || x > a.max) {
        if (mode == OutOfRange::Reject && (x < a.min - tol || x > a.max + tol))
            throw InputError("table '" + table + "': axis '" + a.name + "' value " +
                             fmt_num(x) + " is outside " + range_text(a));
        x = std::min(std::max(x, a.min), a.max);
    }
    return x;
}

// Sparse 1-D interpolation weights over real node indices of one axis.
struct AxisWeights {
    std::size_t idx[4];
    double w[4];
    int n = 0;
    void add(std::size_t i, double wt) {
        for (int k = 0; k < n; ++k)
            if (idx[k] == i) {
                w[k] += wt;
                return;
            }
        idx[n] = i;
        w[n] = wt;
        ++n;
    }
    void single(std::size_t i) {
        n = 0;
        add(i, 1.0);
    }
};

bool is_mirror_phi(const Axis& a) {
    return a.name == "phi_d" && a.spacing == Spacing::Linear &&
           std::fabs(a.min) < 1e-9 &&
           (a.unit == "rad" ? std::fabs(a.max - kPi) < 1e-9 : std::fabs(a.max - 180.0) < 1e-9);
}

// Weights of the (already range-resolved) coordinate x on axis a, computed in
// the warped coordinate u = unwarp(x) * (count - 1) (node k at u = k).
void axis_weights(const Axis& a, double x, Interpolation interp, AxisWeights& out) {
    const std::size_t n = a.count;
    out.n = 0;
    double u = a.unwarp(x) * double(n - 1);
    if (!(u >= 0)) u = 0;  // also catches NaN from a degenerate warp
    if (u > double(n - 1)) u = double(n - 1);
    std::size_t k = std::min<std::size_t>(std::size_t(u), n - 2);
    const double s = std::min(std::max(u - double(k), 0.0), 1.0);
    if (interp == Interpolation::Linear) {
        out.add(k, 1.0 - s);
        out.add(k + 1, s);
        return;
    }
    // Uniform Catmull-Rom in u: Hermite with central-difference slopes.
    const double s2 = s * s, s3 = s2 * s;
    const double wm = 0.5 * (-s3 + 2 * s2 - s);
    const double w0 = 0.5 * (3 * s3 - 5 * s2 + 2);
    const double w1 = 0.5 * (-3 * s3 + 4 * s2 + s);
    const double w2 = 0.5 * (s3 - s2);
    const bool mirror = is_mirror_phi(a);
    out.add(k, w0);
    out.add(k + 1, w1);
    // Ghost below node 0.
    if (k >= 1) {
        out.add(k - 1, wm);
    } else if (mirror) {
        out.add(1, wm);  // f(-h) = f(h): even about phi_d = 0
    } else if (n >= 3) {
        out.add(0, 3 * wm);  // quadratic extrapolation: p(-1) = 3p0 - 3p1 + p2
        out.add(1, -3 * wm);
        out.add(2, wm);
    } else {
        out.add(0, 2 * wm);  // linear: p(-1) = 2p0 - p1
        out.add(1, -wm);
    }
    // Ghost above node n-1.
    if (k + 2 <= n - 1) {
        out.add(k + 2, w2);
    } else if (mirror) {
        out.add(n - 2, w2);  // even about phi_d = 180
    } else if (n >= 3) {
        out.add(n - 1, 3 * w2);
        out.add(n - 2, -3 * w2);
        out.add(n - 3, w2);
    } else {
        out.add(n - 1, 2 * w2);
        out.add(n - 2, -w2);
    }
}

// Tensor-product contraction of per-axis weights with a row-major array.
double contract(const AxisWeights* ws, const std::size_t* strides, std::size_t dims,
                const double* values, std::size_t d = 0, std::size_t offset = 0) {
    if (d == dims) return values[offset];
    double sum = 0;
    for (int k = 0; k < ws[d].n; ++k) {
        if (ws[d].w[k] == 0) continue;
        sum += ws[d].w[k] *
               contract(ws, strides, dims, values, d + 1, offset + ws[d].idx[k] * strides[d]);
    }
    return sum;
}

double horner(const std::vector<double>& c, double p) {
    double r = 0;
    for (std::size_t k = c.size(); k-- > 0;) r = r * p + c[k];
    return r;
}

std::vector<double> number_list(const nlohmann::json& j, const std::string& where) {
    if (!j.is_array() || j.empty())
        throw InputError(where + ": expected a non-empty array of numbers");
    std::vector<double> v;
    for (const auto& e : j) {
        if (!e.is_number()) throw InputError(where + ": expected a non-empty array of numbers");
        v.push_back(e.get<double>());
    }
    return v;
}

// Table names a "recombine" object refers to (validated shape).
std::vector<std::string> recombine_tables(const TableData& head) {
    std::vector<std::string> names;
    if (!head.parameters.is_object() || !head.parameters.contains("recombine")) return names;
    const auto& r = head.parameters["recombine"];
    const std::string where = "table '" + head.name + "': parameters.recombine";
    if (!r.is_object() || !r.contains("terms") || !r["terms"].is_array() || r["terms"].empty())
        throw InputError(where + ": expected an object with a non-empty 'terms' array");
    for (const auto& t : r["terms"]) {
        if (!t.is_object() || !t.contains("table") || !t["table"].is_string())
            throw InputError(where + ".terms: each term needs a string 'table'");
        names.push_back(t["table"].get<std::string>());
    }
    return names;
}

void check_table(TableData& t) {
    const std::string where = "table '" + t.name + "'";
    if (t.axes.empty()) throw InputError(where + ": has no axes");
    std::size_t cells = 1;
    for (auto& a : t.axes) {
        if (a.count < 2)
            throw InputError(where + ": axis '" + a.name + "' needs at least 2 nodes");
        if (a.values.empty()) {
            for (std::size_t k = 0; k < a.count; ++k)
                a.values.push_back(a.warp(double(k) / double(a.count - 1)));
        }
        if (a.values.size() != a.count)
            throw InputError(where + ": axis '" + a.name + "' has " +
                             std::to_string(a.values.size()) + " values for count " +
                             std::to_string(a.count));
        for (std::size_t k = 1; k < a.count; ++k)
            if (!(a.values[k] > a.values[k - 1]))
                throw InputError(where + ": axis '" + a.name + "' nodes must increase");
        cells *= a.count;
    }
    if (t.value.size() != cells)
        throw InputError(where + ": value has " + std::to_string(t.value.size()) +
                         " entries, axes need " + std::to_string(cells));
}

bool same_axes(const std::vector<Axis>& a, const std::vector<Axis>& b) {
    if (a.size() != b.size()) return false;
    for (std::size_t d = 0; d < a.size(); ++d) {
        if (a[d].name != b[d].name || a[d].count != b[d].count) return false;
        for (std::size_t k = 0; k < a[d].count; ++k) {
            const double scale = std::max(1.0, std::fabs(a[d].values[k]));
            if (std::fabs(a[d].values[k] - b[d].values[k]) > 1e-12 * scale) return false;
        }
    }
    return true;
}

// Radians per axis unit for angular axes.
double angle_scale(const Axis& a, const std::string& table) {
    if (a.unit == "deg" || a.unit == "degree" || a.unit == "degrees") return kDeg;
    if (a.unit == "rad") return 1.0;
    throw InputError("table '" + table + "': angular axis '" + a.name + "' has unit '" +
                     a.unit + "' (expected 'deg' or 'rad')");
}

double wrap_pi(double d) {  // into (-pi, pi]
    d = std::fmod(d, 2 * kPi);
    if (d > kPi) d -= 2 * kPi;
    if (d <= -kPi) d += 2 * kPi;
    return d;
}

Vec3 normalised(const Vec3& v) {
    const double l = std::sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
    if (!(l > 0)) throw InputError("direction vector has zero or NaN length");
    return {v.x / l, v.y / l, v.z / l};
}

// Shared by LookupTable::eval_dirs and BoundTable: angular coordinates of
// (wi, wo) in axis units.  phi is reduced to the phi axis' span (fold or wrap).
void direction_coords(const LookupTable::AngleLayout& L, const Axis* phi_axis,
                      const Vec3& wi_in, const Vec3& wo_in, double& xi, double& xo,
                      double& xphi, double& phi_i) {
    const Vec3 wi = normalised(wi_in), wo = normalised(wo_in);
    const double mi = std::min(1.0, std::max(-1.0, wi.z));
    const double mo = std::min(1.0, std::max(-1.0, wo.z));
    xi = L.mu_i ? mi : std::acos(mi) / L.scale_i;
    xo = L.mu_o ? mo : std::acos(mo) / L.scale_o;
    // atan2(0, 0) = 0: a direction on the pole gets azimuth 0, both here and
    // in the sampler, so pdf() and sample() agree there too.
    phi_i = std::atan2(wi.y, wi.x);
    const double d = wrap_pi(std::atan2(wo.y, wo.x) - phi_i);
    xphi = 0;
    if (!phi_axis) return;
    if (L.fold_phi) {
        xphi = std::fabs(d) / L.scale_phi;  // isotropy: f(phi_d) = f(-phi_d)
    } else {
        const double period = 2 * kPi / L.scale_phi;
        double v = std::fmod(d / L.scale_phi - phi_axis->min, period);
        if (v < 0) v += period;
        xphi = phi_axis->min + v;
    }
}

}  // namespace

// ---------------------------------------------------------------------------
// LookupTable

LookupTable::LookupTable(TableData table) {
    pieces_.push_back(std::move(table));
    init();
}

LookupTable LookupTable::from_tables(const std::vector<TableData>& tables,
                                     const std::string& name) {
    auto find = [&](const std::string& n) -> const TableData* {
        for (const auto& t : tables)
            if (t.name == n) return &t;
        return nullptr;
    };
    const TableData* head = find(name);
    if (!head) throw InputError("table '" + name + "' is not among the given tables");
    LookupTable lt;
    lt.pieces_.push_back(*head);
    for (const auto& n : recombine_tables(*head)) {
        if (n == name) continue;
        bool have = false;
        for (const auto& p : lt.pieces_) have = have || p.name == n;
        if (have) continue;
        const TableData* t = find(n);
        if (!t)
            throw InputError("table '" + name + "': parameters.recombine names table '" + n +
                             "', which is missing");
        lt.pieces_.push_back(*t);
    }
    lt.init();
    return lt;
}

LookupTable LookupTable::open(const std::string& path, const std::string& table) {
    std::vector<TableData> tables;
    tables.push_back(read_table(path, table));
    for (const auto& n : recombine_tables(tables.front())) {
        bool have = false;
        for (const auto& t : tables) have = have || t.name == n;
        if (!have) tables.push_back(read_table(path, n));
    }
    try {
        return from_tables(tables, table);
    } catch (const InputError& e) {
        throw InputError(path + ": " + e.what());
    }
}

void LookupTable::init() {
    TableData& head = pieces_.front();
    for (auto& p : pieces_) check_table(p);
    for (std::size_t k = 1; k < pieces_.size(); ++k)
        if (!same_axes(head.axes, pieces_[k].axes))
            throw InputError("table '" + head.name + "': recombine term table '" +
                             pieces_[k].name + "' has different axes");
    const std::size_t dims = head.axes.size();
    strides_.assign(dims, 1);
    for (std::size_t d = dims - 1; d-- > 0;) strides_[d] = strides_[d + 1] * head.axes[d + 1].count;

    // Recombination.
    if (head.parameters.is_object() && head.parameters.contains("recombine")) {
        const auto& r = head.parameters["recombine"];
        const std::string where = "table '" + head.name + "': parameters.recombine";
        recombine_tables(head);  // shape check
        if (!r.contains("parameter") || !r["parameter"].is_string() ||
            r["parameter"].get<std::string>().empty())
            throw InputError(where + ": needs a string 'parameter'");
        rparam_ = r["parameter"].get<std::string>();
        for (const auto& a : head.axes)
            if (a.name == rparam_)
                throw InputError(where + ": parameter '" + rparam_ + "' is also a table axis");
        if (r.contains("range")) {
            auto rg = number_list(r["range"], where + ".range");
            if (rg.size() != 2 || !(rg[0] <= rg[1]))
                throw InputError(where + ".range: expected [min, max] with min <= max");
            rmin_ = rg[0];
            rmax_ = rg[1];
        }
        for (const auto& t : r["terms"]) {
            Term term;
            const std::string name = t["table"].get<std::string>();
            term.piece = pieces_.size();
            for (std::size_t k = 0; k < pieces_.size(); ++k)
                if (pieces_[k].name == name) term.piece = k;
            if (term.piece == pieces_.size())
                throw InputError(where + ": term table '" + name + "' is missing");
            if (!t.contains("coeffs"))
                throw InputError(where + ".terms: term '" + name + "' needs 'coeffs'");
            term.coeffs = number_list(t["coeffs"], where + ".terms." + name + ".coeffs");
            terms_.push_back(term);
        }
        if (r.contains("prefactor")) {
            const auto& pf = r["prefactor"];
            if (!pf.is_object()) throw InputError(where + ".prefactor: expected an object");
            if (pf.contains("num")) num_ = number_list(pf["num"], where + ".prefactor.num");
            if (pf.contains("den")) den_ = number_list(pf["den"], where + ".prefactor.den");
        }
    }

    // Angular layout.
    AngleLayout L;
    for (std::size_t d = 0; d < dims; ++d) {
        const std::string& n = head.axes[d].name;
        if (n == "theta_i" || n == "mu_i") {
            L.axis_i = int(d);
            L.mu_i = n == "mu_i";
        } else if (n == "theta_o" || n == "mu_o") {
            L.axis_o = int(d);
            L.mu_o = n == "mu_o";
        } else if (n == "phi_d") {
            L.axis_phi = int(d);
        }
    }
    directional_ = L.axis_i >= 0 && L.axis_o >= 0;
    for (const auto& a : head.axes)
        if (a.name == "phi_i" || a.name == "phi_o") directional_ = false;
    if (!directional_) {
        directional_error_ = "table '" + head.name +
                             "': direction-level lookup needs axes theta_i|mu_i, "
                             "theta_o|mu_o and optionally phi_d (isotropic tables only)";
    } else {
        const Axis& ai = head.axes[L.axis_i];
        const Axis& ao = head.axes[L.axis_o];
        if (!L.mu_i) L.scale_i = angle_scale(ai, head.name);
        if (!L.mu_o) L.scale_o = angle_scale(ao, head.name);
        if (L.axis_phi >= 0) {
            const Axis& ap = head.axes[L.axis_phi];
            L.scale_phi = angle_scale(ap, head.name);
            L.fold_phi = ap.min * L.scale_phi >= -1e-12 && ap.max * L.scale_phi <= kPi + 1e-12;
        } else {
            L.scale_phi = kDeg;
        }
    }
    layout_ = L;

    // Reciprocal half tables: complete the unstored half from f(i,o) = f(o,i).
    if (head.parameters.is_object() && head.parameters.contains("reciprocal_half")) {
        const auto& rh = head.parameters["reciprocal_half"];
        if (!rh.is_boolean())
            throw InputError("table '" + head.name + "': parameters.reciprocal_half must be a boolean");
        if (rh.get<bool>()) {
            if (!directional_) throw InputError(directional_error_ + " (reciprocal_half)");
            const Axis& ai = head.axes[L.axis_i];
            const Axis& ao = head.axes[L.axis_o];
            bool same = L.mu_i == L.mu_o && ai.count == ao.count && L.scale_i == L.scale_o;
            for (std::size_t k = 0; same && k < ai.count; ++k)
                same = std::fabs(ai.values[k] - ao.values[k]) <=
                       1e-12 * std::max(1.0, std::fabs(ai.values[k]));
            if (!same)
                throw InputError("table '" + head.name +
                                 "': reciprocal_half needs identical incident and "
                                 "outgoing axes");
            const std::size_t si = strides_[L.axis_i], so = strides_[L.axis_o];
            const std::size_t n = ai.count;
            for (auto& p : pieces_) {
                for (std::size_t flat = 0; flat < p.value.size(); ++flat) {
                    const std::size_t ii = (flat / si) % n, io = (flat / so) % n;
                    // Stored half: theta_i <= theta_o, i.e. index_i <= index_o on
                    // theta axes and index_i >= index_o on mu axes.
                    const bool stored = L.mu_i ? ii >= io : ii <= io;
                    if (stored) continue;
                    const std::size_t mirror = flat - ii * si - io * so + io * si + ii * so;
                    p.value[flat] = p.value[mirror];
                    if (p.stderr_.size() == p.value.size()) p.stderr_[flat] = p.stderr_[mirror];
                }
            }
        }
    }
}

std::vector<std::string> LookupTable::coordinate_names() const {
    std::vector<std::string> names;
    for (const auto& a : axes()) names.push_back(a.name);
    if (!terms_.empty()) names.push_back(rparam_);
    return names;
}

void LookupTable::resolve_param(double& p, OutOfRange mode) const {
    if (std::isnan(p))
        throw InputError("table '" + table().name + "': parameter '" + rparam_ + "' is NaN");
    if (p < rmin_ || p > rmax_) {
        if (mode == OutOfRange::Reject)
            throw InputError("table '" + table().name + "': parameter '" + rparam_ + "' value " +
                             fmt_num(p) + " is outside [" + fmt_num(rmin_) + ", " +
                             fmt_num(rmax_) + "]");
        p = std::min(std::max(p, rmin_), rmax_);
    }
}

double LookupTable::combine(const std::vector<double>& pv, double p) const {
    if (terms_.empty()) return pv[0];
    double sum = 0;
    for (const auto& t : terms_) sum += horner(t.coeffs, p) * pv[t.piece];
    const double den = horner(den_, p);
    if (den == 0)
        throw InputError("table '" + table().name + "': recombination prefactor has a zero "
                         "denominator at " + rparam_ + " = " + fmt_num(p));
    return horner(num_, p) / den * sum;
}

double LookupTable::eval(const std::vector<double>& coords, Interpolation interp,
                         OutOfRange mode) const {
    const auto& ax = axes();
    const std::size_t dims = ax.size();
    const std::size_t want = dims + (terms_.empty() ? 0 : 1);
    if (coords.size() != want)
        throw InputError("table '" + table().name + "': eval needs " + std::to_string(want) +
                         " coordinates, got " + std::to_string(coords.size()));
    std::vector<AxisWeights> ws(dims);
    for (std::size_t d = 0; d < dims; ++d)
        axis_weights(ax[d], resolve(ax[d], coords[d], mode, table().name), interp, ws[d]);
    double p = 0;
    if (!terms_.empty()) {
        p = coords[dims];
        resolve_param(p, mode);
    }
    std::vector<double> pv(pieces_.size());
    for (std::size_t k = 0; k < pieces_.size(); ++k)
        pv[k] = contract(ws.data(), strides_.data(), dims, pieces_[k].value.data());
    return combine(pv, p);
}

double LookupTable::eval(const std::map<std::string, double>& coords, Interpolation interp,
                         OutOfRange mode) const {
    const auto names = coordinate_names();
    std::vector<double> v;
    for (const auto& n : names) {
        auto it = coords.find(n);
        if (it == coords.end())
            throw InputError("table '" + table().name + "': coordinate '" + n + "' is missing");
        v.push_back(it->second);
    }
    for (const auto& kv : coords)
        if (std::find(names.begin(), names.end(), kv.first) == names.end())
            throw InputError("table '" + table().name + "': unknown coordinate '" + kv.first +
                             "'");
    return eval(v, interp, mode);
}

// Coordinates of the non-angle axes from `params` (NaN in angle slots).
std::vector<double> LookupTable::param_coords(const std::map<std::string, double>& params,
                                              double* p_out) const {
    if (!directional_) throw InputError(directional_error_);
    const auto& ax = axes();
    std::vector<double> v(ax.size() + (terms_.empty() ? 0 : 1),
                          std::numeric_limits<double>::quiet_NaN());
    std::vector<std::string> used;
    for (std::size_t d = 0; d < ax.size(); ++d) {
        if (int(d) == layout_.axis_i || int(d) == layout_.axis_o || int(d) == layout_.axis_phi)
            continue;
        auto it = params.find(ax[d].name);
        if (it == params.end())
            throw InputError("table '" + table().name + "': parameter '" + ax[d].name +
                             "' is missing (range " + range_text(ax[d]) + ")");
        v[d] = it->second;
        used.push_back(ax[d].name);
    }
    if (!terms_.empty()) {
        auto it = params.find(rparam_);
        if (it == params.end())
            throw InputError("table '" + table().name + "': parameter '" + rparam_ +
                             "' is missing");
        v.back() = it->second;
        used.push_back(rparam_);
        if (p_out) *p_out = it->second;
    }
    for (const auto& kv : params)
        if (std::find(used.begin(), used.end(), kv.first) == used.end())
            throw InputError("table '" + table().name + "': unknown parameter '" + kv.first +
                             "'");
    return v;
}

double LookupTable::eval_dirs(const Vec3& wi, const Vec3& wo,
                              const std::map<std::string, double>& params,
                              Interpolation interp, OutOfRange mode) const {
    std::vector<double> v = param_coords(params, nullptr);
    double xi, xo, xphi, phi_i;
    const Axis* phi_axis = layout_.axis_phi >= 0 ? &axes()[layout_.axis_phi] : nullptr;
    direction_coords(layout_, phi_axis, wi, wo, xi, xo, xphi, phi_i);
    v[layout_.axis_i] = xi;
    v[layout_.axis_o] = xo;
    if (phi_axis) v[layout_.axis_phi] = xphi;
    return eval(v, interp, mode);
}

BoundTable LookupTable::bind(const std::map<std::string, double>& params,
                             Interpolation interp, OutOfRange mode) const {
    std::vector<double> v = param_coords(params, nullptr);
    const auto& ax = axes();
    const std::size_t dims = ax.size();
    std::vector<AxisWeights> ws(dims);
    for (std::size_t d = 0; d < dims; ++d) {
        if (int(d) == layout_.axis_i || int(d) == layout_.axis_o || int(d) == layout_.axis_phi)
            continue;
        axis_weights(ax[d], resolve(ax[d], v[d], mode, table().name), interp, ws[d]);
    }
    double p = 0;
    if (!terms_.empty()) {
        p = v.back();
        resolve_param(p, mode);
    }

    BoundTable b;
    b.name_ = table().name;
    b.layout_ = layout_;
    b.interp_ = interp;
    b.mode_ = mode;
    b.axes_.push_back(ax[layout_.axis_i]);
    b.axes_.push_back(ax[layout_.axis_o]);
    b.has_phi_ = layout_.axis_phi >= 0;
    if (b.has_phi_) {
        b.axes_.push_back(ax[layout_.axis_phi]);
    } else {
        // Azimuth-independent table: a 2-node synthetic phi_d axis over [0, 180]
        // carrying the same value at both nodes.
        Axis a;
        a.name = "phi_d";
        a.unit = "deg";
        a.min = 0;
        a.max = 180;
        a.count = 2;
        a.spacing = Spacing::Linear;
        a.values = {0.0, 180.0};
        b.axes_.push_back(a);
        b.layout_.fold_phi = true;
        b.layout_.scale_phi = kDeg;
    }
    const std::size_t ni = b.axes_[0].count, no = b.axes_[1].count, np = b.axes_[2].count;
    b.values_.resize(ni * no * np);
    std::vector<double> pv(pieces_.size());
    for (std::size_t i = 0; i < ni; ++i)
        for (std::size_t o = 0; o < no; ++o)
            for (std::size_t f = 0; f < np; ++f) {
                ws[layout_.axis_i].single(i);
                ws[layout_.axis_o].single(o);
                if (b.has_phi_) ws[layout_.axis_phi].single(f);
                for (std::size_t k = 0; k < pieces_.size(); ++k)
                    pv[k] = contract(ws.data(), strides_.data(), dims, pieces_[k].value.data());
                b.values_[(i * no + o) * np + f] = combine(pv, p);
            }
    b.build_sampling();
    return b;
}

// ---------------------------------------------------------------------------
// BoundTable

double BoundTable::eval_angles(double xi, double xo, double xphi) const {
    AxisWeights ws[3];
    const double x[3] = {xi, xo, xphi};
    for (int d = 0; d < 3; ++d)
        axis_weights(axes_[d], resolve(axes_[d], x[d], mode_, name_), interp_, ws[d]);
    const std::size_t strides[3] = {axes_[1].count * axes_[2].count, axes_[2].count, 1};
    return contract(ws, strides, 3, values_.data());
}

double BoundTable::eval(const Vec3& wi, const Vec3& wo) const {
    double xi, xo, xphi, phi_i;
    direction_coords(layout_, &axes_[2], wi, wo, xi, xo, xphi, phi_i);
    return eval_angles(xi, xo, xphi);
}

void BoundTable::build_sampling() {
    const Axis& ao = axes_[1];
    const Axis& ap = axes_[2];
    // Coverage: theta_o must span [0, 90] or [0, 180]; phi_d [0, 180] (folded)
    // or a full 360-degree period (wrapped).
    double mu_top, mu_bottom;
    if (layout_.mu_o) {
        mu_top = ao.max;
        mu_bottom = ao.min;
    } else {
        mu_top = std::cos(ao.min * layout_.scale_o);
        mu_bottom = std::cos(ao.max * layout_.scale_o);
    }
    if (std::fabs(mu_top - 1) > 1e-9 ||
        !(std::fabs(mu_bottom) < 1e-9 || std::fabs(mu_bottom + 1) < 1e-9)) {
        sampling_error_ = "table '" + name_ + "': sampling needs the " + ao.name +
                          " axis to cover theta_o in [0, 90] or [0, 180] degrees";
        return;
    }
    const double pspan = (ap.max - ap.min) * layout_.scale_phi;
    if (layout_.fold_phi ? (std::fabs(ap.min) > 1e-9 || std::fabs(pspan - kPi) > 1e-9)
                         : std::fabs(pspan - 2 * kPi) > 1e-9) {
        sampling_error_ = "table '" + name_ +
                          "': sampling needs phi_d to span [0, 180] degrees or a full "
                          "360-degree period";
        return;
    }
    phi_mult_ = layout_.fold_phi ? 2.0 : 1.0;
    const std::size_t ni = axes_[0].count, no = ao.count, np = ap.count;
    mu_nodes_o_.resize(no);
    for (std::size_t k = 0; k < no; ++k)
        mu_nodes_o_[k] = layout_.mu_o ? ao.values[k] : std::cos(ao.values[k] * layout_.scale_o);
    phi_nodes_.resize(np);
    for (std::size_t l = 0; l < np; ++l) phi_nodes_[l] = ap.values[l] * layout_.scale_phi;

    const double g = 0.5 / std::sqrt(3.0);  // 2-point Gauss abscissae at mid +- g * width
    const std::size_t co = no - 1, cp = np - 1;
    dists_.resize(ni);
    for (std::size_t j = 0; j < ni; ++j) {
        const double xi = axes_[0].values[j];
        NodeDist& nd = dists_[j];
        nd.cell_prob.assign(co * cp, 0.0);
        double total = 0;
        for (std::size_t k = 0; k < co; ++k) {
            const double ma = std::min(mu_nodes_o_[k], mu_nodes_o_[k + 1]);
            const double mb = std::max(mu_nodes_o_[k], mu_nodes_o_[k + 1]);
            // Split at mu = 0 so |mu| is smooth on each piece (the integrand
            // is then polynomial enough for 2x2 Gauss to be exact for the
            // multilinear interpolant of a cos-spaced axis).
            double cuts[3] = {ma, mb, mb};
            int pieces = 1;
            if (ma < 0 && mb > 0) {
                cuts[1] = 0;
                pieces = 2;
            }
            const double mean_abs_mu =
                (ma >= 0 ? 0.5 * (ma + mb)
                         : (mb <= 0 ? -0.5 * (ma + mb) : 0.5 * (ma * ma + mb * mb) / (mb - ma)));
            for (std::size_t l = 0; l < cp; ++l) {
                const double pa = phi_nodes_[l], pb = phi_nodes_[l + 1];
                double w = 0;
                for (int s = 0; s < pieces; ++s) {
                    const double a = cuts[s], b = cuts[s + 1];
                    const double mm = 0.5 * (a + b), hm = b - a;
                    const double pm = 0.5 * (pa + pb), hp = pb - pa;
                    for (int q = 0; q < 4; ++q) {
                        const double mu = mm + ((q & 1) ? g : -g) * hm;
                        const double ph = pm + ((q & 2) ? g : -g) * hp;
                        const double xo = layout_.mu_o ? mu : std::acos(mu) / layout_.scale_o;
                        const double f = eval_angles(xi, xo, ph / layout_.scale_phi);
                        w += 0.25 * hm * hp * std::max(f, 0.0) * std::fabs(mu);
                    }
                }
                if (w == 0) {
                    // Keep cells whose corner nodes are positive reachable
                    // (Catmull-Rom may undershoot to 0 at the Gauss points).
                    double corner = 0;
                    for (std::size_t dk = 0; dk < 2; ++dk)
                        for (std::size_t dl = 0; dl < 2; ++dl)
                            corner = std::max(corner,
                                              values_[(j * no + k + dk) * np + l + dl]);
                    w = 1e-3 * corner * mean_abs_mu * (mb - ma) * (pb - pa);
                }
                nd.cell_prob[k * cp + l] = w;
                total += w;
            }
        }
        if (!(total > 0)) {
            // f == 0 for this theta_i: any density works (weights are 0);
            // use uniform in solid angle.
            total = 0;
            for (std::size_t k = 0; k < co; ++k)
                for (std::size_t l = 0; l < cp; ++l) {
                    const double w = std::fabs(mu_nodes_o_[k + 1] - mu_nodes_o_[k]) *
                                     (phi_nodes_[l + 1] - phi_nodes_[l]);
                    nd.cell_prob[k * cp + l] = w;
                    total += w;
                }
        }
        for (auto& w : nd.cell_prob) w /= total;
        nd.cdf_o.assign(no, 0.0);
        nd.cdf_phi.assign(co * np, 0.0);
        for (std::size_t k = 0; k < co; ++k) {
            double row = 0;
            for (std::size_t l = 0; l < cp; ++l) {
                row += nd.cell_prob[k * cp + l];
                nd.cdf_phi[k * np + l + 1] = row;
            }
            for (std::size_t l = 1; l <= cp; ++l)
                nd.cdf_phi[k * np + l] = row > 0 ? nd.cdf_phi[k * np + l] / row : double(l) / cp;
            nd.cdf_phi[k * np + cp] = 1.0;
            nd.cdf_o[k + 1] = nd.cdf_o[k] + row;
        }
        for (std::size_t k = 1; k < no; ++k) nd.cdf_o[k] /= nd.cdf_o[co];
        nd.cdf_o[co] = 1.0;
    }
}

namespace {
// Pick cell c with cdf[c] <= u < cdf[c+1] (never a zero-probability cell) and
// return u rescaled to [0, 1) within it.
std::size_t pick(const double* cdf, std::size_t cells, double& u) {
    u = std::min(std::max(u, 0.0), 1.0);
    std::size_t c = std::size_t(std::upper_bound(cdf, cdf + cells + 1, u) - cdf);
    c = c == 0 ? 0 : c - 1;
    if (c >= cells) c = cells - 1;
    while (c > 0 && !(cdf[c + 1] > cdf[c])) --c;  // u == 1 lands past the last positive cell
    const double width = cdf[c + 1] - cdf[c];
    u = width > 0 ? std::min(std::max((u - cdf[c]) / width, 0.0), 1.0) : 0.5;
    return c;
}
}  // namespace

void BoundTable::node_mixture(double xi, std::size_t& j0, double& w1) const {
    const Axis& a = axes_[0];
    xi = resolve(a, xi, mode_, name_);
    AxisWeights w;
    axis_weights(a, xi, Interpolation::Linear, w);
    j0 = w.idx[0];
    w1 = w.n > 1 ? w.w[1] : 0.0;
}

double BoundTable::node_pdf(std::size_t j, double mu, double phi) const {
    const std::size_t no = mu_nodes_o_.size(), np = phi_nodes_.size();
    const NodeDist& nd = dists_[j];
    // theta_o cell: nodes are ordered by axis value; mu decreases along a theta axis.
    const bool desc = !layout_.mu_o;
    const double lo = desc ? mu_nodes_o_[no - 1] : mu_nodes_o_[0];
    const double hi = desc ? mu_nodes_o_[0] : mu_nodes_o_[no - 1];
    if (mu < lo || mu > hi) return 0;
    std::size_t k;
    if (desc)
        k = std::size_t(std::upper_bound(mu_nodes_o_.begin(), mu_nodes_o_.end(), mu,
                                         [](double a, double b) { return a > b; }) -
                        mu_nodes_o_.begin());
    else
        k = std::size_t(std::upper_bound(mu_nodes_o_.begin(), mu_nodes_o_.end(), mu) -
                        mu_nodes_o_.begin());
    k = std::min(std::max<std::size_t>(k, 1), no - 1) - 1;
    std::size_t l = std::size_t(std::upper_bound(phi_nodes_.begin(), phi_nodes_.end(), phi) -
                                phi_nodes_.begin());
    l = std::min(std::max<std::size_t>(l, 1), np - 1) - 1;
    const double area = phi_mult_ * std::fabs(mu_nodes_o_[k + 1] - mu_nodes_o_[k]) *
                        (phi_nodes_[l + 1] - phi_nodes_[l]);
    return nd.cell_prob[k * (np - 1) + l] / area;
}

double BoundTable::pdf(const Vec3& wi, const Vec3& wo) const {
    if (!can_sample()) throw Error(sampling_error_);
    double xi, xo, xphi, phi_i;
    direction_coords(layout_, &axes_[2], wi, wo, xi, xo, xphi, phi_i);
    const double mu = layout_.mu_o ? xo : std::cos(xo * layout_.scale_o);
    const double phi = xphi * layout_.scale_phi;
    std::size_t j0;
    double w1;
    node_mixture(xi, j0, w1);
    double p = 0;
    if (w1 < 1) p += (1 - w1) * node_pdf(j0, mu, phi);
    if (w1 > 0) p += w1 * node_pdf(j0 + 1, mu, phi);
    return p;
}

SampleResult BoundTable::sample(const Vec3& wi, double u1, double u2) const {
    if (!can_sample()) throw Error(sampling_error_);
    double xi, xo, xphi, phi_i;
    direction_coords(layout_, &axes_[2], wi, Vec3{0, 0, 1}, xi, xo, xphi, phi_i);
    std::size_t j0;
    double w1;
    node_mixture(xi, j0, w1);
    // Choose the theta_i node with probability equal to its interpolation
    // weight, re-using u1.
    std::size_t j = j0;
    u1 = std::min(std::max(u1, 0.0), 1.0);
    if (w1 > 0 && u1 < w1) {
        j = j0 + 1;
        u1 = u1 / w1;
    } else if (w1 < 1) {
        u1 = (u1 - w1) / (1 - w1);
    }
    const NodeDist& nd = dists_[j];
    const std::size_t co = mu_nodes_o_.size() - 1, cp = phi_nodes_.size() - 1;
    const std::size_t k = pick(nd.cdf_o.data(), co, u1);
    const std::size_t l = pick(nd.cdf_phi.data() + k * (cp + 1), cp, u2);
    double sign = 1;
    if (phi_mult_ == 2) {  // mirror: phi_d and -phi_d equally likely
        if (u2 < 0.5) {
            u2 *= 2;
        } else {
            sign = -1;
            u2 = 2 * u2 - 1;
        }
    }
    // Uniform in (cos theta, phi) inside the cell: constant density in solid angle.
    const double mu = mu_nodes_o_[k] + u1 * (mu_nodes_o_[k + 1] - mu_nodes_o_[k]);
    const double pd = phi_nodes_[l] + u2 * (phi_nodes_[l + 1] - phi_nodes_[l]);
    const double phi_o = phi_i + sign * pd;
    const double st = std::sqrt(std::max(0.0, 1 - mu * mu));
    SampleResult r;
    r.wo = {st * std::cos(phi_o), st * std::sin(phi_o), mu};
    r.pdf = pdf(wi, r.wo);
    r.value = eval(wi, r.wo);
    r.weight = r.pdf > 0 ? r.value * std::fabs(mu) / r.pdf : 0.0;
    return r;
}

}  // namespace brdftab
