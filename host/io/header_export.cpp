// header_export.cpp — a table as a C99 header (see header_export.h).
//
// The generated lookup mirrors the library's linear path step by step, so
// that with float storage the two differ only by the rounding of the stored
// values: resolve() clamps to [min, max]; the inverse warp maps x to t with
// the exact end points, from the constants the library prepares once per
// axis (lookup_detail::FastAxis: cos(min), cos(max) - cos(min), the log
// ratios, the uniform index of an explicit node list), written into the
// header so that a lookup computes none of them; the cell is
// k = min(floor(u), count - 2) for u = t (count - 1), s = u - k clamped to
// [0, 1]; contract() sums (1 - s) f_k + s f_{k+1} axis by axis, first axis
// outermost, skipping zero weights.  (Gathering the 2^D corners first and
// contracting them in place measured slower in C than this recursion.)
#include "host/io/header_export.h"

#include "host/adaptive/adaptive_table.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <limits>

#include "host/core/atomic_file.h"
#include "host/core/error.h"
#include "host/core/text.h"
#include "host/io/half_float.h"
#include "host/lookup/lookup.h"

#ifndef BRDFTAB_VERSION
#define BRDFTAB_VERSION "unknown"
#endif

namespace brdftab {

HeaderValueType parse_header_value_type(const std::string& name) {
    if (name == "float") return HeaderValueType::Float;
    if (name == "half") return HeaderValueType::Half;
    if (name == "uint16") return HeaderValueType::Uint16;
    throw InputError("--type '" + name + "' is not one of float, half, uint16");
}

bool is_c_identifier(const std::string& s) {
    if (s.empty()) return false;
    if (!(std::isalpha(static_cast<unsigned char>(s[0])) || s[0] == '_')) return false;
    return std::all_of(s.begin(), s.end(), [](char c) {
        return std::isalnum(static_cast<unsigned char>(c)) || c == '_';
    });
}

std::string c_float_literal(float v) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.9g", static_cast<double>(v));
    std::string s = buf;
    if (s.find_first_of(".eE") == std::string::npos) s += ".0";
    return s + "f";
}

namespace {

// %.17g round-trips a double; %.9g a float.
std::string dbl(double v) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.17g", v);
    std::string s = buf;
    // A C literal without '.', 'e' or "inf" would be an int: "0" -> "0.0".
    if (s.find_first_of(".eEn") == std::string::npos) s += ".0";
    return s;
}

// A C string literal (names and units are plain ASCII, but be safe).
std::string c_string(const std::string& s) {
    std::string out = "\"";
    for (char c : s) {
        if (c == '"' || c == '\\') out += '\\';
        if (static_cast<unsigned char>(c) < 0x20) continue;
        out += c;
    }
    return out + "\"";
}

// Text inside a /* */ comment must not close it.
std::string comment_text(std::string s) {
    for (std::size_t p; (p = s.find("*/")) != std::string::npos;) s.replace(p, 2, "* /");
    for (char& c : s)
        if (c == '\n' || c == '\r') c = ' ';
    return s;
}

const char* spacing_macro(Spacing s) {
    switch (s) {
        case Spacing::Linear: return "LINEAR";
        case Spacing::Cos: return "COS";
        case Spacing::Log: return "LOG";
        case Spacing::Quadratic: return "QUADRATIC";
        case Spacing::Explicit: return "EXPLICIT";
        case Spacing::LogComplement: return "LOG_COMPLEMENT";
        case Spacing::Critical: return "CRITICAL";  // refused by export_c_header
    }
    return "LINEAR";
}

// Writes a list of already formatted numbers, eight per line.
void put_list(std::string& out, const std::vector<std::string>& items) {
    for (std::size_t i = 0; i < items.size(); ++i) {
        out += (i % 8 == 0) ? "\n    " : " ";
        out += items[i];
        if (i + 1 < items.size()) out += ",";
    }
    out += "\n";
}

}  // namespace

std::string header_identifier(const TableData& table, const HeaderExportOptions& options) {
    if (!options.name.empty()) {
        if (!is_c_identifier(options.name))
            throw InputError("--name '" + options.name +
                             "' is not a C identifier (letters, digits and '_', not starting "
                             "with a digit)");
        return options.name;
    }
    std::string s = table.name;
    for (char& c : s)
        if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_')) c = '_';
    if (s.empty() || std::isdigit(static_cast<unsigned char>(s[0]))) s = "table_" + s;
    return s;
}

namespace {

// Checks what the header format cannot hold; returns whether some axis has
// log-complement spacing (its pivot array is written only then).
bool check_exportable(const TableData& table, const std::string& where, bool tensor = true) {
    if (table.parameters.is_object() && table.parameters.contains("recombine"))
        throw InputError(where +
                         "the table is recombined from other tables at lookup time; export "
                         "each of its term tables instead (see `brdftab info`)");
    if (table.axes.empty()) throw InputError(where + "the table has no axes");
    bool has_pivot = false;
    for (const Axis& a : table.axes) {
        if (a.count < 2 || a.values.size() != a.count)
            throw InputError(where + "axis '" + a.name + "' needs at least 2 nodes");
        // The critical warp's inverse needs eta and the Fresnel critical
        // cosine; the header's lookup does not implement it.
        if (a.spacing == Spacing::Critical)
            throw InputError(where + "axis '" + a.name +
                             "' has spacing 'critical', which the C header's lookup does not "
                             "implement; use the lookup library (brdftab::LookupTable, the "
                             "Python module) or regenerate the table with another spacing");
        has_pivot = has_pivot || a.spacing == Spacing::LogComplement;
    }
    const std::size_t cells = tensor ? checked_cell_count(table.axes, where) : table.value.size();
    if (table.value.size() != cells)
        throw Error(where + "value has " + std::to_string(table.value.size()) +
                    " entries, the axes need " + std::to_string(cells));
    for (std::size_t i = 0; i < cells; ++i)
        if (!std::isfinite(table.value[i]))
            throw InputError(where + "value #" + std::to_string(i) +
                             " is not finite; a header can only hold finite values");
    return has_pivot;
}

// The stored values and how the header decodes them.
struct Storage {
    std::vector<std::string> items;  // one C literal per value
    std::string c_type, description, decode, error_note;
    double offset = 0, scale = 0;    // uint16
};

Storage make_storage(const TableData& table, HeaderValueType type, const std::string& id,
                     const std::string& where) {
    const std::size_t cells = table.value.size();
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (double v : table.value) {
        lo = std::min(lo, v);
        hi = std::max(hi, v);
    }
    Storage st;
    st.items.resize(cells);
    switch (type) {
        case HeaderValueType::Float:
            if (std::max(std::fabs(lo), std::fabs(hi)) > std::numeric_limits<float>::max())
                throw InputError(where + "values reach " + dbl(std::max(std::fabs(lo), hi)) +
                                 ", beyond the float range; use the library");
            for (std::size_t i = 0; i < cells; ++i)
                st.items[i] = c_float_literal(static_cast<float>(table.value[i]));
            st.c_type = "float";
            st.description = "float (each node value rounded to nearest float)";
            st.decode = "    return (double)" + id + "_values[i];\n";
            st.error_note = "differs from the library's linear lookup by at most 2^-24 (6e-8)\n"
                            "   times the largest |value| of the cell's corners (float rounding).";
            break;
        case HeaderValueType::Half:
            if (std::max(std::fabs(lo), std::fabs(hi)) > 65504.0)
                throw InputError(where + "values reach " + dbl(std::max(std::fabs(lo), hi)) +
                                 ", beyond the half range (65504); use --type float or uint16");
            for (std::size_t i = 0; i < cells; ++i) {
                char buf[12];
                std::snprintf(buf, sizeof buf, "0x%04x", half_bits(table.value[i]));
                st.items[i] = buf;
            }
            st.c_type = "uint16_t";
            st.description = "IEEE 754 binary16 bits (\"half\"), rounded to nearest, ties to even";
            st.decode =
                "    /* binary16: sign, 5 exponent bits (bias 15), 10 mantissa bits. */\n"
                "    const unsigned h = " + id + "_values[i];\n"
                "    const int e = (int)((h >> 10) & 31u), m = (int)(h & 1023u);\n"
                "    double v;\n"
                "    if (e == 0) v = ldexp((double)m, -24);            /* subnormal */\n"
                "    else if (e == 31) v = m ? NAN : HUGE_VAL;\n"
                "    else v = ldexp((double)(m | 1024), e - 25);      /* (1 + m/1024) 2^(e-15) */\n"
                "    return (h & 0x8000u) ? -v : v;\n";
            st.error_note = "each node value has relative error <= 2^-11 (4.9e-4) for |v| >= 2^-14,\n"
                            "   absolute error <= 2^-25 (3e-8) below; so the lookup differs from the\n"
                            "   library's by at most 2^-11 max|corner| + 2^-25.";
            break;
        case HeaderValueType::Uint16:
            st.offset = lo;
            st.scale = hi > lo ? (hi - lo) / 65535.0 : 0.0;
            for (std::size_t i = 0; i < cells; ++i) {
                const double q =
                    st.scale > 0 ? std::nearbyint((table.value[i] - st.offset) / st.scale) : 0;
                st.items[i] =
                    std::to_string(static_cast<unsigned>(std::min(65535.0, std::max(0.0, q))));
            }
            st.c_type = "uint16_t";
            st.description = "uint16 q with value = " + id + "_OFFSET + " + id + "_SCALE * q";
            st.decode = "    return " + id + "_OFFSET + " + id + "_SCALE * (double)" + id +
                        "_values[i];\n";
            st.error_note = "each node value has absolute error <= " + id +
                            "_SCALE / 2; so does the lookup\n"
                            "   (its weights are convex).";
            break;
    }
    return st;
}

// What is known of the table's own error (the storage error comes on top):
// the certificate's total error between nodes, and the stored stderr, which
// is integration noise at the nodes only.
std::string accuracy_note(const TableData& table, const HeaderExportOptions& options) {
    double max_stderr = 0;
    const bool has_stderr = table.stderr_.size() == table.value.size() && !table.stderr_.empty();
    for (double e : table.stderr_) max_stderr = std::max(max_stderr, std::fabs(e));
    std::string a = "   Accuracy: ";
    if (options.certificate) {
        const StoredCertificate& c = *options.certificate;
        a += "certified max total error " + number_text(c.max_error, 3) + " (RMS " + number_text(c.rms_error, 3) +
             ", " + (c.absolute ? std::string("absolute") : "relative to max(|value|, " + number_text(c.abs_floor, 3) + ")") +
             ", " + c.interpolation + " interpolation" + (c.passed ? "" : "; it missed its target " + number_text(c.target, 3)) +
             "):\n   the error between nodes, measured off-grid against the model" +
             (c.interpolation == "linear" ? "." : "; this header interpolates linearly, so its\n   error between nodes differs.");
    } else {
        a += "no certificate stored: the error between nodes was not measured\n   (`brdftab certify FILE --table " +
             comment_text(table.name) + " --accuracy E --store` measures it).";
    }
    if (has_stderr)
        a += "\n   Stored stderr up to " + number_text(max_stderr, 3) +
             " (not in this header): the integration noise at the nodes only.";
    return a + "\n";
}

// The opening comment: provenance, the lookup function and the accuracy.
std::string header_comment(const TableData& table, const HeaderExportOptions& options,
                           const std::string& id, const Storage& st) {
    const std::string D = id + "_DIMS";
    std::string h;
    h += "/* " + id + ".h — brdftab table '" + comment_text(table.name) + "' as a C99 header.\n";
    h += "   Generated by brdftab " BRDFTAB_VERSION;
    if (!options.source.empty()) h += " from " + comment_text(options.source);
    h += ".\n   Model " + comment_text(table.model) + ", quantity " + comment_text(table.quantity) +
         ", units " + comment_text(table.units.empty() ? "-" : table.units) + ".\n";
    if (!table.parameters.empty())
        h += "   Parameters: " + comment_text(table.parameters.dump()) + "\n";
    h += "\n   double " + id + "_eval(const double x[" + D + "]);\n"
         "     x[k] is the coordinate on axis k (" + id + "_axis_name[k], unit\n"
         "     " + id + "_axis_unit[k]; angles in the unit stored, usually degrees).  Each\n"
         "     coordinate is clamped to [" + id + "_min[k], " + id + "_max[k]], mapped to the\n"
         "     axis' normalised coordinate t (inverse of its node spacing: linear, cos,\n"
         "     log, quadratic or explicit nodes), and the values are interpolated\n"
         "     multilinearly in t: brdftab's linear lookup with out-of-range clamping.\n"
         "     NaN in, NaN out.  No folding of periodic axes: pass phi_d in the axis range.\n"
         "     Thread-safe (reads constants only); no allocation.\n"
         "   Values: " + id + "_values, row-major, last axis fastest; storage: " + st.description +
         ";\n   " + st.error_note + "\n";
    h += accuracy_note(table, options);
    h += "   Needs only <math.h> (link with -lm), <stddef.h> and <stdint.h>. */\n";
    return h;
}

// Writes `static const decl = {items};`.
void put_array(std::string& h, const std::string& decl, const std::vector<std::string>& v) {
    h += "static const " + decl + " = {";
    put_list(h, v);
    h += "};\n";
}

// The axis arrays: names, units, counts, strides, spacings, ranges, the
// inverse-warp constants, pivots, explicit node indices and node lists.
std::string axis_arrays(const TableData& table, const std::string& id, bool has_pivot,
                        bool has_explicit) {
    const std::string D = id + "_DIMS";
    const std::size_t dims = table.axes.size();
    std::vector<std::string> names, units, counts, spacings, mins, maxs, strides, node_ptrs, c0s,
        dcs, ratios, index_ptrs, index_bins, index_scales;
    std::vector<lookup_detail::FastAxis> fast(dims);
    std::vector<std::size_t> stride_of(dims);
    std::size_t stride = 1;
    for (std::size_t d = dims; d-- > 0;) {
        stride_of[d] = stride;
        stride *= table.axes[d].count;
    }
    for (std::size_t d = 0; d < dims; ++d) {
        const Axis& a = table.axes[d];
        fast[d].build(a);
        names.push_back(c_string(a.name));
        units.push_back(c_string(a.unit));
        counts.push_back(std::to_string(a.count) + "u");
        spacings.push_back(id + "_SPACING_" + spacing_macro(a.spacing));
        mins.push_back(dbl(a.min));
        maxs.push_back(dbl(a.max));
        strides.push_back(std::to_string(stride_of[d]) + "u");
        node_ptrs.push_back(id + "_nodes_" + std::to_string(d));
        c0s.push_back(dbl(fast[d].c0));
        dcs.push_back(dbl(fast[d].dc));
        ratios.push_back(dbl(fast[d].log_ratio));
        const bool ex = a.spacing == Spacing::Explicit;
        const auto& ix = fast[d].explicit_nodes;
        index_ptrs.push_back(ex ? id + "_index_" + std::to_string(d) : "NULL");
        index_bins.push_back(std::to_string(ex ? ix.start.size() : 0) + "u");
        index_scales.push_back(dbl(ex ? ix.inv_width : 0.0));
    }
    std::string h;
    put_array(h, "char* const " + id + "_axis_name[" + D + "]", names);
    put_array(h, "char* const " + id + "_axis_unit[" + D + "]", units);
    put_array(h, "size_t " + id + "_count[" + D + "]", counts);
    put_array(h, "size_t " + id + "_stride[" + D + "]", strides);
    put_array(h, "int " + id + "_spacing[" + D + "]", spacings);
    put_array(h, "double " + id + "_min[" + D + "]", mins);
    put_array(h, "double " + id + "_max[" + D + "]", maxs);
    h += "/* inverse-warp constants, computed once at export: cos spacing c0 = cos(min),\n"
         "   dc = cos(max) - cos(min) (degrees); log_ratio = log(max/min) (log spacing),\n"
         "   log((P - max)/(P - min)) (log-complement); 0 where unused */\n";
    put_array(h, "double " + id + "_c0[" + D + "]", c0s);
    put_array(h, "double " + id + "_dc[" + D + "]", dcs);
    put_array(h, "double " + id + "_log_ratio[" + D + "]", ratios);
    if (has_pivot) {
        std::vector<std::string> pivots;
        for (const Axis& a : table.axes)
            pivots.push_back(dbl(a.spacing == Spacing::LogComplement ? a.pivot : 0.0));
        h += "/* log-complement spacing: the pivot P of each axis (0 for other spacings) */\n";
        put_array(h, "double " + id + "_pivot[" + D + "]", pivots);
    }
    for (std::size_t d = 0; d < dims; ++d) {
        std::vector<std::string> nodes;
        for (double v : table.axes[d].values) nodes.push_back(dbl(v));
        h += "/* nodes of axis " + std::to_string(d) + " (" + comment_text(table.axes[d].name) +
             ") */\n";
        put_array(h, "double " + node_ptrs[d] + "[" + std::to_string(nodes.size()) + "]", nodes);
        if (table.axes[d].spacing != Spacing::Explicit) continue;
        std::vector<std::string> starts;
        for (auto v : fast[d].explicit_nodes.start) starts.push_back(std::to_string(v) + "u");
        h += "/* axis " + std::to_string(d) + ", explicit nodes: per bin b the cell that holds\n"
             "   nodes[0] + b / index_scale (a uniform index: no search per lookup) */\n";
        put_array(h, "uint32_t " + index_ptrs[d] + "[" + std::to_string(starts.size()) + "]",
                  starts);
    }
    put_array(h, "double* const " + id + "_nodes[" + D + "]", node_ptrs);
    if (has_explicit) {
        put_array(h, "uint32_t* const " + id + "_index[" + D + "]", index_ptrs);
        put_array(h, "size_t " + id + "_index_bins[" + D + "]", index_bins);
        put_array(h, "double " + id + "_index_scale[" + D + "]", index_scales);
    }
    return h;
}

// The lookup functions: value decode, inverse warp, eval.  `static inline`,
// so that several headers (different ids) and several translation units can
// include them, and unused ones draw no warning.
std::string lookup_functions(const std::string& id, const Storage& st, bool has_pivot,
                             bool has_explicit) {
    const std::string D = id + "_DIMS";
    std::string h;
    h += "/* Node value i (flat row-major index) as a double. */\n";
    h += "static inline double " + id + "_value(size_t i) {\n" + st.decode + "}\n\n";
    h += "/* Normalised coordinate t of x on axis k (node j at t = j / (count - 1));\n"
         "   the end nodes map to exactly 0 and 1. */\n";
    const std::string explicit_case =
        has_explicit ? "    if (" + id + "_spacing[k] == " + id + "_SPACING_EXPLICIT) {\n"
                       "        /* piecewise linear between the nodes: the cell from the uniform\n"
                       "           index, corrected to the last node <= x (first cell below) */\n"
                       "        const double* v = " + id + "_nodes[k];\n"
                       "        const size_t n = " + id + "_count[k], bins = " + id + "_index_bins[k];\n"
                       "        const double f = (x - v[0]) * " + id + "_index_scale[k];\n"
                       "        size_t j = f > 0 ? " + id + "_index[k][f < (double)bins ? (size_t)f : bins - 1] : 0;\n"
                       "        while (j + 2 < n && !(x < v[j + 1])) ++j;\n"
                       "        while (j > 0 && x < v[j]) --j;\n"
                       "        return ((double)j + (x - v[j]) / (v[j + 1] - v[j])) / (double)(n - 1);\n"
                       "    }\n"
                     : std::string();
    const std::string log_complement_case =
        has_pivot ? "    case " + id + "_SPACING_LOG_COMPLEMENT: {\n"
                    "        /* distance to the pivot is geometric in t */\n"
                    "        const double P = " + id + "_pivot[k];\n"
                    "        const double r = (P - x) / (P - lo);\n"
                    "        if (!(r > 0)) return P > hi ? HUGE_VAL : -HUGE_VAL;\n"
                    "        return log(r) / " + id + "_log_ratio[k];\n"
                    "    }\n"
                  : std::string();
    h += "static inline double " + id + "_unwarp(int k, double x) {\n"
         "    const double lo = " + id + "_min[k], hi = " + id + "_max[k];\n"
         "    const double rad = 3.14159265358979323846 / 180.0; /* cos spacing: degrees */\n"
         + explicit_case +
         "    if (x == lo) return 0.0;\n"
         "    if (x == hi) return 1.0;\n"
         "    switch (" + id + "_spacing[k]) {\n"
         "    case " + id + "_SPACING_COS:\n"
         "        return (cos(x * rad) - " + id + "_c0[k]) / " + id + "_dc[k];\n"
         "    case " + id + "_SPACING_LOG:\n"
         "        if (x <= 0) return -HUGE_VAL;\n"
         "        return log(x / lo) / " + id + "_log_ratio[k];\n"
         "    case " + id + "_SPACING_QUADRATIC: {\n"
         "        const double r = (x - lo) / (hi - lo);\n"
         "        return r >= 0 ? sqrt(r) : -sqrt(-r);\n"
         "    }\n"
         + log_complement_case +
         "    default:\n"
         "        return (x - lo) / (hi - lo);\n"
         "    }\n"
         "}\n\n";
    h += "static inline double " + id + "_contract_(const size_t* cell, const double* s, int d,\n"
         "                                  size_t offset) {\n"
         "    double sum = 0, w0, w1;\n"
         "    if (d == " + D + ") return " + id + "_value(offset);\n"
         "    w0 = 1.0 - s[d];\n"
         "    w1 = s[d];\n"
         "    if (w0 != 0) sum += w0 * " + id + "_contract_(cell, s, d + 1, offset + cell[d] * " +
         id + "_stride[d]);\n"
         "    if (w1 != 0) sum += w1 * " + id + "_contract_(cell, s, d + 1, offset + (cell[d] + 1) * " +
         id + "_stride[d]);\n"
         "    return sum;\n"
         "}\n\n";
    h += "static inline double " + id + "_eval(const double x[" + D + "]) {\n"
         "    size_t cell[" + D + "];\n"
         "    double s[" + D + "];\n"
         "    int k;\n"
         "    for (k = 0; k < " + D + "; ++k) {\n"
         "        const size_t n = " + id + "_count[k];\n"
         "        double v = x[k], u;\n"
         "        size_t c;\n"
         "        if (v != v) return v; /* NaN */\n"
         "        if (v < " + id + "_min[k]) v = " + id + "_min[k];\n"
         "        if (v > " + id + "_max[k]) v = " + id + "_max[k];\n"
         "        u = " + id + "_unwarp(k, v) * (double)(n - 1);\n"
         "        if (!(u >= 0)) u = 0;\n"
         "        if (u > (double)(n - 1)) u = (double)(n - 1);\n"
         "        c = (size_t)u;\n"
         "        if (c > n - 2) c = n - 2;\n"
         "        cell[k] = c;\n"
         "        s[k] = u - (double)c;\n"
         "        if (s[k] < 0) s[k] = 0;\n"
         "        if (s[k] > 1) s[k] = 1;\n"
         "    }\n";
    h += "    return " + id + "_contract_(cell, s, 0, 0);\n"
         "}\n\n";
    return h;
}

}  // namespace

namespace {

// The guard, includes, macros and axis arrays every header opens with.
std::string header_preamble(const TableData& table, const std::string& id, const std::string& guard,
                            const Storage& st, HeaderValueType type, bool has_pivot,
                            bool has_explicit) {
    const std::string D = id + "_DIMS";
    std::string h = "#ifndef " + guard + "\n#define " + guard + "\n\n";
    h += "#include <math.h>\n#include <stddef.h>\n#include <stdint.h>\n\n";
    h += "#define " + D + " " + std::to_string(table.axes.size()) + "\n";
    h += "#define " + id + "_CELLS " + std::to_string(table.value.size()) + "u\n";
    const char* spacing_names[] = {"LINEAR", "COS", "LOG", "QUADRATIC", "EXPLICIT"};
    for (int k = 0; k < 5; ++k)
        h += "#define " + id + "_SPACING_" + spacing_names[k] + " " + std::to_string(k) + "\n";
    // Only in headers that use it, so other headers stay as they were.
    if (has_pivot) h += "#define " + id + "_SPACING_LOG_COMPLEMENT 5\n";
    if (type == HeaderValueType::Uint16) {
        h += "#define " + id + "_OFFSET " + dbl(st.offset) + "\n";
        h += "#define " + id + "_SCALE " + dbl(st.scale) + "\n";
    }
    h += "\n" + axis_arrays(table, id, has_pivot, has_explicit) + "\n";
    put_array(h, st.c_type + " " + id + "_values[" + id + "_CELLS]", st.items);
    return h;
}

std::string guard_of(const std::string& id) {
    std::string guard = "BRDFTAB_" + id + "_H";
    for (char& c : guard) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    return guard;
}

bool any_explicit(const TableData& table) {
    for (const Axis& a : table.axes)
        if (a.spacing == Spacing::Explicit) return true;
    return false;
}

// The tree and leaf arrays of an adaptive table.
std::string adaptive_arrays(const AdaptiveLayout& L, const std::string& id) {
    std::vector<std::string> axis, split, lower, upper, box, nodes;
    for (std::size_t k = 0; k < L.split_axis.size(); ++k) {
        axis.push_back(std::to_string(L.split_axis[k]));
        split.push_back(dbl(L.split_t[k]));
        lower.push_back(std::to_string(L.lower[k]) + "u");
        upper.push_back(std::to_string(L.upper[k]) + "u");
    }
    for (double b : L.box) box.push_back(dbl(b));
    for (auto n : L.leaf_nodes) nodes.push_back(std::to_string(n) + "u");
    const std::string tn = std::to_string(axis.size());
    std::string h;
    h += "#define " + id + "_PATCH_NODES " + std::to_string(L.patch_nodes) + "u\n";
    h += "#define " + id + "_LEAVES " + std::to_string(L.leaf_count()) + "u\n";
    h += "/* tree node k: split_axis[k] >= 0 cuts that axis at t = split_t[k], children\n"
         "   lower[k] (t < split_t[k]) and upper[k]; split_axis[k] = -1: a leaf, lower[k]\n"
         "   its index.  Node 0 is the root. */\n";
    put_array(h, "int32_t " + id + "_split_axis[" + tn + "]", axis);
    put_array(h, "double " + id + "_split_t[" + tn + "]", split);
    put_array(h, "uint32_t " + id + "_lower[" + tn + "]", lower);
    put_array(h, "uint32_t " + id + "_upper[" + tn + "]", upper);
    h += "/* leaf l's box on axis a: [box[(l*DIMS + a)*2], box[(l*DIMS + a)*2 + 1]] in t */\n";
    put_array(h, "double " + id + "_box[" + std::to_string(box.size()) + "]", box);
    h += "/* leaf l's PATCH_NODES^DIMS nodes (row-major, last axis fastest): indices into\n"
         "   the values; node (i_0, ...) at t_a = lo_a + i_a (hi_a - lo_a) / (PATCH_NODES - 1) */\n";
    put_array(h, "uint32_t " + id + "_leaf_nodes[" + std::to_string(nodes.size()) + "]", nodes);
    return h;
}

// eval: clamp, t per axis, the descent, the leaf's multilinear interpolant.
std::string adaptive_eval(const std::string& id) {
    const std::string D = id + "_DIMS", N = id + "_PATCH_NODES";
    std::string h;
    h += "static inline double " + id + "_eval(const double x[" + D + "]) {\n"
         "    double t[" + D + "], frac[" + D + "], sum = 0;\n"
         "    size_t stride[" + D + "], base = 0, s = 1, npl = 1, corner, leaf;\n"
         "    uint32_t node = 0;\n"
         "    const double* box;\n"
         "    const uint32_t* nodes;\n"
         "    int k;\n"
         "    for (k = 0; k < " + D + "; ++k) {\n"
         "        double v = x[k];\n"
         "        if (v != v) return v; /* NaN */\n"
         "        if (v < " + id + "_min[k]) v = " + id + "_min[k];\n"
         "        if (v > " + id + "_max[k]) v = " + id + "_max[k];\n"
         "        v = " + id + "_unwarp(k, v);\n"
         "        t[k] = v < 0 ? 0 : (v > 1 ? 1 : v);\n"
         "    }\n"
         "    while (" + id + "_split_axis[node] >= 0)\n"
         "        node = t[" + id + "_split_axis[node]] < " + id + "_split_t[node] ? " + id +
         "_lower[node] : " + id + "_upper[node];\n"
         "    leaf = " + id + "_lower[node];\n"
         "    for (k = " + D + " - 1; k >= 0; --k) {\n"
         "        stride[k] = s;\n"
         "        s *= " + N + ";\n"
         "    }\n"
         "    npl = s;\n"
         "    box = " + id + "_box + leaf * " + D + " * 2;\n"
         "    nodes = " + id + "_leaf_nodes + leaf * npl;\n"
         "    for (k = 0; k < " + D + "; ++k) {\n"
         "        const double lo = box[2 * k], hi = box[2 * k + 1];\n"
         "        double v = t[k] < lo ? lo : (t[k] > hi ? hi : t[k]), u;\n"
         "        size_t i;\n"
         "        u = (v - lo) * ((double)(" + N + " - 1) / (hi - lo));\n"
         "        if (u < 0) u = 0;\n"
         "        if (u > (double)(" + N + " - 1)) u = (double)(" + N + " - 1);\n"
         "        i = (size_t)u;\n"
         "        if (i > " + N + " - 2) i = " + N + " - 2;\n"
         "        frac[k] = u - (double)i;\n"
         "        base += i * stride[k];\n"
         "    }\n"
         "    for (corner = 0; corner < ((size_t)1 << " + D + "); ++corner) {\n"
         "        double w = 1;\n"
         "        size_t idx = base;\n"
         "        for (k = 0; k < " + D + "; ++k) {\n"
         "            if ((corner >> k) & 1u) {\n"
         "                w *= frac[k];\n"
         "                idx += stride[k];\n"
         "            } else {\n"
         "                w *= 1 - frac[k];\n"
         "            }\n"
         "        }\n"
         "        if (w != 0) sum += w * " + id + "_value(nodes[idx]);\n"
         "    }\n"
         "    (void)npl;\n"
         "    return sum;\n"
         "}\n\n";
    return h;
}

}  // namespace

void export_c_header(const TableData& table, const std::string& out_path,
                     const HeaderExportOptions& options) {
    const std::string where = "C header export of table '" + table.name + "': ";
    const bool has_pivot = check_exportable(table, where);
    const bool has_explicit = any_explicit(table);
    const std::string id = header_identifier(table, options);
    const std::string guard = guard_of(id);
    const Storage st = make_storage(table, options.type, id, where);
    std::string h = header_comment(table, options, id, st);
    h += header_preamble(table, id, guard, st, options.type, has_pivot, has_explicit);
    h += "\n" + lookup_functions(id, st, has_pivot, has_explicit);
    h += "#endif /* " + guard + " */\n";
    write_text_atomically(out_path, h);
}

void export_c_header(const AdaptiveTable& at, const std::string& out_path,
                     const HeaderExportOptions& options) {
    TableData table = at.data;
    const std::string where = "C header export of table '" + table.name + "': ";
    // The generated eval interpolates multilinearly; a piecewise-quadratic
    // table would be misread, so it is refused rather than approximated.
    if (at.layout.patch_order != 1)
        throw InputError(where + "the table has piecewise-quadratic patches (patch_order " +
                         std::to_string(at.layout.patch_order) +
                         "); the header's tree traversal interpolates multilinearly (patch_order 1) only");
    for (auto& a : table.axes)  // the node lists of the warps, as the lookup library forms them
        if (a.values.empty() && a.count >= 2 && !a.dependent())
            for (std::size_t k = 0; k < a.count; ++k) a.values.push_back(a.warp(double(k) / double(a.count - 1)));
    const bool has_pivot = check_exportable(table, where, false);
    at.layout.check(table.value.size(), where);
    const bool has_explicit = any_explicit(table);
    const std::string id = header_identifier(table, options);
    const std::string guard = guard_of(id);
    const Storage st = make_storage(table, options.type, id, where);
    std::string h = header_comment(table, options, id, st);
    // The tensor comment's interpolation paragraph, corrected for the tree.
    h += "/* Adaptive table (docs/adaptive.md): " + id + "_eval descends the k-d tree to the\n"
         "   leaf holding t and interpolates its " + std::to_string(at.layout.patch_nodes) +
         "^DIMS-node patch multilinearly in t\n"
         "   (instead of one tensor grid; " + id + "_values holds one value per node, the\n"
         "   hanging nodes' already interpolated from their leaves). */\n";
    h += header_preamble(table, id, guard, st, options.type, has_pivot, has_explicit);
    h += adaptive_arrays(at.layout, id) + "\n";
    std::string f = lookup_functions(id, st, has_pivot, has_explicit);
    // Keep the value decode and the inverse warp; the tensor contraction and
    // eval give way to the adaptive eval.
    f = f.substr(0, f.find("static inline double " + id + "_contract_("));
    h += "\n" + f + adaptive_eval(id);
    h += "#endif /* " + guard + " */\n";
    write_text_atomically(out_path, h);
}

}  // namespace brdftab
