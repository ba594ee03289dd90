// header_export.cpp — a table as a C99 header (see header_export.h).
//
// The generated lookup mirrors the library's linear path step by step, so
// that with float storage the two differ only by the rounding of the stored
// values: resolve() clamps to [min, max]; Axis::unwarp() maps x to t with the
// exact end points; axis_weights() forms u = t (count - 1), the cell
// k = min(floor(u), count - 2) and s = u - k clamped to [0, 1]; contract()
// sums (1 - s) f_k + s f_{k+1} axis by axis, first axis outermost, skipping
// zero weights.
#include "host/io/header_export.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <limits>

#include "host/core/atomic_file.h"
#include "host/core/error.h"
#include "host/core/text.h"
#include "host/io/half_float.h"

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

void export_c_header(const TableData& table, const std::string& out_path,
                     const HeaderExportOptions& options) {
    const std::string where = "C header export of table '" + table.name + "': ";
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
    const std::size_t cells = checked_cell_count(table.axes, where);
    if (table.value.size() != cells)
        throw Error(where + "value has " + std::to_string(table.value.size()) +
                    " entries, the axes need " + std::to_string(cells));
    const std::string id = header_identifier(table, options);
    std::string guard = "BRDFTAB_" + id + "_H";
    for (char& c : guard) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));

    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (std::size_t i = 0; i < cells; ++i) {
        const double v = table.value[i];
        if (!std::isfinite(v))
            throw InputError(where + "value #" + std::to_string(i) +
                             " is not finite; a header can only hold finite values");
        lo = std::min(lo, v);
        hi = std::max(hi, v);
    }
    const std::size_t dims = table.axes.size();
    const std::string D = id + "_DIMS";

    // Storage and its decode.
    std::vector<std::string> items(cells);
    std::string storage, c_type, decode, error_note;
    double offset = 0, scale = 0;
    switch (options.type) {
        case HeaderValueType::Float:
            if (std::max(std::fabs(lo), std::fabs(hi)) > std::numeric_limits<float>::max())
                throw InputError(where + "values reach " + dbl(std::max(std::fabs(lo), hi)) +
                                 ", beyond the float range; use the library");
            for (std::size_t i = 0; i < cells; ++i)
                items[i] = c_float_literal(static_cast<float>(table.value[i]));
            c_type = "float";
            storage = "float (each node value rounded to nearest float)";
            decode = "    return (double)" + id + "_values[i];\n";
            error_note = "differs from the library's linear lookup by at most 2^-24 (6e-8)\n"
                         "   times the largest |value| of the cell's corners (float rounding).";
            break;
        case HeaderValueType::Half:
            if (std::max(std::fabs(lo), std::fabs(hi)) > 65504.0)
                throw InputError(where + "values reach " + dbl(std::max(std::fabs(lo), hi)) +
                                 ", beyond the half range (65504); use --type float or uint16");
            for (std::size_t i = 0; i < cells; ++i) {
                char buf[12];
                std::snprintf(buf, sizeof buf, "0x%04x", half_bits(table.value[i]));
                items[i] = buf;
            }
            c_type = "uint16_t";
            storage = "IEEE 754 binary16 bits (\"half\"), rounded to nearest, ties to even";
            decode =
                "    /* binary16: sign, 5 exponent bits (bias 15), 10 mantissa bits. */\n"
                "    const unsigned h = " + id + "_values[i];\n"
                "    const int e = (int)((h >> 10) & 31u), m = (int)(h & 1023u);\n"
                "    double v;\n"
                "    if (e == 0) v = ldexp((double)m, -24);            /* subnormal */\n"
                "    else if (e == 31) v = m ? NAN : HUGE_VAL;\n"
                "    else v = ldexp((double)(m | 1024), e - 25);      /* (1 + m/1024) 2^(e-15) */\n"
                "    return (h & 0x8000u) ? -v : v;\n";
            error_note = "each node value has relative error <= 2^-11 (4.9e-4) for |v| >= 2^-14,\n"
                         "   absolute error <= 2^-25 (3e-8) below; so the lookup differs from the\n"
                         "   library's by at most 2^-11 max|corner| + 2^-25.";
            break;
        case HeaderValueType::Uint16:
            offset = lo;
            scale = hi > lo ? (hi - lo) / 65535.0 : 0.0;
            for (std::size_t i = 0; i < cells; ++i) {
                const double q = scale > 0 ? std::nearbyint((table.value[i] - offset) / scale) : 0;
                items[i] = std::to_string(static_cast<unsigned>(std::min(65535.0, std::max(0.0, q))));
            }
            c_type = "uint16_t";
            storage = "uint16 q with value = " + id + "_OFFSET + " + id + "_SCALE * q";
            decode = "    return " + id + "_OFFSET + " + id + "_SCALE * (double)" + id +
                     "_values[i];\n";
            error_note = "each node value has absolute error <= " + id +
                         "_SCALE / 2; so does the lookup\n"
                         "   (its weights are convex).";
            break;
    }

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
         "   Values: " + id + "_values, row-major, last axis fastest; storage: " + storage +
         ";\n   " + error_note + "\n";
    // What is known of the table's own error (the storage error above comes
    // on top): the certificate's total error between nodes, and the stored
    // stderr, which is integration noise at the nodes only.
    {
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
        h += a + "\n";
    }
    h += "   Needs only <math.h> (link with -lm), <stddef.h> and <stdint.h>. */\n";
    h += "#ifndef " + guard + "\n#define " + guard + "\n\n";
    h += "#include <math.h>\n#include <stddef.h>\n#include <stdint.h>\n\n";
    h += "#define " + D + " " + std::to_string(dims) + "\n";
    h += "#define " + id + "_CELLS " + std::to_string(cells) + "u\n";
    const char* spacing_names[] = {"LINEAR", "COS", "LOG", "QUADRATIC", "EXPLICIT"};
    for (int k = 0; k < 5; ++k)
        h += "#define " + id + "_SPACING_" + spacing_names[k] + " " + std::to_string(k) + "\n";
    // Only in headers that use it, so other headers stay as they were.
    if (has_pivot) h += "#define " + id + "_SPACING_LOG_COMPLEMENT 5\n";
    if (options.type == HeaderValueType::Uint16) {
        h += "#define " + id + "_OFFSET " + dbl(offset) + "\n";
        h += "#define " + id + "_SCALE " + dbl(scale) + "\n";
    }
    h += "\n";

    std::vector<std::string> names, units, counts, spacings, mins, maxs, strides, node_ptrs;
    std::size_t stride = 1;
    std::vector<std::size_t> stride_of(dims);
    for (std::size_t d = dims; d-- > 0;) {
        stride_of[d] = stride;
        stride *= table.axes[d].count;
    }
    for (std::size_t d = 0; d < dims; ++d) {
        const Axis& a = table.axes[d];
        names.push_back(c_string(a.name));
        units.push_back(c_string(a.unit));
        counts.push_back(std::to_string(a.count) + "u");
        spacings.push_back(id + "_SPACING_" + spacing_macro(a.spacing));
        mins.push_back(dbl(a.min));
        maxs.push_back(dbl(a.max));
        strides.push_back(std::to_string(stride_of[d]) + "u");
        node_ptrs.push_back(id + "_nodes_" + std::to_string(d));
    }
    auto array = [&](const std::string& decl, const std::vector<std::string>& v) {
        h += "static const " + decl + " = {";
        put_list(h, v);
        h += "};\n";
    };
    array("char* const " + id + "_axis_name[" + D + "]", names);
    array("char* const " + id + "_axis_unit[" + D + "]", units);
    array("size_t " + id + "_count[" + D + "]", counts);
    array("size_t " + id + "_stride[" + D + "]", strides);
    array("int " + id + "_spacing[" + D + "]", spacings);
    array("double " + id + "_min[" + D + "]", mins);
    array("double " + id + "_max[" + D + "]", maxs);
    if (has_pivot) {
        std::vector<std::string> pivots;
        for (const Axis& a : table.axes)
            pivots.push_back(dbl(a.spacing == Spacing::LogComplement ? a.pivot : 0.0));
        h += "/* log-complement spacing: the pivot P of each axis (0 for other spacings) */\n";
        array("double " + id + "_pivot[" + D + "]", pivots);
    }
    for (std::size_t d = 0; d < dims; ++d) {
        std::vector<std::string> nodes;
        for (double v : table.axes[d].values) nodes.push_back(dbl(v));
        h += "/* nodes of axis " + std::to_string(d) + " (" + comment_text(table.axes[d].name) +
             ") */\n";
        array("double " + node_ptrs[d] + "[" + std::to_string(nodes.size()) + "]", nodes);
    }
    array("double* const " + id + "_nodes[" + D + "]", node_ptrs);
    h += "\n";
    array(c_type + " " + id + "_values[" + id + "_CELLS]", items);
    h += "\n";

    // Functions: `static inline`, so that several headers (different ids) and
    // several translation units can include them, and unused ones draw no
    // warning.
    h += "/* Node value i (flat row-major index) as a double. */\n";
    h += "static inline double " + id + "_value(size_t i) {\n" + decode + "}\n\n";
    h += "/* Normalised coordinate t of x on axis k (node j at t = j / (count - 1));\n"
         "   the end nodes map to exactly 0 and 1. */\n";
    const std::string log_complement_case =
        has_pivot ? "    case " + id + "_SPACING_LOG_COMPLEMENT: {\n"
                    "        /* distance to the pivot is geometric in t */\n"
                    "        const double P = " + id + "_pivot[k];\n"
                    "        const double r = (P - x) / (P - lo);\n"
                    "        if (!(r > 0)) return P > hi ? HUGE_VAL : -HUGE_VAL;\n"
                    "        return log(r) / log((P - hi) / (P - lo));\n"
                    "    }\n"
                  : std::string();
    h += "static inline double " + id + "_unwarp(int k, double x) {\n"
         "    const double lo = " + id + "_min[k], hi = " + id + "_max[k];\n"
         "    const double rad = 3.14159265358979323846 / 180.0; /* cos spacing: degrees */\n"
         "    if (" + id + "_spacing[k] != " + id + "_SPACING_EXPLICIT) {\n"
         "        if (x == lo) return 0.0;\n"
         "        if (x == hi) return 1.0;\n"
         "    }\n"
         "    switch (" + id + "_spacing[k]) {\n"
         "    case " + id + "_SPACING_COS: {\n"
         "        const double c0 = cos(lo * rad), c1 = cos(hi * rad);\n"
         "        return (cos(x * rad) - c0) / (c1 - c0);\n"
         "    }\n"
         "    case " + id + "_SPACING_LOG:\n"
         "        if (x <= 0) return -HUGE_VAL;\n"
         "        return log(x / lo) / log(hi / lo);\n"
         "    case " + id + "_SPACING_QUADRATIC: {\n"
         "        const double r = (x - lo) / (hi - lo);\n"
         "        return r >= 0 ? sqrt(r) : -sqrt(-r);\n"
         "    }\n"
         + log_complement_case +
         "    case " + id + "_SPACING_EXPLICIT: {\n"
         "        /* piecewise linear between the nodes: first node > x, one back */\n"
         "        const double* v = " + id + "_nodes[k];\n"
         "        const size_t n = " + id + "_count[k];\n"
         "        size_t j = 0;\n"
         "        while (j < n && !(x < v[j])) ++j;\n"
         "        j = j == 0 ? 0 : j - 1;\n"
         "        if (j > n - 2) j = n - 2;\n"
         "        return ((double)j + (x - v[j]) / (v[j + 1] - v[j])) / (double)(n - 1);\n"
         "    }\n"
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
         "    }\n"
         "    return " + id + "_contract_(cell, s, 0, 0);\n"
         "}\n\n";
    h += "#endif /* " + guard + " */\n";
    write_text_atomically(out_path, h);
}

}  // namespace brdftab
