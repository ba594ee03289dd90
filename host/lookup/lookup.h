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
#include <cstdint>
#include <initializer_list>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "../core/grid.h"
#include "../core/table.h"

namespace brdftab {

struct AdaptiveTable;  // host/adaptive/adaptive_table.h

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

namespace lookup_detail {

// Which cell of a sorted node list holds x, in O(1): the result of
// std::upper_bound(nodes, x) - 1 clamped to [0, n - 2], found from a uniform
// table of starting cells over [nodes[0], nodes[n-1]] and a short scan that
// corrects it (so the answer is the binary search's, bit for bit).
struct NodeIndex {
    std::vector<double> nodes;          // strictly increasing
    std::vector<std::uint32_t> start;   // per bin: the cell of the bin's lower edge
    double lo = 0, inv_width = 0;       // bin b covers lo + [b, b + 1) / inv_width
    void build(std::vector<double> v);
    std::size_t cell(double x) const {
        const std::size_t n = nodes.size();
        const double f = (x - lo) * inv_width;
        const std::size_t bins = start.size();
        std::size_t k = f > 0 ? (f < double(bins) ? start[std::size_t(f)] : start[bins - 1]) : 0;
        // The first step up without a branch (a quarter of the points need
        // it on evenly spaced nodes), further ones in the loop.
        if (k + 2 < n) k += std::size_t(!(x < nodes[k + 1]));
        while (k + 2 < n && !(x < nodes[k + 1])) ++k;
        while (k > 0 && x < nodes[k]) --k;
        return k;
    }
};

// An axis prepared for lookups: its range policy and its inverse warp
// x -> t with every per-call constant computed once (cos(min), log(max/min),
// the explicit node index, ...).  unwarp() returns Axis::unwarp(x) bit for
// bit; the lookup library builds one per axis when a table is loaded or
// bound (host/lookup/fast_axis.cpp).
struct FastAxis {
    enum class Warp : std::uint8_t { Linear, Cos, Log, Quadratic, Explicit, LogComplement, General };
    enum class Periodic : std::uint8_t { None, Fold, Wrap };
    Warp warp = Warp::Linear;
    Periodic periodic = Periodic::None;  // phi_d in deg/rad: how values outside are reduced
    bool mirror = false;                 // Catmull-Rom ghosts mirrored (phi_d over [0, 180])
    bool dependent = false;              // nodes depend on another axis (unwarp_at)
    std::size_t count = 0;
    double last = 0;                     // count - 1
    double min = 0, max = 0, tol = 0;    // tol: 1e-9 of the span (Reject)
    double span = 0;                     // max - min
    double c0 = 0, dc = 0;               // cos: cos(min), cos(max) - cos(min)
    double log_ratio = 0;                // log: log(max/min); log-complement: log((P-max)/(P-min))
    double pivot = 0;                    // log-complement
    double half_turn = 0, turn = 0;      // periodic: 180 or pi, and twice that
    NodeIndex explicit_nodes;            // explicit
    // The node list of an independent axis, for guessing a lookup's cell
    // before its inverse warp is computed (prefetching on large tables).
    NodeIndex cells;
    void build(const Axis& a);
};

// What the adaptive kernels need besides the table (adaptive_lookup.cpp):
// the packed tree, the leaves' node strides, and the kernel chosen once.
struct TreeNode;
struct AdaptiveKernel {
    std::size_t stride[8] = {0, 0, 0, 0, 0, 0, 0, 0};  // of a leaf's nodes, per axis
    std::size_t nodes_per_leaf = 0, patch_nodes = 0;
    // Leaf l's block at leaves + l * leaf_stride: per axis lo, hi and
    // (n - 1)/(hi - lo) of its box, then its n^dims node values in patch
    // order (copies: no index to follow).
    std::size_t leaf_stride = 0;
    std::shared_ptr<const std::vector<double>> leaf_blocks;
    const double* leaves = nullptr;
    // A uniform grid of 2^grid_bits[a] cells along axis a over t (cells
    // numbered with the last axis fastest): per cell the deepest tree node
    // whose box holds the whole cell, where the descent starts (it would
    // reach that node anyway: the same leaf), or kStartLeaf | the leaf when
    // that node is a leaf.
    static constexpr std::uint32_t kStartLeaf = 0x80000000u;
    unsigned grid_bits[8] = {0, 0, 0, 0, 0, 0, 0, 0};
    std::vector<std::uint32_t> start;
    // The value at resolved coordinates x (every axis inside its range).
    double (*value)(const AdaptiveTable& at, const AdaptiveKernel& k, const TreeNode* tree,
                    const FastAxis* fast, const int* dependency, const double* x) = nullptr;
};

// One node of an adaptive table's tree, packed for the descent: split axis
// (-1: a leaf, child[0] its index), cut, children below and above the cut.
struct TreeNode {
    double split = 0;
    std::int32_t axis = -1;
    std::uint32_t child[2] = {0, 0};
};

}  // namespace lookup_detail

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
    // An adaptive table (docs/adaptive.md): eval, eval_many, eval_dirs and
    // bind() (eval, sample, pdf) as for a tensor table, linear interpolation
    // only (Cubic is an InputError); no recombination, no reciprocal half.
    // open() takes this path by itself for an adaptive table of the file.
    explicit LookupTable(AdaptiveTable table);
    bool is_adaptive() const { return adaptive_ != nullptr; }
    const AdaptiveTable* adaptive() const { return adaptive_.get(); }

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

    // Batch eval: `count` points, row-major, each row the coordinates of
    // coordinate_names() in that order; one value per point into `out`,
    // each bit-identical to eval() of that row.  The same checks and
    // messages as eval(); the first bad point throws (points before it are
    // written).  Allocates nothing for tables of up to 8 axes.
    void eval_many(const double* coords, std::size_t count, double* out,
                   Interpolation interp = Interpolation::Linear,
                   OutOfRange mode = OutOfRange::Clamp) const;
    // The same for a raw array of exactly coordinate_names().size() values.
    double eval(const double* coords, Interpolation interp = Interpolation::Linear,
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

    // Batch eval_dirs: wi and wo hold `count` directions as rows of 3
    // doubles (x, y, z); one value per pair into `out`, each bit-identical
    // to eval_dirs() of that pair.  `params` is checked once per call.
    void eval_dirs_many(const double* wi, const double* wo, std::size_t count, double* out,
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
        double per_rad_i = 1, per_rad_o = 1, per_rad_phi = 1;  // units per radian: 1 / scale
        bool fold_phi = true;   // phi_d axis within [0, 180]: fold by isotropy
    };

private:
    LookupTable() = default;
    void init();
    void init_recombination();
    double combine(const double* piece_values, double p) const;
    // eval() of checked coordinates (coords: the table axes, then p).
    double eval_point(const double* coords, Interpolation interp, OutOfRange mode) const;
    double eval_general(const double* coords, Interpolation interp, OutOfRange mode) const;
    // The linear lookup of a table of D independent axes, unrolled; chosen
    // once per table by choose_linear_kernel() (interpolate.cpp).
    template <int D, bool Skip>
    static double linear_kernel(const LookupTable& lt, const double* coords, OutOfRange mode);
    void choose_linear_kernel();
    // Adaptive tables (adaptive_lookup.cpp): checks, and the kernel for the
    // table's axis count, chosen once into linear_.
    void init_adaptive();
    void init_axes();    // dependency_, fast_, has_dependent_
    void init_angles();  // layout_, directional_, directional_error_
    [[noreturn]] void refuse_adaptive(const char* what) const;
    template <int D>
    static double adaptive_kernel(const LookupTable& lt, const double* coords, OutOfRange mode);
    double (*linear_)(const LookupTable&, const double*, OutOfRange) = nullptr;
    // Offsets of the cache lines a linear lookup's corners start on (the
    // last axis' pair shares them), from the first corner; for the prefetch
    // of tables of 4 or more axes.
    std::vector<std::size_t> corner_lines_;
    void dirs_point(const double* param_coords, const Vec3& wi, const Vec3& wo,
                    double* coords) const;
    void resolve_param(double& p, OutOfRange mode) const;
    std::vector<double> param_coords(const std::map<std::string, double>& params,
                                     double* p_out) const;

    std::vector<TableData> pieces_;  // pieces_[0] is the head table
    std::vector<std::size_t> strides_;
    std::vector<lookup_detail::FastAxis> fast_;  // one per axis (init)
    bool has_dependent_ = false;                  // some axis depends on another
    // Per axis: the index of the axis its nodes depend on (critical), or -1.
    std::vector<int> dependency_;
    // Recombination (empty terms_: value = pieces_[0]).
    std::vector<Term> terms_;
    std::string rparam_;
    double rmin_ = -1e300, rmax_ = 1e300;
    std::vector<double> num_{1.0}, den_{1.0};
    AngleLayout layout_;
    std::shared_ptr<const AdaptiveTable> adaptive_;  // null: a tensor table
    std::vector<lookup_detail::TreeNode> tree_;      // its tree, packed
    lookup_detail::AdaptiveKernel akernel_;
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

    // Batch forms: `count` directions as rows of 3 doubles (x, y, z) in wi
    // and wo (u: rows of 2 numbers u1, u2); results into the output arrays,
    // each element bit-identical to the scalar call on that row.  They
    // allocate nothing and, like every const member, may run concurrently
    // from several threads.  sample_many writes wo as rows of 3; any of
    // pdf, value and weight may be null.
    void eval_many(const double* wi, const double* wo, std::size_t count, double* out) const;
    void pdf_many(const double* wi, const double* wo, std::size_t count, double* out) const;
    void sample_many(const double* wi, const double* u, std::size_t count, double* wo,
                     double* pdf, double* value = nullptr, double* weight = nullptr) const;

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

    // What a lookup of wi needs, computed once per wi (sample(), the batch
    // calls).
    struct Incident {
        double x = 0, y = 0;   // wi's tangent components (unnormalised)
        double xi = 0;         // theta_i (or mu_i) in axis units
        std::size_t j0 = 0;    // sampling: theta_i node and the weight of node j0 + 1
        double w1 = 0;
    };

    // How the bound values are stored and interpolated, chosen once by
    // bind(); eval_angles() dispatches on it.  A second representation of
    // the angular table gets its own enumerator here.
    enum class Kernel : std::uint8_t { GridLinear, GridLinearNonFinite, GridCubic, Adaptive };

    double eval_angles(double x_i, double x_o, double phi) const;
    // The direction kernel (build_direction_kernel()): on a linear grid
    // kernel in Clamp mode, when each axis' node coordinate u = t (count - 1)
    // is affine in a quantity q of the directions, u = q dir_a_ + dir_b_
    // with q the polar angle in radians (linear theta axis), its cosine
    // (cos-spaced theta axis, linear mu axis) or |phi_o - phi_i| (linear
    // folded phi_d axis): no unwarp, no division, no range branches.
    // Incident::xi and the x_o of eval_from() then hold u instead of the
    // axis coordinate.
    bool dir_affine_ = false;
    bool dir_cos_[2] = {false, false};  // axes 0, 1: q = cos(theta)
    double dir_a_[3] = {0, 0, 0}, dir_b_[3] = {0, 0, 0};
    void build_direction_kernel();
    double direction_coord(const Vec3& w, int axis) const;  // axis 0 (wi) or 1 (wo)
    double eval_u(const double* u) const;
    Incident incident(const Vec3& wi) const;          // without the node mixture
    Incident incident_sampled(const Vec3& wi) const;  // with it (sampling only)
    // At an outgoing direction given by its polar coordinate xo (theta_o or
    // mu_o in axis units; eval_from) or mo = cos(theta_o) (pdf_from), and
    // d = phi_o - phi_i.
    double eval_from(const Incident& in, double xo, double d) const;
    double pdf_from(const Incident& in, double mo, double d) const;
    SampleResult sample_from(const Incident& in, double u1, double u2) const;
    void build_sampling();
    void node_mixture(double x_i, std::size_t& j0, double& w1) const;

    std::string name_;         // table name, for messages
    std::vector<Axis> axes_;   // [theta_i|mu_i, theta_o|mu_o, phi_d (synthetic if absent)]
    bool has_phi_ = false;
    std::vector<double> values_;  // ni * no * np (np = 1 without phi axis)
    lookup_detail::FastAxis fast_[3];
    std::size_t stride_i_ = 0, stride_o_ = 0;  // no * np, np
    Kernel kernel_ = Kernel::GridLinear;
    // Kernel::Adaptive: the table, its prepared axes, every coordinate with
    // the bound ones resolved (the angle slots are filled per lookup), and
    // per axis the axis its nodes depend on or -1.  values_ then holds the
    // table at the angle nodes (the sampling densities' corners).
    std::shared_ptr<const AdaptiveTable> adaptive_;
    std::vector<lookup_detail::FastAxis> adaptive_fast_;
    std::vector<double> adaptive_coords_;
    std::vector<int> adaptive_dependency_;
    std::vector<lookup_detail::TreeNode> adaptive_tree_;
    lookup_detail::AdaptiveKernel akernel_;
    double eval_adaptive(const double* x) const;  // x: resolved angles
    // Kernel::Adaptive from the table and every coordinate (the bound ones
    // resolved), once axes_ and has_phi_ are set.
    void bind_adaptive(const LookupTable& lt, const std::vector<double>& coords);
    LookupTable::AngleLayout layout_;
    Interpolation interp_ = Interpolation::Linear;
    OutOfRange mode_ = OutOfRange::Clamp;
    // Sampling, one block per theta_i node j, cells row-major (theta_o cell,
    // phi_d cell): cell probabilities, their densities (probability / solid
    // angle, 1/sr), the marginal CDF over theta_o cells (no entries per node)
    // and the conditional CDFs over phi_d cells (np entries per theta_o cell).
    std::string sampling_error_;
    std::vector<double> mu_nodes_o_;  // cos(theta_o) at theta_o nodes
    std::vector<double> phi_nodes_;   // phi_d nodes in radians (fold domain)
    lookup_detail::NodeIndex mu_index_;   // ascending: mu_nodes_o_, negated on a theta axis
    lookup_detail::NodeIndex phi_index_;  // phi_nodes_
    double phi_mult_ = 2;             // 2 when phi_d is folded (mirror), else 1
    std::vector<double> cell_prob_, cell_density_, cdf_o_, cdf_phi_;
};

}  // namespace brdftab
