// certify.cpp — certificates of written tables and the plan -> generate ->
// certify -> refine loop (certify.h, docs/planning.md "Certified generation").
#include "host/plan/certify.h"

#include "host/adaptive/adaptive_generate.h"
#include "host/adaptive/adaptive_io.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <map>
#include <optional>

#include "host/core/error.h"
#include "host/core/polynomial.h"
#include "host/core/splitmix.h"
#include "host/core/text.h"
#include "host/engine/evaluate.h"
#include "host/generate/chunked.h"
#include "host/io/bit_rounding.h"
#include "host/io/half_float.h"
#include "host/io/hdf5_attributes.h"
#include "host/io/hdf5_handles.h"
#include "host/io/table_io.h"
#include "host/models/registry.h"

namespace brdftab {

namespace {

double wall_seconds() {
    using clock = std::chrono::steady_clock;
    return std::chrono::duration<double>(clock::now().time_since_epoch()).count();
}

const char* interpolation_name(Interpolation i) { return i == Interpolation::Cubic ? "cubic" : "linear"; }

void check_certify_options(const CertifyOptions& o) {
    if (!(o.target > 0) || !std::isfinite(o.target))
        throw InputError("certificate target must be a finite number > 0, got " + number_text(o.target, 6));
    if (o.abs_floor < 0 || !std::isfinite(o.abs_floor))
        throw InputError("--abs-floor must be a finite number >= 0, got " + number_text(o.abs_floor, 6));
    if (!(o.rel_floor_factor > 0 && o.rel_floor_factor < 1))
        throw InputError("the relative-error floor factor must be in (0, 1)");
    if (!(o.reference_noise_fraction > 0 && o.reference_noise_fraction < 1))
        throw InputError("the reference noise fraction must be in (0, 1)");
    if (o.reference_max_samples < 1 || o.reference_max_samples > kMaxSampleCount)
        throw InputError("reference_max_samples out of range; allowed: " + sample_count_range_text());
}

// The x of a point a fraction s into interval j of an axis: uniform in the
// warped coordinate t (an explicit axis: linear between its nodes, as the
// planner probes it).
double interval_point(const Axis& axis, std::size_t j, double s) {
    if (axis.spacing == Spacing::Explicit)
        return axis.values[j] + s * (axis.values[j + 1] - axis.values[j]);
    const double t = (double(j) + s) / double(axis.count - 1);
    return std::clamp(axis.warp(t), axis.min, axis.max);
}

enum class ProbeKind { Line, Random, Node, Local };

// Stored values computed where the probes need them (the sparse
// certificate, certify_spec_table): before each batch of probes is
// interpolated, `fill` computes the cells of their stencils that are still
// missing and writes them into `values` as the file would hold them.
struct LazyCells {
    std::function<void(const std::vector<std::size_t>& cells, TableData& values)> fill;
    std::size_t limit = 0;     // refuse (skipped) when stage 1 + the bound of stage 2 touch more
    bool skipped = false;
    std::size_t planned = 0;   // stage 1's cells + the bound of stage 2's (the refusal test)
    // Points (model-input names) whose interpolation cells also set the
    // automatic floor (SparseCertifyOptions::floor_hints).
    std::vector<std::map<std::string, double>> floor_hints;
};

Certificate certify_impl(const TableData& stored, Backend& backend, const CertifyOptions& options,
                         const ProgressFn& progress, LazyCells* lazy);

}  // namespace

Certificate certify_table(const TableData& stored, Backend& backend, const CertifyOptions& options,
                          const ProgressFn& progress) {
    return certify_impl(stored, backend, options, progress, nullptr);
}

namespace {

// The steps of one certificate (certify_impl): the table and its model
// inputs, the first stage's probes, the lazily computed cells, the measure
// and the reference, the probes' evaluation, the local search and the
// quadrature's own rule error.  Members are the state the steps share.
class CertifyRun {
public:
    CertifyRun(const TableData& stored, Backend& backend, const CertifyOptions& options,
               const ProgressFn& progress, LazyCells* lazy)
        : options_(options), backend_(backend), progress_(progress), lazy_(lazy),
          model_(certified_model(stored)), q_(model_.quantity(stored.quantity)),
          where_("table '" + stored.name + "' parameters"), table_(without_recombination(stored)),
          t_(table_.table()), dims_(t_.axes.size()), rng_{options.seed * 0x9E3779B97F4A7C15ull + t_.seed + 0xCE27} {
        read_model_inputs();
    }

    void place_first_stage_probes();
    void plan_local_stage();
    void collect_floor_cells();
    bool refused_by_limit();
    void set_measure();
    void evaluate(std::size_t first);
    void local_search();
    Certificate finish();

private:
    static const ModelInfo& certified_model(const TableData& stored);
    void read_model_inputs();
    double axis_point(std::size_t a, std::size_t j, double s) const;
    void add(std::vector<double> c, ProbeKind k, std::size_t axis);
    void set_reference_noise();
    void fill_lazy_cells(std::size_t first);
    void fold(std::size_t k, double e);

    const CertifyOptions& options_;
    Backend& backend_;
    const ProgressFn& progress_;
    LazyCells* lazy_;
    const ModelInfo& model_;
    const QuantityInfo& q_;
    const std::string where_;
    const LookupTable table_;
    const TableData& t_;
    const std::size_t dims_;
    SplitMix rng_;

    // Model inputs.
    std::map<std::string, double> fixed_;
    std::vector<int> model_options_;
    bool integral_ = false;
    bool finer_rule_ = false;

    // The probes.
    std::vector<std::map<std::string, double>> named_;
    std::vector<std::vector<double>> coords_;
    std::vector<ProbeKind> kind_;
    std::vector<std::size_t> line_axis_;     // the axis a line probe runs along
    std::vector<std::vector<double>> unit_;  // probes as given to `add` (t on dependent axes)
    std::vector<int> depends_on_;
    std::vector<bool> whole_;

    // The second stage's shape.
    std::size_t worst_ = 0, cap_ = 0, per_cell_ = 1, neighbourhood_ = 1;
    bool with_neighbours_ = false;

    // Lazily computed values.
    std::optional<LookupTable> filled_;
    TableData work_;
    std::vector<std::size_t> floor_cells_;

    // The measure, the reference and the result.
    double floor_ = 0;
    bool floor_from_cells_ = false;
    IntegrationSettings ref_;
    Certificate c_;
    double random_sum2_ = 0;
    bool have_max_ = false;
    std::vector<std::pair<double, std::size_t>> off_node_;  // (error, probe) of line and random probes
};

// A recombined table (its values the recipe's sum at stored_at) is
// certified against the model quantity of its name at the stored
// parameter, as `validate` checks it (e.g. Oren-Nayar's brdf at rho).
const ModelInfo& CertifyRun::certified_model(const TableData& stored) {
    const bool recombined = stored.kind == TableKind::Recombined;
    if (stored.kind != TableKind::Computed && !recombined)
        throw InputError("table '" + stored.name + "' is " + method_attribute(stored) +
                         ": only computed and recombined tables (a model quantity of their name) can "
                         "be certified");
    const ModelInfo& model = find_model(stored.model);
    if (recombined && !model.find_quantity(stored.quantity))
        throw InputError("recombined table '" + stored.name + "': model '" + model.name +
                         "' has no quantity of that name to certify it against");
    return model;
}

void CertifyRun::read_model_inputs() {
    // Fixed model inputs from the table's attributes (as validate reads them):
    // keys the model does not know describe the storage, not the model.
    nlohmann::json option_values = nlohmann::json::object();
    if (t_.parameters.is_object())
        for (auto it = t_.parameters.begin(); it != t_.parameters.end(); ++it) {
            if (it.value().is_number() && (model_.find_parameter(it.key()) || is_direction_coordinate(it.key())))
                fixed_[it.key()] = it.value().get<double>();
            else if (it.value().is_string() && model_.find_option(it.key()))
                option_values[it.key()] = it.value();
        }
    model_options_ = resolve_options(model_, option_values, where_);
    integral_ = q_.kind != QuantityKind::ClosedForm;

    // A quadrature's reference must not be the table's own rule: against the
    // same rule the node probes read zero and the certificate would never see
    // the rule's own error.  Where the model exposes its rule size (a `nodes`
    // parameter, the rough-dielectric albedos) the reference takes a finer
    // rule: twice the nodes, at least 24, within the parameter's range.
    // Otherwise the table's stored two-rule difference (its stderr) is added
    // to the measured error at the end.
    const double finer = finer_rule_nodes(model_, q_, fixed_);
    finer_rule_ = finer > 0;
    if (finer_rule_) fixed_["nodes"] = finer;

    // A dependent axis (critical spacing tied to an eta axis) has no node
    // positions of its own, only t_k: its probes are placed in t and mapped
    // to x at the probe's value of the axis it depends on (in `add`).
    const Grid grid(t_.axes);  // finds (and checks) each dependent axis' independent one
    depends_on_.assign(dims_, -1);
    for (std::size_t a = 0; a < dims_; ++a) depends_on_[a] = grid.dependency(a);
    // An explicit axis of a whole-number parameter (an order, a mode: the
    // model refuses values between) is exact at its nodes and probed only
    // there: no lines along it, random and local probes on its nodes.
    whole_.assign(dims_, false);
    for (std::size_t a = 0; a < dims_; ++a)
        if (t_.axes[a].spacing == Spacing::Explicit)
            if (const ParameterInfo* info = model_.find_parameter(t_.axes[a].name)) whole_[a] = info->integer;
}

// x of interval j, fraction s, of axis a; t for a dependent axis.
double CertifyRun::axis_point(std::size_t a, std::size_t j, double s) const {
    const Axis& ax = t_.axes[a];
    if (whole_[a]) return ax.values[s > 0.5 ? j + 1 : j];
    return ax.dependent() ? (double(j) + s) / double(ax.count - 1) : interval_point(ax, j, s);
}

void CertifyRun::add(std::vector<double> c, ProbeKind k, std::size_t axis) {
    unit_.push_back(c);
    for (std::size_t a = 0; a < dims_; ++a)
        if (depends_on_[a] >= 0) {
            const Axis& ax = t_.axes[a];
            c[a] = std::clamp(ax.warp_at(c[a], c[std::size_t(depends_on_[a])]), ax.min, ax.max);
        }
    std::map<std::string, double> p = fixed_;
    for (std::size_t a = 0; a < dims_; ++a) p[t_.axes[a].name] = c[a];
    named_.push_back(std::move(p));
    coords_.push_back(std::move(c));
    kind_.push_back(k);
    line_axis_.push_back(axis);
}

// Lines along every axis, random points and (integrals) random nodes.
void CertifyRun::place_first_stage_probes() {
    const std::size_t nl = integral_ ? options_.integral_lines : options_.lines;
    for (std::size_t a = 0; a < dims_ && nl > 0; ++a) {
        if (whole_[a]) continue;
        // Lines along a: along every other axis the nl lines take nodes spread
        // evenly from the first to the last (the edges always among them), in
        // a random order per axis (the planner's design, plan.cpp).
        std::vector<std::vector<double>> lines(nl, std::vector<double>(dims_, 0.0));
        for (std::size_t b = 0; b < dims_; ++b) {
            if (b == a) continue;
            const Axis& other = t_.axes[b];
            std::vector<std::size_t> idx(nl);
            for (std::size_t l = 0; l < nl; ++l)
                idx[l] = nl == 1 ? rng_.below(other.count)
                                 : static_cast<std::size_t>(
                                       std::lround(double(l) * double(other.count - 1) / double(nl - 1)));
            for (std::size_t l = nl; l > 1; --l) std::swap(idx[l - 1], idx[rng_.below(l)]);
            for (std::size_t l = 0; l < nl; ++l) lines[l][b] = other.values[idx[l]];
        }
        const Axis& axis = t_.axes[a];
        for (const auto& line : lines)
            for (std::size_t j = 0; j + 1 < axis.count; ++j)
                for (double s : kProbeFractions) {
                    std::vector<double> c = line;
                    c[a] = axis_point(a, j, s);
                    add(std::move(c), ProbeKind::Line, a);
                }
    }
    const std::size_t nr = integral_ ? options_.integral_random_points : options_.random_points;
    for (std::size_t k = 0; k < nr; ++k) {
        std::vector<double> c(dims_);
        for (std::size_t a = 0; a < dims_; ++a)
            c[a] = t_.axes[a].dependent() ? rng_.uniform()
                   : whole_[a] ? t_.axes[a].values[static_cast<std::size_t>(
                                     std::lround(rng_.uniform() * double(t_.axes[a].count - 1)))]
                               : std::clamp(t_.axes[a].warp(rng_.uniform()), t_.axes[a].min, t_.axes[a].max);
        add(std::move(c), ProbeKind::Random, dims_);
    }
    if (integral_)
        for (std::size_t k = 0; k < options_.node_points; ++k) {
            std::vector<double> c(dims_);
            for (std::size_t a = 0; a < dims_; ++a) c[a] = t_.axes[a].values[rng_.below(t_.axes[a].count)];
            add(std::move(c), ProbeKind::Node, dims_);
        }
    if (named_.empty()) throw InputError("certificate: no probes (lines and random points are 0)");
}

// The second stage's shape (local_search), fixed by the options and the axes.
void CertifyRun::plan_local_stage() {
    worst_ = integral_ ? options_.integral_local_worst : options_.local_worst;
    cap_ = integral_ ? options_.integral_local_probe_cap : options_.local_probe_cap;
    per_cell_ = 1;
    for (std::size_t a = 0; a < dims_; ++a) per_cell_ *= 3;
    neighbourhood_ = per_cell_;  // 3^D cells around a probe
    with_neighbours_ = worst_ * neighbourhood_ * per_cell_ <= cap_;
    if (!with_neighbours_) neighbourhood_ = 1;
}

// Lazily computed with the automatic relative floor: the cells that set
// the floor besides those the first stage reads.  A table's largest value
// often lies at a corner or along an edge (grazing angles, the specular
// direction at grazing, the ends of parameter ranges), which the probe
// lines rarely pass through in the right combination: every node of the
// table's edges (the lines along one axis with every other axis at one
// of its ends; the corners are among them), and the nodes within
// kHintReach of the nearest node to each of the caller's floor hints on
// every axis (the planner's: where its pilot saw its largest value; a
// peak's largest node need not be the nearest one: the off-specular
// shift of a glossy lobe, the pilot's own spacing).  Hints on tables with
// dependent axes are not used (their nodes move with the other axes).
void CertifyRun::collect_floor_cells() {
    if (!lazy_ || options_.absolute || options_.abs_floor > 0) return;
    auto add_block = [&](const std::vector<std::size_t>& lo, const std::vector<std::size_t>& hi) {
        std::vector<std::size_t> at = lo;  // odometer over the block
        for (bool more = true; more;) {
            floor_cells_.push_back(t_.flat_index(at));
            more = false;
            for (std::size_t a = dims_; a-- > 0;) {
                if (at[a] < hi[a]) {
                    ++at[a];
                    more = true;
                    break;
                }
                at[a] = lo[a];
            }
        }
    };
    for (std::size_t a = 0; a < dims_; ++a)
        for (std::size_t ends = 0; ends < (std::size_t(1) << dims_); ++ends) {
            if ((ends >> a) & 1) continue;  // axis a's bit unused: each edge once
            std::vector<std::size_t> lo(dims_), hi(dims_);
            for (std::size_t b = 0; b < dims_; ++b) {
                const std::size_t end = ((ends >> b) & 1) ? t_.axes[b].count - 1 : 0;
                lo[b] = b == a ? 0 : end;
                hi[b] = b == a ? t_.axes[b].count - 1 : end;
            }
            add_block(lo, hi);
        }
    constexpr std::size_t kHintReach = 2;
    bool independent = true;
    for (const Axis& ax : t_.axes) independent = independent && !ax.dependent();
    for (const auto& hint : lazy_->floor_hints) {
        if (!independent) break;
        std::vector<std::size_t> lo(dims_), hi(dims_);
        bool complete = true;
        for (std::size_t a = 0; a < dims_ && complete; ++a) {
            const auto it = hint.find(t_.axes[a].name);
            complete = it != hint.end() && std::isfinite(it->second);
            if (!complete) break;
            const std::vector<double>& v = t_.axes[a].values;
            std::size_t near = 0;
            for (std::size_t j = 1; j < v.size(); ++j)
                if (std::fabs(v[j] - it->second) < std::fabs(v[near] - it->second)) near = j;
            lo[a] = near >= kHintReach ? near - kHintReach : 0;
            hi[a] = std::min(v.size() - 1, near + kHintReach);
        }
        if (complete) add_block(lo, hi);
    }
    std::sort(floor_cells_.begin(), floor_cells_.end());
    floor_cells_.erase(std::unique(floor_cells_.begin(), floor_cells_.end()), floor_cells_.end());
}

// Lazily computed values: the stored cells that stage 1 reads, plus a
// bound of stage 2's (up to `worst` blocks of 3^D cells, or single cells,
// each reading its nodes and the stencil's neighbours; at most cap /
// 3^D cells).  Refused above the caller's limit before anything is
// computed.
bool CertifyRun::refused_by_limit() {
    if (!lazy_) return false;
    std::vector<std::size_t> touched = floor_cells_;
    for (const auto& x : coords_) table_.stencil_cells(x, options_.interpolation, OutOfRange::Clamp, touched);
    std::sort(touched.begin(), touched.end());
    touched.erase(std::unique(touched.begin(), touched.end()), touched.end());
    const std::size_t reach = options_.interpolation == Interpolation::Cubic ? 4 : 2;
    double block = 1, single = 1;
    for (const Axis& ax : t_.axes) {
        block *= double(std::min(ax.count, reach + (with_neighbours_ ? 2 : 0)));
        single *= double(std::min(ax.count, reach));
    }
    const double stage2 = std::min(double(std::min(worst_, named_.size())) * block,
                                   double(cap_ / per_cell_) * single);
    lazy_->planned = std::min(t_.value.size(), touched.size() + std::size_t(stage2));
    if (double(lazy_->planned) > double(lazy_->limit)) {
        lazy_->skipped = true;
        return true;
    }
    work_ = t_;
    return false;
}

// The reference's noise: a fraction of the target in the measure.
void CertifyRun::set_reference_noise() {
    if (!integral_) return;
    const double noise = options_.reference_noise_fraction * options_.target;
    if (options_.absolute) {
        ref_.tolerance = 1e-12;  // never the binding one: abs_floor is
        ref_.abs_floor = noise;
    } else {
        ref_.tolerance = std::min(noise, 0.5);
        ref_.abs_floor = noise * floor_;
    }
    ref_.max_samples = options_.reference_max_samples;
}

void CertifyRun::set_measure() {
    // ---- the measure: |table - reference| / max(|reference|, F), or absolute.
    double max_table = 0;
    if (!lazy_)
        for (double v : t_.value)
            if (std::isfinite(v)) max_table = std::max(max_table, std::fabs(v));
    floor_ = options_.absolute ? 0.0
             : options_.abs_floor > 0 ? options_.abs_floor
                                      : std::max(options_.rel_floor_factor * max_table, 1e-300);
    // Computed lazily, the automatic floor is taken over the cells the first
    // stage reads and floor_cells (set in `evaluate`, before any error is
    // measured): the table's largest value whenever its cell is among them,
    // otherwise below it (the certificate errs towards larger relative
    // errors).
    floor_from_cells_ = lazy_ && !options_.absolute && !(options_.abs_floor > 0);

    // ---- the reference: closed form, or the quantity's default method under
    // a tolerance that keeps its noise at a fraction of the target.
    ref_.method = resolve_method(q_, Method::Auto);
    ref_.seed = t_.seed * 0x9E3779B97F4A7C15ull + options_.seed + 0xCE27;
    set_reference_noise();
    c_.table = t_.name;
    c_.target = options_.target;
    c_.absolute = options_.absolute;
    c_.abs_floor = floor_;
    c_.interpolation = options_.interpolation;
    for (const Axis& ax : t_.axes) c_.axis_names.push_back(ax.name);
    c_.axis_max.assign(dims_, 0.0);
    c_.max_at.assign(dims_, 0.0);
}

// Computes the cells that probes [first, end) read and that are still
// missing (and, first, the floor's cells and the automatic floor itself).
void CertifyRun::fill_lazy_cells(std::size_t first) {
    std::vector<std::size_t> cells;
    for (std::size_t k = first; k < coords_.size(); ++k)
        table_.stencil_cells(coords_[k], options_.interpolation, OutOfRange::Clamp, cells);
    if (floor_from_cells_ && first == 0) cells.insert(cells.end(), floor_cells_.begin(), floor_cells_.end());
    std::sort(cells.begin(), cells.end());
    cells.erase(std::unique(cells.begin(), cells.end()), cells.end());
    lazy_->fill(cells, work_);
    filled_.emplace(work_);
    if (floor_from_cells_ && first == 0) {
        double m = 0;  // cells not computed hold 0
        for (double v : work_.value)
            if (std::isfinite(v)) m = std::max(m, std::fabs(v));
        floor_ = std::max(options_.rel_floor_factor * m, 1e-300);
        c_.abs_floor = floor_;
        set_reference_noise();
    }
}

// Folds probe k's error e into the certificate.
void CertifyRun::fold(std::size_t k, double e) {
    if (!have_max_ || e > c_.max_error) {
        c_.max_error = e;
        c_.max_at = coords_[k];
        have_max_ = true;
    }
    ++c_.probes;
    switch (kind_[k]) {
        case ProbeKind::Line:
            ++c_.line_probes;
            c_.axis_max[line_axis_[k]] = std::max(c_.axis_max[line_axis_[k]], e);
            off_node_.emplace_back(e, k);
            break;
        case ProbeKind::Random:
            ++c_.random_probes;
            random_sum2_ += e * e;
            off_node_.emplace_back(e, k);
            break;
        case ProbeKind::Node:
            ++c_.node_probes;
            c_.node_max = std::max(c_.node_max, e);
            break;
        case ProbeKind::Local:
            ++c_.local_probes;
            break;
    }
}

// Evaluates probes [first, named.size()) and folds them into the certificate.
void CertifyRun::evaluate(std::size_t first) {
    if (lazy_) fill_lazy_cells(first);
    const LookupTable& values = filled_ ? *filled_ : table_;
    const std::vector<std::map<std::string, double>> batch(named_.begin() + first, named_.end());
    const std::vector<double> points = build_kernel_points(model_, q_, batch, [&](std::size_t) { return where_; });
    const EstimateResult r = estimate_at(backend_, model_, q_, model_options_, points, ref_, progress_);
    c_.reference_method = to_string(r.method);
    for (std::size_t i = 0; i < batch.size(); ++i) {
        const std::size_t k = first + i;
        const double v = values.eval(coords_[k], options_.interpolation, OutOfRange::Clamp);
        const double den = options_.absolute ? 1.0 : std::max(std::fabs(r.value[i]), floor_);
        double e = std::fabs(v - r.value[i]) / den;
        if (!std::isfinite(e)) e = std::numeric_limits<double>::infinity();  // NaN fails the certificate
        if (integral_ && i < r.stderr_.size()) c_.reference_noise = std::max(c_.reference_noise, r.stderr_[i] / den);
        fold(k, e);
    }
}

// Second stage, a local search: the cells around the worst probes,
// probed inside at every combination of the fractions 1/4, 1/2, 3/4.
// Lines hold all but one coordinate at nodes, and random points are
// sparse (~1 per cell or fewer), so a narrow feature whose error peaks
// inside a cell (a cross term, e.g. at the centre of the first cell of a
// peak at a corner) is found here, next to where the first stage saw
// the largest errors.
void CertifyRun::local_search() {
    std::sort(off_node_.begin(), off_node_.end(), std::greater<>());
    std::vector<std::vector<std::size_t>> cells;
    for (std::size_t w = 0; w < std::min(worst_, off_node_.size()); ++w) {
        const std::vector<double>& x = unit_[off_node_[w].second];
        std::vector<std::size_t> home(dims_);
        for (std::size_t a = 0; a < dims_; ++a) {
            const Axis& ax = t_.axes[a];
            if (ax.dependent()) {
                home[a] = std::min(std::size_t(std::max(0.0, x[a]) * double(ax.count - 1)), ax.count - 2);
                continue;
            }
            const auto it = std::upper_bound(ax.values.begin(), ax.values.end(), x[a]);
            const std::size_t j = it == ax.values.begin() ? 0 : std::size_t(it - ax.values.begin()) - 1;
            home[a] = std::min(j, ax.count - 2);
        }
        for (std::size_t n = 0; n < neighbourhood_; ++n) {
            std::vector<std::size_t> cell = home;
            bool inside = true;
            for (std::size_t a = 0, m = n; a < dims_ && with_neighbours_; ++a, m /= 3) {
                const long j = long(home[a]) + long(m % 3) - 1;
                inside = inside && j >= 0 && j <= long(t_.axes[a].count) - 2;
                cell[a] = std::size_t(std::max(j, 0L));
            }
            if (inside && std::find(cells.begin(), cells.end(), cell) == cells.end()) cells.push_back(cell);
        }
    }
    const std::size_t first_local = named_.size();
    for (const auto& cell : cells) {
        if ((named_.size() - first_local) + per_cell_ > cap_) break;
        for (std::size_t n = 0; n < per_cell_; ++n) {
            std::vector<double> x(dims_);
            for (std::size_t a = 0, m = n; a < dims_; ++a, m /= 3)
                x[a] = axis_point(a, cell[a], kProbeFractions[m % 3]);
            add(std::move(x), ProbeKind::Local, dims_);
        }
    }
    if (named_.size() > first_local) evaluate(first_local);
}

Certificate CertifyRun::finish() {
    c_.rms_error = c_.random_probes ? std::sqrt(random_sum2_ / double(c_.random_probes)) : 0.0;
    if (q_.kind == QuantityKind::Quadrature && !finer_rule_) {
        // The reference is the table's own rule (read_model_inputs): add the
        // rule's own error estimate, the largest stored two-rule difference,
        // in the measure (a bound-like term: it is an estimate, not a
        // measurement).  (Computed lazily: over the cells computed, NaN
        // elsewhere.)
        const TableData& held = lazy_ ? work_ : t_;
        double rule_error = 0;
        for (std::size_t i = 0; i < held.stderr_.size() && i < held.value.size(); ++i) {
            const double den = options_.absolute ? 1.0 : std::max(std::fabs(held.value[i]), floor_);
            if (std::isfinite(held.stderr_[i])) rule_error = std::max(rule_error, held.stderr_[i] / den);
        }
        c_.reference_noise = std::max(c_.reference_noise, rule_error);
        c_.max_error += rule_error;
    }
    c_.passed = c_.max_error <= c_.target;
    return c_;
}

Certificate certify_impl(const TableData& stored, Backend& backend, const CertifyOptions& options,
                         const ProgressFn& progress, LazyCells* lazy) {
    const double start = wall_seconds();
    check_certify_options(options);
    CertifyRun run(stored, backend, options, progress, lazy);
    run.place_first_stage_probes();
    run.plan_local_stage();
    run.collect_floor_cells();
    if (run.refused_by_limit()) return Certificate{};
    run.set_measure();
    run.evaluate(0);
    run.local_search();
    Certificate c = run.finish();
    c.seconds = wall_seconds() - start;
    return c;
}

}  // namespace

namespace {

// One computed table of the spec that a sparse certificate reads, and its
// coefficient: a computed table is its own single source (coefficient 1,
// values taken as they are); a recombined table sums its terms.
struct SparseSource {
    std::size_t table_index;
    double coefficient;
};

// The sparse certificate of `described` (a table's metadata as generate
// writes it, no values), whose cells are computed on demand from `sources`:
// the value of a computed table, or, with `combine`, the recombination
// sum_t c_t T_t (with the stderr sqrt(sum_t c_t^2 s_t^2)) in the term order
// and arithmetic of generate_detail::recombine.  Values are rounded to the
// stored type as the writer rounds them.
SparseCertificate sparse_certificate(ChunkComputer& computer, TableData described,
                                     const std::vector<SparseSource>& sources, bool combine,
                                     Backend& backend, const CertifyOptions& options,
                                     const SparseCertifyOptions& sparse, const ProgressFn& progress,
                                     double start) {
    SparseCertificate out;
    const std::size_t cells = computer.cell_count(sources.front().table_index);
    out.table_cells = cells;
    if (cells > sparse.max_table_cells) {
        out.why = std::to_string(cells) + " cells, above the " + std::to_string(sparse.max_table_cells) +
                  " a sparse certificate holds in memory";
        out.seconds = wall_seconds() - start;
        return out;
    }
    const TableData first = computer.describe(sources.front().table_index);
    const bool closed = first.method == Method::ClosedForm;
    const bool keep_stderr = described.keep_stderr;
    const StoredType type = described.stored_type;
    described.value.assign(cells, 0.0);
    described.stderr_.clear();
    described.samples.clear();
    std::vector<bool> have(cells, false);
    const std::size_t gap = closed || first.method == Method::Quadrature ? sparse.merge_gap_closed_form
                                                                          : sparse.merge_gap_sampled;
    // The stored value as the writer rounds it (table_io.cpp write_real_cells;
    // a rounded table's rules: bit_rounding.h).
    const RoundingRule value_rule = value_rounding(described), stderr_rule = stderr_rounding(described);
    auto stored_as = [type](double v, const RoundingRule& rule) {
        if (rule.active()) return round_value(v, rule);
        switch (type) {
            case StoredType::Float32: return double(static_cast<float>(v));
            case StoredType::Float16: return half_to_double(half_bits(v));
            case StoredType::Float64: break;
        }
        return v;
    };
    auto stored = [&](double v) { return stored_as(v, value_rule); };
    auto stored_err = [&](double v) { return stored_as(v, stderr_rule); };
    LazyCells lazy;
    lazy.limit = static_cast<std::size_t>(sparse.max_touched_fraction * double(cells));
    lazy.floor_hints = sparse.floor_hints;
    lazy.fill = [&](const std::vector<std::size_t>& wanted, TableData& values) {
        if (keep_stderr && values.stderr_.empty()) values.stderr_.assign(cells, std::nan(""));
        std::vector<std::pair<std::size_t, std::size_t>> runs;  // [first, last]
        for (std::size_t c : wanted) {
            if (have[c]) continue;
            ++out.touched_cells;
            if (!runs.empty() && c <= runs.back().second + gap + 1)
                runs.back().second = c;
            else
                runs.emplace_back(c, c);
        }
        const double t0 = wall_seconds();
        for (const auto& [lo, hi] : runs) {
            const std::size_t n = hi - lo + 1;
            // err: a single source's stderr, or the combination's variance
            // sum_t c_t^2 s_t^2 (its square root is stored).
            std::vector<double> value(n, 0.0), err(n, 0.0);
            bool have_stderr = true;
            for (const SparseSource& src : sources) {
                const ChunkResult r = computer.compute(CellChunk{src.table_index, lo, n}, nullptr);
                have_stderr = have_stderr && r.stderr_.size() == r.value.size();
                for (std::size_t i = 0; i < n && i < r.value.size(); ++i) {
                    if (!combine) {
                        value[i] = r.value[i];
                        if (i < r.stderr_.size()) err[i] = r.stderr_[i];
                        continue;
                    }
                    value[i] += src.coefficient * r.value[i];
                    if (have_stderr)
                        err[i] += src.coefficient * src.coefficient * r.stderr_[i] * r.stderr_[i];
                }
                ++out.engine_runs;
            }
            for (std::size_t i = 0; i < n; ++i) {
                if (have[lo + i]) continue;
                have[lo + i] = true;
                values.value[lo + i] = stored(value[i]);
                if (keep_stderr && have_stderr)
                    values.stderr_[lo + i] = stored_err(combine ? std::sqrt(err[i]) : err[i]);
                ++out.computed_cells;
            }
            if (progress) {
                Progress p;
                p.cells_total = out.planned_cells;
                p.cells_done = out.computed_cells;
                p.elapsed_seconds = wall_seconds() - start;
                p.fraction = out.planned_cells ? std::min(1.0, double(out.computed_cells) / double(out.planned_cells)) : 0;
                progress(p);
            }
        }
        out.compute_seconds += wall_seconds() - t0;
        out.planned_cells = lazy.planned;
    };
    Certificate c = certify_impl(described, backend, options, nullptr, &lazy);
    out.planned_cells = lazy.planned;
    if (lazy.skipped) {
        out.why = "the probes would touch up to " + std::to_string(lazy.planned) + " of its " +
                  std::to_string(cells) + " cells (limit " +
                  number_text(100 * sparse.max_touched_fraction, 3) + " %)";
    } else {
        out.verified = true;
        out.certificate = std::move(c);
    }
    out.seconds = wall_seconds() - start;
    return out;
}

}  // namespace

SparseCertificate certify_spec_table(const Spec& spec, std::size_t table_index, Backend& backend,
                                     const IntegrationSettings& settings, const CertifyOptions& options,
                                     const SparseCertifyOptions& sparse, const ProgressFn& progress) {
    const double start = wall_seconds();
    check_certify_options(options);
    if (table_index >= spec.tables.size()) throw Error("certify_spec_table: no table " + std::to_string(table_index));
    ChunkComputer computer(spec, backend, settings);
    return sparse_certificate(computer, computer.describe(table_index), {{table_index, 1.0}}, false, backend,
                              options, sparse, progress, start);
}

SparseCertificate certify_spec_recombined(const Spec& spec, std::size_t recombined_index, Backend& backend,
                                          const IntegrationSettings& settings, const CertifyOptions& options,
                                          const SparseCertifyOptions& sparse, const ProgressFn& progress) {
    const double start = wall_seconds();
    check_certify_options(options);
    if (recombined_index >= spec.recombined.size())
        throw Error("certify_spec_recombined: no recombined table " + std::to_string(recombined_index));
    const RecombinedSpec& rs = spec.recombined[recombined_index];
    std::vector<SparseSource> sources;
    for (const auto& [name, coeffs] : rs.terms) {
        std::optional<std::size_t> index;
        for (std::size_t k = 0; k < spec.tables.size(); ++k)
            if (spec.tables[k].name == name) index = k;
        if (!index) throw InputError(spec.file + ": recombined table '" + rs.name + "': term '" + name + "' missing");
        sources.push_back({*index, polynomial_at(coeffs, rs.stored_at)});  // as generate_detail::recombine
    }
    if (sources.empty()) throw InputError(spec.file + ": recombined table '" + rs.name + "' has no terms");
    ChunkComputer computer(spec, backend, settings);
    // The recombined table's metadata as generate_detail::recombine writes
    // it: the first term's axes, provenance and parameters, plus the stored
    // parameter; its stderr kept when every term has one.
    TableData described = computer.describe(sources.front().table_index);
    bool all_stderr = true;
    for (const SparseSource& src : sources) all_stderr = all_stderr && computer.describe(src.table_index).keep_stderr;
    described.name = rs.name;
    described.quantity = rs.name;
    described.kind = TableKind::Recombined;
    described.parameters[rs.parameter] = rs.stored_at;
    described.keep_stderr = spec.output.keep_stderr && all_stderr;
    described.stored_type = spec.output.stored_type;
    described.round_accuracy = spec.output.round_accuracy;
    described.round_absolute = spec.output.round_absolute;
    return sparse_certificate(computer, std::move(described), sources, true, backend, options, sparse, progress,
                              start);
}

Certificate certify_file_table(const std::string& path, const std::string& table, Backend& backend,
                               const CertifyOptions& options, const ProgressFn& progress) {
    check_certify_options(options);
    // An adaptive table has its own probes (host/adaptive/adaptive_generate.h).
    if (is_adaptive_table(path, table)) return certify_adaptive_file(path, table, backend, options, progress);
    return certify_table(read_table(path, table), backend, options, progress);
}

// ------------------------------------------------------------ attributes

namespace {

constexpr const char* kCertificateAttributes[] = {
    "certificate_mode",          "certificate_target",        "certificate_measure",
    "certificate_abs_floor",     "certificate_interpolation", "certificate_max_error",
    "certificate_rms_error",     "certificate_max_at",        "certificate_probes",
    "certificate_line_probes",   "certificate_random_probes", "certificate_node_probes",
    "certificate_local_probes",
    "certificate_axis_max",      "certificate_reference_noise", "certificate_reference_method",
    "certificate_passed",        "certificate_refinements",   "certificate_predicted_max",
    "certificate_predicted_rms", "certificate_seconds"};

}  // namespace

void write_certificate(const std::string& path, const Certificate& c) {
    using namespace hdf5;
    silence_hdf5();
    Handle file(H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT), H5Fclose, "H5Fopen", path);
    Handle group(H5Gopen2(file, c.table.c_str(), H5P_DEFAULT), H5Gclose, "H5Gopen2", path + ": " + c.table);
    for (const char* name : kCertificateAttributes)
        if (has_attr(group, name)) check(H5Adelete(group, name), "H5Adelete", name);
    nlohmann::json at = nlohmann::json::object(), axis_max = nlohmann::json::object();
    for (std::size_t a = 0; a < c.axis_names.size(); ++a) {
        if (a < c.max_at.size()) at[c.axis_names[a]] = c.max_at[a];
        if (a < c.axis_max.size()) axis_max[c.axis_names[a]] = c.axis_max[a];
    }
    write_string_attr(group, "certificate_mode", c.mode);
    write_double_attr(group, "certificate_target", c.target);
    write_string_attr(group, "certificate_measure", c.absolute ? "absolute" : "relative");
    write_double_attr(group, "certificate_abs_floor", c.abs_floor);
    write_string_attr(group, "certificate_interpolation", interpolation_name(c.interpolation));
    write_double_attr(group, "certificate_max_error", c.max_error);
    write_double_attr(group, "certificate_rms_error", c.rms_error);
    write_string_attr(group, "certificate_max_at", at.dump());
    write_u64_attr(group, "certificate_probes", c.probes);
    write_u64_attr(group, "certificate_line_probes", c.line_probes);
    write_u64_attr(group, "certificate_random_probes", c.random_probes);
    write_u64_attr(group, "certificate_node_probes", c.node_probes);
    write_u64_attr(group, "certificate_local_probes", c.local_probes);
    write_string_attr(group, "certificate_axis_max", axis_max.dump());
    write_double_attr(group, "certificate_reference_noise", c.reference_noise);
    write_string_attr(group, "certificate_reference_method", c.reference_method);
    write_i32_attr(group, "certificate_passed", c.passed ? 1 : 0);
    write_i32_attr(group, "certificate_refinements", c.refinements);
    write_double_attr(group, "certificate_predicted_max", c.predicted_max);
    write_double_attr(group, "certificate_predicted_rms", c.predicted_rms);
    write_double_attr(group, "certificate_seconds", c.seconds);
    group = Handle();
    close_written_file(file, path);
}

namespace {
std::optional<Certificate> read_certificate_in(hid_t file, const std::string& path, const std::string& table) {
    using namespace hdf5;
    Handle group(H5Gopen2(file, table.c_str(), H5P_DEFAULT), H5Gclose, "H5Gopen2", path + ": " + table);
    if (!has_attr(group, "certificate_max_error")) return std::nullopt;
    Certificate c;
    c.table = table;
    c.mode = read_string_attr(group, "certificate_mode");
    c.target = read_double_attr(group, "certificate_target");
    c.absolute = read_string_attr(group, "certificate_measure") == "absolute";
    c.abs_floor = read_double_attr(group, "certificate_abs_floor");
    c.interpolation = read_string_attr(group, "certificate_interpolation") == "cubic" ? Interpolation::Cubic
                                                                                     : Interpolation::Linear;
    c.max_error = read_double_attr(group, "certificate_max_error");
    c.rms_error = read_double_attr(group, "certificate_rms_error");
    auto parse = [&](const char* name) {
        const nlohmann::json j = nlohmann::json::parse(read_string_attr(group, name), nullptr, false);
        if (!j.is_object()) throw InputError(attr_location(group, name) + ": not a JSON object");
        return j;
    };
    // Axis order: the table's `axes` attribute.
    const nlohmann::json axes = nlohmann::json::parse(read_string_attr(group, "axes"), nullptr, false);
    const nlohmann::json at = parse("certificate_max_at"), axis_max = parse("certificate_axis_max");
    if (axes.is_array())
        for (const auto& a : axes) {
            const std::string name = a.is_string() ? a.get<std::string>() : std::string();
            c.axis_names.push_back(name);
            c.max_at.push_back(at.contains(name) && at[name].is_number() ? at[name].get<double>() : NAN);
            c.axis_max.push_back(axis_max.contains(name) && axis_max[name].is_number()
                                     ? axis_max[name].get<double>() : NAN);
        }
    c.probes = read_u64_attr(group, "certificate_probes");
    c.line_probes = read_u64_attr(group, "certificate_line_probes");
    c.random_probes = read_u64_attr(group, "certificate_random_probes");
    c.node_probes = read_u64_attr(group, "certificate_node_probes");
    c.local_probes = read_u64_attr(group, "certificate_local_probes");
    c.reference_noise = read_double_attr(group, "certificate_reference_noise");
    c.reference_method = read_string_attr(group, "certificate_reference_method");
    c.passed = read_u64_attr(group, "certificate_passed") != 0;
    c.refinements = static_cast<int>(read_u64_attr(group, "certificate_refinements"));
    c.predicted_max = read_double_attr(group, "certificate_predicted_max");
    c.predicted_rms = read_double_attr(group, "certificate_predicted_rms");
    c.seconds = read_double_attr(group, "certificate_seconds");
    return c;
}
}  // namespace

std::optional<Certificate> read_certificate(const std::string& path, const std::string& table) {
    using namespace hdf5;
    silence_hdf5();
    Handle file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose, "H5Fopen", path);
    return read_certificate_in(file, path, table);
}

std::optional<Certificate> read_certificate(const TableReader& reader, const std::string& table) {
    hdf5::silence_hdf5();
    return read_certificate_in(reader.hdf5_file(), reader.path(), table);
}

// ------------------------------------------------------------ the loop

namespace {

std::string sci(double v) {
    if (!std::isfinite(v)) return "inf";
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.2e", v);
    return buf;
}

std::vector<AxisFit>& fits_of(TablePilot& p, const PlanTarget& t) {
    return t.interpolation == Interpolation::Linear ? p.linear : p.cubic;
}

void scale_fit(PowerFit& f, double r) {
    if (f.valid) f.c *= r;
}

// Candidate `c` with its tables' counts replaced and its predictions redone.
Candidate repredict(const Candidate& c, const std::vector<TablePilot>& pilots, const PlanTarget& target,
                    const std::vector<std::vector<std::size_t>>& counts) {
    Candidate out = c;
    out.error_max = out.error_rms = out.seconds = out.bytes = 0;
    for (std::size_t i = 0; i < pilots.size(); ++i) {
        out.tables[i] = predict_table(pilots[i], target, counts[i], c.method, c.samples, c.stored_type);
        out.error_max = std::max(out.error_max, out.tables[i].error_max);
        out.error_rms = std::max(out.error_rms, out.tables[i].error_rms);
        out.seconds += out.tables[i].seconds;
    }
    return out;
}

}  // namespace

namespace {

// The certificate options of one table of a verified plan: the target's
// measure and interpolation, its reference noise set by E (with an accuracy
// target) or by the table's prediction.
CertifyOptions plan_certify_options(const PlanTarget& target, double abs_floor, double predicted) {
    CertifyOptions co;
    co.absolute = target.absolute;
    co.abs_floor = target.absolute ? 0.0 : abs_floor;
    co.interpolation = target.interpolation;
    const double fitted = std::isfinite(predicted) && predicted > 0 ? predicted : 1e-300;
    co.target = target.accuracy ? *target.accuracy : fitted;
    return co;
}

// The sparse limits of a table predicted to generate in `seconds`: a cheap
// one is verified whatever its probes read.
SparseCertifyOptions plan_sparse_options(const SparseCertifyOptions& sparse, double seconds) {
    SparseCertifyOptions table_sparse = sparse;
    if (std::isfinite(seconds) && seconds <= sparse.cheap_table_seconds) table_sparse.max_touched_fraction = 1.0;
    return table_sparse;
}

}  // namespace

PlanVerification verify_plan(const Spec& planned, const std::vector<std::size_t>& table_indices,
                             const Candidate& plan, const std::vector<TablePilot>& pilots,
                             Backend& backend, const IntegrationSettings& settings, const PlanTarget& target,
                             double abs_floor, const SparseCertifyOptions& sparse, const ProgressFn& progress) {
    const double start = wall_seconds();
    PlanVerification v;
    v.fitted_max = plan.error_max;
    v.fitted_rms = plan.error_rms;
    const std::vector<RecombinedGroup> groups = recombined_groups(planned, table_indices);
    // Folds a table's sparse certificate into the verification's counts; a
    // verified one keeps the prediction it replaces.
    auto account = [&v](SparseCertificate& sc, double predicted_max, double predicted_rms) {
        if (sc.verified) {
            sc.certificate.predicted_max = predicted_max;
            sc.certificate.predicted_rms = predicted_rms;
            ++v.verified;
        }
        v.touched_cells += sc.touched_cells;
        v.computed_cells += sc.computed_cells;
        v.table_cells += sc.table_cells;
    };
    for (std::size_t i = 0; i < plan.tables.size(); ++i) {
        const TablePlan& tp = plan.tables[i];
        double table_max = tp.error_max, table_rms = tp.error_rms;
        if (i >= pilots.size()) {
            // A recombined entry (after every piloted table, so its terms are
            // done): the same bound as the fitted prediction, from the terms'
            // verified errors where they have them, then its own certificate
            // where the probes allow (the time limit: its terms').
            PlanVerification::Recombined r;
            r.table = tp.table;
            r.max = r.fitted_max = tp.error_max;
            r.rms = r.fitted_rms = tp.error_rms;
            double seconds = 0;
            const auto g = std::find_if(groups.begin(), groups.end(),
                                        [&](const RecombinedGroup& x) { return x.name == tp.table; });
            if (g != groups.end() &&
                std::all_of(g->terms.begin(), g->terms.end(), [&](std::size_t t) { return t < pilots.size(); })) {
                std::vector<TablePlan> terms;
                r.from_verified_terms = true;
                for (std::size_t t : g->terms) {
                    TablePlan term = plan.tables[t];
                    seconds += term.seconds;
                    if (t < v.tables.size() && v.tables[t].verified) {
                        term.error_max = v.tables[t].certificate.max_error;
                        term.error_rms = v.tables[t].certificate.rms_error;
                    } else {
                        r.from_verified_terms = false;
                    }
                    terms.push_back(term);
                }
                const TablePlan bound = predict_recombined(*g, pilots, terms, target);
                r.max = bound.error_max;
                r.rms = bound.error_rms;
            }
            const auto rs = std::find_if(planned.recombined.begin(), planned.recombined.end(),
                                         [&](const RecombinedSpec& x) { return x.name == tp.table; });
            if (rs != planned.recombined.end()) {
                try {
                    r.sparse = certify_spec_recombined(
                        planned, static_cast<std::size_t>(rs - planned.recombined.begin()), backend, settings,
                        plan_certify_options(target, abs_floor, r.max), plan_sparse_options(sparse, seconds),
                        progress);
                } catch (const InputError& e) {
                    r.sparse.why = e.what();  // e.g. no model quantity of its name: the bound stands
                }
                account(r.sparse, r.max, r.rms);
                if (r.sparse.verified) {
                    r.verified = true;
                    r.max = r.sparse.certificate.max_error;
                    r.rms = r.sparse.certificate.rms_error;
                }
            }
            table_max = r.max;
            table_rms = r.rms;
            v.recombined.push_back(r);
        } else if (i < table_indices.size()) {
            SparseCertificate sc;
            try {
                SparseCertifyOptions table_sparse = plan_sparse_options(sparse, tp.seconds);
                if (!pilots[i].max_at.empty()) table_sparse.floor_hints.push_back(pilots[i].max_at);
                sc = certify_spec_table(planned, table_indices[i], backend, settings,
                                        plan_certify_options(target, abs_floor, tp.error_max),
                                        table_sparse, progress);
            } catch (const InputError& e) {
                // A table the certificate cannot measure (e.g. a model input
                // it cannot probe): the fitted prediction stands.
                sc.why = e.what();
            }
            account(sc, tp.error_max, tp.error_rms);
            if (sc.verified) {
                table_max = sc.certificate.max_error;
                table_rms = sc.certificate.rms_error;
            }
            v.tables.push_back(std::move(sc));
        }
        v.error_max = std::max(v.error_max, table_max);
        v.error_rms = std::max(v.error_rms, table_rms);
    }
    v.seconds = wall_seconds() - start;
    return v;
}

void correct_error_model(std::vector<TablePilot>& pilots, const PlanTarget& target, const Candidate& plan,
                         const std::vector<const Certificate*>& certificates,
                         const std::function<void(const std::string&)>& say_to) {
    auto say = [&](const std::string& m) {
        if (say_to) say_to(m);
    };
    // Correct the error model with what the probes measured: an axis whose
    // lines exceeded E has its interpolation law scaled by measured /
    // predicted (at least 1.5 so that the next plan differs); a node
    // probe above half of E (integration noise plus rounding) scales the
    // integration law the same way.
    for (std::size_t i = 0; i < pilots.size() && i < certificates.size(); ++i) {
        if (!certificates[i] || certificates[i]->passed) continue;
        const Certificate& c = *certificates[i];
        TablePilot& pilot = pilots[i];
        const TablePlan& tp = plan.tables[i];
        std::vector<AxisFit>& fits = fits_of(pilot, target);
        bool any_axis = false;
        // A larger error off the lines (random or local probes: the
        // cross terms of the tensor-product interpolation) raises every
        // failing axis' correction by the same factor.
        double line_max = 0;
        for (double m : c.axis_max) line_max = std::max(line_max, m);
        const double cross = line_max > 0 ? std::max(c.max_error / line_max, 1.0) : 1.0;
        for (std::size_t a = 0; a < fits.size() && a < c.axis_max.size(); ++a) {
            if (!(c.axis_max[a] > c.target)) continue;
            any_axis = true;
            PowerFit& fm = target.absolute ? fits[a].max_abs : fits[a].max_rel;
            PowerFit& fr = target.absolute ? fits[a].rms_abs : fits[a].rms_rel;
            const double h = 1.0 / double(tp.counts[a] - 1);
            const double predicted = (fm.valid ? fm.eval(h) : 0) + tp.integration_max + tp.storage_max;
            const double ratio = predicted > 0 ? std::max(cross * c.axis_max[a] / predicted, 1.5) : 1.5;
            scale_fit(fm, ratio);
            scale_fit(fr, ratio);
            say("table '" + c.table + "' axis " + pilot.axes[a].name + ": measured " +
                sci(c.axis_max[a]) + " along its lines" +
                (cross > 1 ? " (x " + number_text(cross, 3) + " off the lines)" : "") +
                ", predicted " + sci(predicted) + ": error law x " + number_text(ratio, 3));
        }
        if (c.node_probes && c.node_max > 0.5 * c.target) {
            const double ratio = tp.integration_max > 0 ? std::max(c.node_max / tp.integration_max, 1.5) : 1.5;
            for (IntegrationFit& f : pilot.integration) {
                for (double& v : f.cell_abs) v *= ratio;
                for (double& v : f.cell_rel) v *= ratio;
                for (double& v : f.max_abs) v *= ratio;
                for (double& v : f.max_rel) v *= ratio;
                scale_fit(f.fit_max_abs, ratio);
                scale_fit(f.fit_max_rel, ratio);
                scale_fit(f.fit_rms_abs, ratio);
                scale_fit(f.fit_rms_rel, ratio);
            }
            say("table '" + c.table + "': measured " + sci(c.node_max) +
                " at nodes (integration + rounding), predicted integration " +
                sci(tp.integration_max) + ": error law x " + number_text(ratio, 3));
        } else if (!any_axis) {
            // Only random (off-line) points failed: cross terms.  Every
            // planned axis' law by measured / predicted.
            const double ratio = std::max(c.max_error / std::max(tp.error_max, 1e-300), 1.5);
            for (AxisFit& f : fits) {
                scale_fit(target.absolute ? f.max_abs : f.max_rel, ratio);
                scale_fit(target.absolute ? f.rms_abs : f.rms_rel, ratio);
            }
            say("table '" + c.table + "': max " + sci(c.max_error) +
                " at random points, predicted " + sci(tp.error_max) +
                ": every axis' error law x " + number_text(ratio, 3));
        }
    }
}

double plan_cells(const Candidate& plan) {
    double cells = 0;
    for (const TablePlan& t : plan.tables) {
        double n = 1;
        for (std::size_t c : t.counts) n *= static_cast<double>(c);
        cells += n;
    }
    return cells;
}

double spec_table_cells(const Spec& spec) {
    double cells = 0;
    for (const TableSpec& t : spec.tables) {
        double n = 1;
        for (const Axis& a : t.axes) n *= static_cast<double>(a.count);
        cells += n;
    }
    return cells;
}

std::string excessive_plan_cost(const Candidate& plan, const Spec& spec, const PlanCostLimits& limits) {
    std::string why;
    if (plan.seconds > limits.max_seconds)
        why = "predicted time " + sci(plan.seconds) + " s, above " + number_text(limits.max_seconds, 6) + " s";
    const double cells = plan_cells(plan), own = spec_table_cells(spec);
    if (own > 0 && cells > limits.max_cell_factor * own && cells > limits.min_cells)
        why += (why.empty() ? "" : "; ") + number_text(cells, 6) + " cells, " +
               number_text(std::floor(cells / own), 6) + "x the spec's own " + number_text(own, 6) +
               " (above " + number_text(limits.max_cell_factor, 6) + "x and " + number_text(limits.min_cells, 6) +
               " cells)";
    return why;
}

CertifiedResult certified_generate(const Spec& spec, Backend& backend, const CertifiedGenerateOptions& options,
                                   const std::string& path, const GenerateToFn& generate,
                                   const CertifyProgressFn& progress) {
    const double start = wall_seconds();
    const PlanTarget& target = options.target;
    check_target(target);
    if (!target.accuracy && !target.budget)
        throw InputError("certified generation needs a target: --accuracy E or --budget SECONDS");
    if (options.max_refinements < 0)
        throw InputError("--max-refinements must be >= 0, got " + std::to_string(options.max_refinements));
    if (options.pilot.abs_floor < 0 || !std::isfinite(options.pilot.abs_floor))
        throw InputError("--abs-floor must be a finite number >= 0, got " + number_text(options.pilot.abs_floor, 6));
    if (!spec.recombined.empty() || !spec.errors.empty() || !spec.inverted.empty())
        throw InputError(spec.file + ": certified generation does not handle [[recombined]], [[errors]] or "
                         "[[inverted]] tables yet; generate a copy of the spec without them");
    const bool budget_mode = target.budget.has_value();
    const char* measure = target.absolute ? "absolute" : "relative";
    // The spec the planned specs are written from: with rounded storage, its
    // [output] rounds for the target (the spec's own round_to_accuracy wins).
    Spec stored_spec = spec;
    const bool spec_rounds = spec.output.round_accuracy > 0 ||
                             std::any_of(spec.tables.begin(), spec.tables.end(),
                                         [](const TableSpec& ts) { return ts.round_accuracy > 0; });
    if (options.round_storage && target.accuracy && !spec_rounds) {
        stored_spec.output.round_accuracy = *target.accuracy;
        stored_spec.output.round_absolute = target.absolute;
    }
    auto say = [&](const std::string& stage, int round, const std::string& message, const Progress& p = {}) {
        if (progress) progress(CertifyEvent{stage, round, message, p});
    };
    auto stage_progress = [&](const std::string& stage, int round) -> ProgressFn {
        if (!progress) return nullptr;
        return [&progress, stage, round](const Progress& p) { progress(CertifyEvent{stage, round, "", p}); };
    };

    CertifiedResult result;
    std::vector<std::size_t> indices;
    for (std::size_t i = 0; i < spec.tables.size(); ++i) {
        indices.push_back(i);
        result.pilots.push_back(run_pilot(spec, i, backend, options.pilot, [&](const std::string& s, const Progress& p) {
            if (progress) progress(CertifyEvent{"pilot: " + s, 0, "", p});
        }));
        say("pilot", 0, "pilot '" + result.pilots.back().table + "': " +
                            std::to_string(result.pilots.back().pilot_evaluations) + " direct evaluations, " +
                            number_text(result.pilots.back().pilot_seconds, 3) + " s");
    }
    result.pilot_seconds = wall_seconds() - start;

    std::optional<Candidate> previous;
    for (int round = 0;; ++round) {
        const std::vector<Candidate> front = pareto_front(make_candidates(result.pilots, target));
        const std::optional<std::size_t> choice = choose_plan(front, target);
        if (!choice) {
            if (round == 0)
                throw Error(target.accuracy ? "no candidate plan is predicted to reach a max total " +
                                                  std::string(measure) + " error of " + sci(*target.accuracy)
                                            : "no candidate plan is predicted to finish within " +
                                                  sci(*target.budget) + " s");
            result.stop = "no-plan";
            say("refine", round, "no plan is predicted to reach the target with the corrected error model");
            break;
        }
        Candidate plan = front[*choice];
        if (previous) {
            // Refinement only adds: never fewer nodes on an axis than the last
            // round, nor fewer samples with the same method.  An axis whose
            // lines failed and whose count the new plan would not raise gets
            // 1.5 x the intervals, so that every round changes the table.
            std::vector<std::vector<std::size_t>> counts(plan.tables.size());
            const CertifiedRound& last = result.rounds.back();
            bool changed = false;
            for (std::size_t i = 0; i < plan.tables.size(); ++i) {
                counts[i] = plan.tables[i].counts;
                for (std::size_t a = 0; a < counts[i].size(); ++a) {
                    const std::size_t old = previous->tables[i].counts[a];
                    counts[i][a] = std::max(counts[i][a], old);
                    const Certificate& c = last.certificates[i];
                    if (!c.passed && a < c.axis_max.size() && c.axis_max[a] > c.target && counts[i][a] == old &&
                        result.pilots[i].axes[a].spacing != Spacing::Explicit)
                        counts[i][a] = std::min<std::size_t>(65536, old + std::max<std::size_t>((old - 1) / 2, 1));
                    changed |= counts[i][a] != old;
                }
            }
            if (plan.method == previous->method && plan.samples < previous->samples) plan.samples = previous->samples;
            changed |= plan.method != previous->method || plan.samples != previous->samples ||
                       plan.stored_type != previous->stored_type;
            if (!changed) {
                // Only the integration can have failed: more samples.
                if (plan.samples && plan.samples < kMaxSampleCount) {
                    plan.samples = std::min<std::uint64_t>(plan.samples * 4, kMaxSampleCount);
                } else {
                    result.stop = "no-plan";
                    say("refine", round, "no refinement left that the error model says would help");
                    break;
                }
            }
            plan = repredict(plan, result.pilots, target, counts);
        }
        // The caller sees every plan before it costs anything (approve_plan).
        auto approved = [&](const Candidate& c) {
            if (!options.approve_plan || options.approve_plan(c, front, round)) return true;
            if (round == 0)
                throw InputError("the planned generation was not started: " + excessive_plan_cost(c, spec));
            result.stop = "cost";
            say("refine", round, "refinement not started: its plan was refused (" + excessive_plan_cost(c, spec) + ")");
            return false;
        };
        if (!approved(plan)) break;
        if (round == 0 && options.verify && target.accuracy) {
            // Verify the first plan before generating it (docs/planning.md
            // "Verified plans"): a missed E corrects the model as a failed
            // certificate would, without a generation round.
            for (int k = 0;; ++k) {
                const Spec planned = parse_spec_string(planned_spec_text(stored_spec, indices, plan, {}),
                                                       options.spec_label.empty() ? spec.file : options.spec_label);
                const IntegrationSettings settings =
                    options.verify_settings ? options.verify_settings(planned) : planned.integration;
                const PlanVerification v = verify_plan(planned, indices, plan, result.pilots, backend, settings, target,
                                                       options.pilot.abs_floor, options.verify_sparse,
                                                       stage_progress("verify", 0));
                std::size_t touched = 0, cells = 0;
                for (const SparseCertificate& t : v.tables)
                    if (t.verified) touched += t.touched_cells, cells += t.table_cells;
                say("verify", 0, v.verified ? "verification: max " + sci(v.error_max) + " (fitted " + sci(v.fitted_max) +
                                                  "), " + std::to_string(v.verified) + " of " +
                                                  std::to_string(v.tables.size()) + " table(s), reading " +
                                                  std::to_string(touched) + " of " + std::to_string(cells) + " cells, " +
                                                  number_text(v.seconds, 3) + " s"
                                            : "verification: no table verified (" +
                                                  (v.tables.empty() ? std::string("none") : v.tables.front().why) +
                                                  "); the fitted prediction stands");
                result.verifications.push_back(v);
                if (v.verified == 0 || v.error_max <= *target.accuracy || k >= 2) break;
                std::vector<const Certificate*> certs;
                for (const SparseCertificate& t : v.tables) certs.push_back(t.verified ? &t.certificate : nullptr);
                correct_error_model(result.pilots, target, plan, certs,
                                    [&](const std::string& m) { say("verify", 0, m); });
                const std::vector<Candidate> again = pareto_front(make_candidates(result.pilots, target));
                const std::optional<std::size_t> pick = choose_plan(again, target);
                if (!pick) {
                    say("verify", 0, "no plan is predicted to reach the target with the corrected model; "
                                     "generating the last one");
                    break;
                }
                plan = again[*pick];
                if (!approved(plan)) break;
            }
        }
        CertifiedRound rnd;
        rnd.round = round;
        rnd.plan = plan;
        std::vector<std::string> header = {
            "Planned by `brdftab generate` (certified) from " + spec.file + " for " +
                (target.accuracy ? "max total " + std::string(measure) + " error <= " + sci(*target.accuracy)
                                 : "a time budget of " + sci(*target.budget) + " s") +
                " (" + interpolation_name(target.interpolation) + " interpolation, device " +
                backend.device_name() + "), round " + std::to_string(round) + ".",
            "Predicted: max total error " + sci(plan.error_max) + ", RMS " + sci(plan.error_rms) + " (" +
                measure + "), engine time " + sci(plan.seconds) + " s.  docs/planning.md"};
        rnd.spec_text = planned_spec_text(stored_spec, indices, plan, header);
        const Spec planned = parse_spec_string(rnd.spec_text, options.spec_label.empty() ? spec.file : options.spec_label);
        {
            std::string nodes;
            for (std::size_t i = 0; i < plan.tables.size(); ++i) {
                if (i) nodes += "; ";
                for (std::size_t a = 0; a < plan.tables[i].counts.size(); ++a)
                    nodes += (a ? "x" : "") + std::to_string(plan.tables[i].counts[a]);
            }
            say("plan", round, "round " + std::to_string(round) + ": nodes " + nodes + ", " + to_string(plan.method) +
                                   (plan.samples ? " " + std::to_string(plan.samples) : std::string()) + ", " +
                                   stored_type_name(plan.stored_type) + "; predicted max " + sci(plan.error_max) +
                                   ", time " + sci(plan.seconds) + " s");
        }
        double t0 = wall_seconds();
        generate(planned, path, round);
        rnd.generate_seconds = wall_seconds() - t0;

        t0 = wall_seconds();
        rnd.passed = true;
        for (std::size_t i = 0; i < planned.tables.size(); ++i) {
            CertifyOptions co = options.certify;
            co.absolute = target.absolute;
            co.abs_floor = options.pilot.abs_floor;
            co.interpolation = target.interpolation;
            co.target = target.accuracy ? *target.accuracy : plan.tables[i].error_max;
            Certificate c = certify_file_table(path, planned.tables[i].name, backend, co,
                                               stage_progress("certify", round));
            c.mode = budget_mode ? "budget" : "accuracy";
            c.refinements = round;
            c.predicted_max = plan.tables[i].error_max;
            c.predicted_rms = plan.tables[i].error_rms;
            rnd.passed = rnd.passed && c.passed;
            // Digits enough for the max and the target to differ when they do.
            std::string max_text = sci(c.max_error), target_text = sci(c.target);
            for (int digits = 3; max_text == target_text && c.max_error != c.target && digits <= 17; ++digits) {
                max_text = number_text(c.max_error, digits);
                target_text = number_text(c.target, digits);
            }
            say("certify", round, "certificate '" + c.table + "': max " + max_text + ", RMS " +
                                      sci(c.rms_error) + " (" + measure + ", target " + target_text + "): " +
                                      (c.passed ? "passed" : "FAILED"));
            rnd.certificates.push_back(std::move(c));
        }
        for (const Certificate& c : rnd.certificates) write_certificate(path, c);
        rnd.certify_seconds = wall_seconds() - t0;
        result.rounds.push_back(rnd);
        previous = plan;

        if (rnd.passed) {
            result.stop = "passed";
            break;
        }
        if (budget_mode) {
            result.stop = "budget";
            break;
        }
        if (round >= options.max_refinements) {
            result.stop = "max-refinements";
            break;
        }
        std::vector<const Certificate*> certs;
        for (const Certificate& c : rnd.certificates) certs.push_back(&c);
        correct_error_model(result.pilots, target, plan, certs,
                            [&](const std::string& m) { say("refine", round, m); });
    }
    result.passed = !result.rounds.empty() && result.rounds.back().passed;
    result.total_seconds = wall_seconds() - start;
    return result;
}

}  // namespace brdftab
