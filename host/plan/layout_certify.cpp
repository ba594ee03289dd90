// layout_certify.cpp — see layout_certify.h.
#include "host/plan/layout_certify.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cmath>
#include <functional>

#include <nlohmann/json.hpp>

#include "host/core/error.h"
#include "host/core/text.h"
#include "host/engine/evaluate.h"
#include "host/io/hdf5_attributes.h"
#include "host/io/hdf5_handles.h"
#include "host/models/registry.h"

namespace brdftab {

namespace {

constexpr double kPi = 3.14159265358979323846;

std::string sci(double v) {
    char b[32];
    std::snprintf(b, sizeof b, "%.3g", v);
    return b;
}

// One table axis as the renderer reads it: node k at u[k], and the model
// input (of the axis' own name) at a coordinate u.
struct LayoutAxis {
    std::string name;
    std::vector<double> u;
    std::function<double(double)> input;
};

LayoutAxis layout_axis(const TableData& t, const Axis& a, RendererLayout layout) {
    LayoutAxis l;
    l.name = a.name;
    const std::size_t n = a.values.size();
    if (n < 2)
        throw InputError("table '" + t.name + "': axis '" + a.name + "' has " + std::to_string(n) +
                         " node; a layout certificate needs at least 2 per axis");
    const bool cycles = layout == RendererLayout::Cycles;
    for (std::size_t k = 0; k < n; ++k)
        l.u.push_back(cycles ? double(k) / double(n - 1) : (double(k) + 0.5) / double(n));
    const auto clamp = [](double v, double lo, double hi) { return std::min(std::max(v, lo), hi); };
    if (a.name == "alpha") {
        l.input = cycles ? std::function<double(double)>([=](double u) { return std::pow(std::max(u, 1e-4), 2); })
                         : [](double u) { return u * u; };
    } else if (a.name == "mu_i") {
        l.input = cycles ? std::function<double(double)>([=](double u) { return std::max(u, 1e-4); })
                         : [](double u) { return u; };
    } else if (cycles && a.name == "theta_i") {
        l.input = [](double u) { return 180.0 - std::acos(std::max(u, 1e-4)) * 180.0 / kPi; };
    } else if (cycles && a.name == "eta") {
        l.input = [=](double u) {
            const double z = clamp(u, 1e-4, 0.99);
            return (1 + z * z) / (1 - z * z);
        };
    } else {
        throw InputError("table '" + t.name + "': axis '" + a.name + "' is not an axis of --layout " +
                         renderer_layout_name(layout) +
                         (cycles ? " (alpha, mu_i or theta_i, eta)" : " (alpha, mu_i)"));
    }
    return l;
}

// Multilinear interpolation of the row-major values at coordinates u (one
// per axis), clamped to each axis' first and last node.
double interpolate(const std::vector<LayoutAxis>& axes, const std::vector<double>& values,
                   const std::vector<double>& u) {
    const std::size_t dims = axes.size();
    std::vector<std::size_t> lo(dims);
    std::vector<double> w(dims);
    for (std::size_t d = 0; d < dims; ++d) {
        const std::vector<double>& nodes = axes[d].u;
        const double x = std::min(std::max(u[d], nodes.front()), nodes.back());
        std::size_t k = std::size_t(std::upper_bound(nodes.begin(), nodes.end(), x) - nodes.begin());
        k = k == 0 ? 0 : std::min(k - 1, nodes.size() - 2);
        lo[d] = k;
        w[d] = (x - nodes[k]) / (nodes[k + 1] - nodes[k]);
    }
    double sum = 0;
    for (std::size_t corner = 0; corner < (std::size_t(1) << dims); ++corner) {
        double weight = 1;
        std::size_t index = 0;
        for (std::size_t d = 0; d < dims; ++d) {
            const bool up = (corner >> d) & 1u;
            weight *= up ? w[d] : 1 - w[d];
            index = index * axes[d].u.size() + lo[d] + (up ? 1 : 0);
        }
        if (weight != 0) sum += weight * values[index];
    }
    return sum;
}

std::string interpolation_words(const std::vector<LayoutAxis>& axes, RendererLayout layout) {
    static const char* kKind[] = {"", "linear", "bilinear", "trilinear"};
    std::string names;
    for (const LayoutAxis& a : axes) {
        const std::string c = a.name == "alpha" ? (layout == RendererLayout::Cycles ? "r" : "roughness")
                              : a.name == "eta" ? "z"
                                                : (layout == RendererLayout::Cycles ? "mu" : "NoV");
        names += (names.empty() ? "" : ", ") + c;
    }
    const std::string where = layout == RendererLayout::Cycles ? "node k of n at k/(n-1)" : "texel k of n at (k+0.5)/n";
    return std::string(axes.size() < 4 ? kKind[axes.size()] : "multilinear") + " in (" + names + "), " + where;
}

// Every index tuple of the grid with counts[d] per axis, in row-major order,
// thinned to at most `cap` evenly spaced ones.
std::vector<std::vector<std::size_t>> tuples(const std::vector<std::size_t>& counts, std::size_t cap) {
    std::size_t total = 1;
    for (std::size_t c : counts) total *= c;
    std::vector<std::vector<std::size_t>> out;
    if (total == 0) return out;
    const std::size_t take = std::min(total, cap);
    for (std::size_t j = 0; j < take; ++j) {
        std::size_t flat = take == total ? j : std::size_t((double(j) + 0.5) * double(total) / double(take));
        std::vector<std::size_t> idx(counts.size());
        for (std::size_t d = counts.size(); d-- > 0;) {
            idx[d] = flat % counts[d];
            flat /= counts[d];
        }
        out.push_back(std::move(idx));
    }
    return out;
}

}  // namespace

LayoutCertificate certify_layout(const TableData& t, RendererLayout layout, Backend& backend,
                                 double reference_nodes, const ProgressFn& progress) {
    const auto start = std::chrono::steady_clock::now();
    if (t.kind != TableKind::Computed)
        throw InputError("table '" + t.name + "' is not a computed model quantity: no layout certificate");
    if (layout != RendererLayout::Cycles && t.axes.size() != 2)
        throw InputError("table '" + t.name + "': --layout " + std::string(renderer_layout_name(layout)) +
                         " reads 2-D textures (alpha, mu_i)");
    const ModelInfo& model = find_model(t.model);
    const QuantityInfo& q = model.quantity(t.quantity);
    std::vector<LayoutAxis> axes;
    for (const Axis& a : t.axes) axes.push_back(layout_axis(t, a, layout));
    const std::size_t dims = axes.size();

    // The table's fixed model inputs and options (as `certify` reads them).
    std::map<std::string, double> fixed;
    nlohmann::json option_values = nlohmann::json::object();
    if (t.parameters.is_object())
        for (auto it = t.parameters.begin(); it != t.parameters.end(); ++it) {
            if (it.value().is_number() && (model.find_parameter(it.key()) || is_direction_coordinate(it.key())))
                fixed[it.key()] = it.value().get<double>();
            else if (it.value().is_string() && model.find_option(it.key()))
                option_values[it.key()] = it.value();
        }
    if (reference_nodes > 0) {
        if (!model.find_parameter("nodes"))
            throw InputError("--reference-nodes: model '" + model.name + "' has no quadrature node count");
        fixed["nodes"] = reference_nodes;
    }
    const std::string where = "table '" + t.name + "' parameters";
    const std::vector<int> options = resolve_options(model, option_values, where);

    // Probes: cell centres, then the nodes computed off the layout's input.
    std::vector<std::vector<double>> coords;
    std::vector<bool> at_node;
    std::vector<std::size_t> cells(dims), nodes(dims);
    std::vector<bool> off(dims, false);
    for (std::size_t d = 0; d < dims; ++d) {
        cells[d] = axes[d].u.size() - 1;
        nodes[d] = axes[d].u.size();
        for (std::size_t k = 0; k < nodes[d]; ++k) {
            const double x = axes[d].input(axes[d].u[k]), v = t.axes[d].values[k];
            if (std::fabs(x - v) > 1e-9 * std::max(1.0, std::fabs(v))) off[d] = true;
        }
    }
    for (const auto& idx : tuples(cells, kMaxLayoutProbes)) {
        std::vector<double> u(dims);
        for (std::size_t d = 0; d < dims; ++d) u[d] = 0.5 * (axes[d].u[idx[d]] + axes[d].u[idx[d] + 1]);
        coords.push_back(u);
        at_node.push_back(false);
    }
    if (std::find(off.begin(), off.end(), true) != off.end())
        for (const auto& idx : tuples(nodes, kMaxLayoutProbes)) {
            std::vector<double> u(dims);
            for (std::size_t d = 0; d < dims; ++d) u[d] = axes[d].u[idx[d]];
            coords.push_back(u);
            at_node.push_back(true);
        }
    std::vector<std::map<std::string, double>> named;
    for (const auto& u : coords) {
        std::map<std::string, double> p = fixed;
        for (std::size_t d = 0; d < dims; ++d) p[axes[d].name] = axes[d].input(u[d]);
        named.push_back(std::move(p));
    }

    IntegrationSettings ref;
    ref.method = resolve_method(q, Method::Auto);
    ref.seed = t.seed;
    const std::vector<double> points = build_kernel_points(model, q, named, [&](std::size_t) { return where; });
    const EstimateResult r = estimate_at(backend, model, q, options, points, ref, progress);

    LayoutCertificate c;
    c.table = t.name;
    c.layout = layout;
    c.interpolation = interpolation_words(axes, layout);
    double sum2 = 0;
    std::size_t worst = 0;
    for (std::size_t k = 0; k < coords.size(); ++k) {
        double e = std::fabs(interpolate(axes, t.value, coords[k]) - r.value[k]);
        if (!std::isfinite(e)) e = std::numeric_limits<double>::infinity();
        if (e > c.max_error || k == 0) {
            c.max_error = e;
            worst = k;
        }
        if (at_node[k]) {
            ++c.node_probes;
            c.node_max = std::max(c.node_max, e);
        } else {
            ++c.cell_probes;
            sum2 += e * e;
        }
        if (k < r.stderr_.size()) c.reference_noise = std::max(c.reference_noise, r.stderr_[k]);
    }
    c.rms_error = c.cell_probes ? std::sqrt(sum2 / double(c.cell_probes)) : 0;
    for (std::size_t d = 0; d < dims; ++d) c.max_at[axes[d].name] = named[worst].at(axes[d].name);
    for (double s : t.stderr_)
        if (std::isfinite(s)) c.integration_estimate = std::max(c.integration_estimate, s);
    c.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return c;
}

void write_layout_certificate(const std::string& path, const LayoutCertificate& c) {
    using namespace hdf5;
    silence_hdf5();
    Handle file(H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT), H5Fclose, "H5Fopen", path);
    Handle group(H5Gopen2(file, c.table.c_str(), H5P_DEFAULT), H5Gclose, "H5Gopen2", path + ": " + c.table);
    const std::string prefix = std::string("layout_certificate_") + renderer_layout_name(c.layout) + "_";
    nlohmann::json at(c.max_at);
    const auto name = [&](const char* field) { return prefix + field; };
    const auto put_string = [&](const char* field, const std::string& v) {
        if (has_attr(group, name(field).c_str())) check(H5Adelete(group, name(field).c_str()), "H5Adelete", name(field));
        write_string_attr(group, name(field).c_str(), v);
    };
    const auto put_double = [&](const char* field, double v) {
        if (has_attr(group, name(field).c_str())) check(H5Adelete(group, name(field).c_str()), "H5Adelete", name(field));
        write_double_attr(group, name(field).c_str(), v);
    };
    const auto put_count = [&](const char* field, std::size_t v) {
        if (has_attr(group, name(field).c_str())) check(H5Adelete(group, name(field).c_str()), "H5Adelete", name(field));
        write_u64_attr(group, name(field).c_str(), v);
    };
    put_string("interpolation", c.interpolation);
    put_double("max_error", c.max_error);
    put_double("rms_error", c.rms_error);
    put_double("node_max", c.node_max);
    put_string("max_at", at.dump());
    put_count("cell_probes", c.cell_probes);
    put_count("node_probes", c.node_probes);
    put_double("integration_estimate", c.integration_estimate);
    put_double("reference_noise", c.reference_noise);
    put_double("seconds", c.seconds);
    group = Handle();
    close_written_file(file, path);
}

std::string layout_certificate_text(const LayoutCertificate& c) {
    std::string at;
    for (const auto& [k, v] : c.max_at) at += (at.empty() ? "" : ", ") + k + " " + sci(v);
    std::string s = "max |interpolated - direct| " + sci(c.max_error) + " at " + at + "; RMS " +
                    sci(c.rms_error) + " over " + std::to_string(c.cell_probes) + " cell centres";
    if (c.node_probes)
        s += "; " + std::to_string(c.node_probes) + " nodes read off their computed point, max " + sci(c.node_max);
    s += "; " + c.interpolation + "; stored values' largest error estimate " + sci(c.integration_estimate) +
         ", direct values' " + sci(c.reference_noise);
    return s;
}

}  // namespace brdftab
