// lookup.h — renderer-side reader of brdftab tables: interpolation,
// direction-level evaluation and importance sampling (docs/lookup.md).
//
// Depends on table I/O (HDF5) and the axis warps only; no OpenCL.
//
// Thread safety: a LookupTable and a BoundTable are immutable after
// construction.  Every const member function may be called concurrently from
// any number of threads without locking.  bind() builds a new object and does
// not modify the LookupTable.
#pragma once

#include <cstddef>
#include <initializer_list>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "../core/grid.h"
#include "../core/table.h"

namespace brdftab {

struct Vec3 {
    double x = 0, y = 0, z = 0;
};

// How values between nodes are formed.  Both act on each axis' normalised
// coordinate t = Axis::unwarp(x) (node k at t = k/(count-1)), so a "cos"
// axis interpolates linearly in cos(theta), a "log" axis in log(x), etc.
//   Linear  multilinear (tensor product of 1-D linear interpolation).
//   Cubic   tensor product of uniform Catmull-Rom splines in t (C1,
//           reproduces polynomials of degree <= 2 in t).  Missing neighbours
//           at the ends are ghost nodes extrapolated quadratically from the
//           three nearest nodes (linearly for a 2-node axis), except on a
//           linear phi_d axis spanning [0, 180], whose ghosts are mirrored
//           (the function is even about 0 and 180 degrees by isotropy).
//           Catmull-Rom may overshoot: results are not clamped to >= 0.
enum class Interpolation { Linear, Cubic };

// Coordinates outside an axis' [min, max]: clamp to the range, or throw
// InputError naming the axis, the value and the range.  NaN always throws.
enum class OutOfRange { Clamp, Reject };

struct SampleResult {
    Vec3 wo;             // sampled outgoing direction (unit, z = macro normal)
    double pdf = 0;      // density of wo w.r.t. solid angle (1/sr)
    double value = 0;    // interpolated table value f(wi, wo)
    double weight = 0;   // value * |cos theta_o| / pdf (0 when pdf == 0)
};

class BoundTable;

class LookupTable {
public:
    // Read table `table` from a brdftab HDF5 file.  If its parameters carry a
    // "recombine" object (see below), the tables it names are read from the
    // same file.  Throws InputError (missing file/table, inconsistent axes).
    static LookupTable open(const std::string& path, const std::string& table);

    // From in-memory tables: `tables` must contain `name` and every table its
    // "recombine" object names.  Throws InputError.
    static LookupTable from_tables(const std::vector<TableData>& tables,
                                   const std::string& name);
    explicit LookupTable(TableData table);

    // Metadata of the (head) table: name, model, quantity, units, parameters,
    // provenance.  Its `value` array is the stored one (after the reciprocal
    // completion described under eval_dirs).
    const TableData& table() const { return pieces_.front(); }
    const std::vector<Axis>& axes() const { return pieces_.front().axes; }
    const nlohmann::json& parameters() const { return pieces_.front().parameters; }
    const std::string& units() const { return pieces_.front().units; }
    const std::string& model() const { return pieces_.front().model; }
    const std::string& quantity() const { return pieces_.front().quantity; }

    // Names eval() expects, in order: the table axes, then the recombination
    // parameter if the table has one.
    std::vector<std::string> coordinate_names() const;
    bool has_recombination() const { return !terms_.empty(); }

    // Interpolated value at `coords` (user units, the order of
    // coordinate_names()).  Throws InputError on a wrong count, NaN, or
    // (Reject) an out-of-range coordinate.
    double eval(const std::vector<double>& coords,
                Interpolation interp = Interpolation::Linear,
                OutOfRange mode = OutOfRange::Clamp) const;
    // Braced lists of numbers, e.g. eval({30.0, 0.5}) (avoids ambiguity with
    // the map overload).
    double eval(std::initializer_list<double> coords,
                Interpolation interp = Interpolation::Linear,
                OutOfRange mode = OutOfRange::Clamp) const {
        return eval(std::vector<double>(coords), interp, mode);
    }
    // Same with named coordinates; every name of coordinate_names() is
    // required and unknown names are rejected (InputError).
    double eval(const std::map<std::string, double>& coords,
                Interpolation interp = Interpolation::Linear,
                OutOfRange mode = OutOfRange::Clamp) const;

    // Coordinates in coordinate_names() order from named values.  An unknown
    // or missing name is an InputError that starts with `where` and lists the
    // table's coordinates (the message of `brdftab query` and of the Python
    // module).
    std::vector<double> ordered_coordinates(const std::map<std::string, double>& values,
                                            const std::string& where) const;

    // Vectorised eval: `count` points, row-major, each row the coordinates
    // of coordinate_names() in that order; one value per point into `out`.
    // The same checks and messages as eval(); the first bad point throws.
    void eval_many(const double* coords, std::size_t count, double* out,
                   Interpolation interp = Interpolation::Linear,
                   OutOfRange mode = OutOfRange::Clamp) const;

    // The cells eval(coords, interp, mode) reads with a non-zero weight, as
    // flat row-major indices into the stored value array, appended to
    // `cells` (the interpolation stencil: up to 2 nodes per axis for Linear,
    // 4 for Cubic, fewer at the ends, in t on a dependent axis).  Only the
    // table axes of `coords` are read.  For computing a table's values
    // lazily where a lookup needs them (host/plan/certify.h).
    void stencil_cells(const std::vector<double>& coords, Interpolation interp,
                       OutOfRange mode, std::vector<std::size_t>& cells) const;

    // Direction-level evaluation for isotropic BRDF-like tables whose axes are
    // theta_i|mu_i, theta_o|mu_o, optionally phi_d, plus parameter axes.
    // wi, wo: unit vectors pointing away from the surface, z = macro normal.
    // phi_d = phi_o - phi_i is reduced to the axis' span: folded to |phi_d| in
    // [0, 180] when the axis lies within [0, 180] (isotropy), otherwise
    // wrapped into [min, min + 360).  A table without phi_d axis is taken as
    // independent of azimuth.  `params` gives every parameter axis and the
    // recombination parameter by name.
    // Tables with parameters["reciprocal_half"] == true store only
    // theta_i <= theta_o; the other half is completed on load from
    // f(i, o) = f(o, i) (requires identical theta_i/theta_o axes).
    double eval_dirs(const Vec3& wi, const Vec3& wo,
                     const std::map<std::string, double>& params = {},
                     Interpolation interp = Interpolation::Linear,
                     OutOfRange mode = OutOfRange::Clamp) const;

    // Fix every non-angle coordinate: returns a table over (wi, wo) only,
    // holding the importance-sampling distributions.  Cost: one pass over the
    // angular grid (a few evaluations per theta_i x theta_o x phi_d cell).
    BoundTable bind(const std::map<std::string, double>& params = {},
                    Interpolation interp = Interpolation::Linear,
                    OutOfRange mode = OutOfRange::Clamp) const;

    // ---- recombination -------------------------------------------------
    // A table may carry in its parameters
    //   "recombine": {"parameter": "c", "range": [0, 1],           (range optional)
    //                 "terms": [{"table": "order1", "coeffs": [0, 1]}, ...],
    //                 "prefactor": {"num": [..], "den": [..]}}       (optional)
    // meaning value = N(p)/D(p) * sum_k C_k(p) * table_k(x), with N, D, C_k
    // polynomials in the user parameter p (coefficients of p^0, p^1, ...).
    // All term tables must share the head table's axes.
    struct Term {
        std::size_t piece;            // index into pieces_
        std::vector<double> coeffs;   // C_k
    };

    // Internal helpers shared with BoundTable (public for the implementation
    // file only; not part of the stable API).
    struct AngleLayout {
        int axis_i = -1, axis_o = -1, axis_phi = -1;  // indices into axes()
        bool mu_i = false, mu_o = false;              // mu axes instead of theta
        double scale_i = 1, scale_o = 1, scale_phi = 1;  // radians per unit (deg or rad)
        bool fold_phi = true;   // phi_d axis within [0, 180]: fold by isotropy
    };

private:
    LookupTable() = default;
    void init();
    void init_recombination();
    double combine(const std::vector<double>& piece_values, double p) const;
    void resolve_param(double& p, OutOfRange mode) const;
    std::vector<double> param_coords(const std::map<std::string, double>& params,
                                     double* p_out) const;

    std::vector<TableData> pieces_;  // pieces_[0] is the head table
    std::vector<std::size_t> strides_;
    // Per axis: the index of the axis its nodes depend on (critical), or -1.
    std::vector<int> dependency_;
    // Recombination (empty terms_: value = pieces_[0]).
    std::vector<Term> terms_;
    std::string rparam_;
    double rmin_ = -1e300, rmax_ = 1e300;
    std::vector<double> num_{1.0}, den_{1.0};
    AngleLayout layout_;
    bool directional_ = false;
    std::string directional_error_;

    friend class BoundTable;
};

// The table with its own stored values only: the "recombine" recipe (if
// any) removed from its parameters.
TableData without_recombination(const TableData& table);

// A lookup over the per-cell standard errors of `lt`'s table (same axes and
// interpolation), or null when the table stores none (closed form) or is
// recombined from several tables.
std::unique_ptr<LookupTable> stderr_lookup(const LookupTable& lt);

// A LookupTable with all non-angle coordinates fixed.  eval / sample / pdf
// use the same interpolation and out-of-range mode given to bind().
class BoundTable {
public:
    double eval(const Vec3& wi, const Vec3& wo) const;

    // Importance sampling of wo given wi (u1, u2 uniform in [0, 1)).  For each
    // theta_i node a piecewise-constant density over the theta_o x phi_d
    // cells proportional to the cell integral of f |cos theta_o|; between
    // nodes the two neighbouring densities are mixed with the linear
    // (warped-coordinate) interpolation weights.  Throws Error when the table
    // cannot be sampled (see sampling_error()).
    SampleResult sample(const Vec3& wi, double u1, double u2) const;
    // The density sample() draws wo with (1/sr), for MIS.
    double pdf(const Vec3& wi, const Vec3& wo) const;

    bool can_sample() const { return sampling_error_.empty(); }
    const std::string& sampling_error() const { return sampling_error_; }

private:
    friend class LookupTable;
    BoundTable() = default;

    struct NodeDist {
        std::vector<double> cell_prob;  // (no-1)*(np-1) cell probabilities, row = theta_o cell
        std::vector<double> cdf_o;      // marginal CDF over theta_o cells, size no
        std::vector<double> cdf_phi;    // per theta_o cell conditional CDF, (no-1)*np
    };

    double eval_angles(double x_i, double x_o, double phi) const;
    void angles(const Vec3& wi, const Vec3& wo, double& x_i, double& x_o,
                double& phi, double& phi_i) const;
    void build_sampling();
    void node_mixture(double x_i, std::size_t& j0, double& w1) const;
    double node_pdf(std::size_t j, double mu_o, double phi) const;

    std::string name_;         // table name, for messages
    std::vector<Axis> axes_;   // [theta_i|mu_i, theta_o|mu_o, phi_d (synthetic if absent)]
    bool has_phi_ = false;
    std::vector<double> values_;  // ni * no * np (np = 1 without phi axis)
    LookupTable::AngleLayout layout_;
    Interpolation interp_ = Interpolation::Linear;
    OutOfRange mode_ = OutOfRange::Clamp;
    // Sampling.
    std::string sampling_error_;
    std::vector<double> mu_nodes_o_;  // cos(theta_o) at theta_o nodes
    std::vector<double> phi_nodes_;   // phi_d nodes in radians (fold domain)
    double phi_mult_ = 2;             // 2 when phi_d is folded (mirror), else 1
    std::vector<NodeDist> dists_;     // one per theta_i node
};

}  // namespace brdftab
