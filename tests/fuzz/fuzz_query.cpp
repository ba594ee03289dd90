// fuzz_query — `brdftab query`'s coordinates: `name=value` arguments parsed
// with split_assignment/parse_number (host/cli/cli_common.h), gathered into a
// name -> value map as the CLI does (a name given twice is an error), and
// looked up in a table with LookupTable::eval (host/lookup/lookup.h).
//
// Input: the first byte chooses the table (bits 2..7), cubic interpolation
// (bit 0) and rejecting out-of-range coordinates (bit 1); the rest is one
// argument per line.  Tables: four small in-memory tables (1-D, an isotropic
// BRDF over theta_i/theta_o/phi_d with a cos axis, log and quadratic
// parameter axes, and a recombined table), plus every table of the .h5 files
// in $BRDFTAB_FUZZ_TABLES when set (scripts/fuzz.sh points it at the tables
// it generates).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "host/cli/cli_common.h"
#include "host/io/table_io.h"
#include "host/lookup/lookup.h"
#include "tests/fuzz/fuzz_common.h"

namespace {

using namespace brdftab;
using namespace brdftab::cli;

TableData make_table(const std::string& name, std::vector<Axis> axes) {
    TableData t;
    t.name = name;
    t.model = "fuzz";
    t.quantity = name;
    t.units = "1";
    t.axes = std::move(axes);
    const std::size_t n = t.cell_count();
    for (std::size_t k = 0; k < n; ++k) t.value.push_back(std::sin(0.37 * double(k)) + 1.5);
    t.stderr_.assign(n, 0.01);
    return t;
}

std::vector<LookupTable> make_tables() {
    std::vector<LookupTable> out;
    out.emplace_back(make_table("albedo", {make_axis("kd", "1", 0, 1, 5, Spacing::Linear)}));
    out.emplace_back(make_table("brdf", {make_axis("theta_i", "deg", 0, 89, 4, Spacing::Cos),
                                         make_axis("theta_o", "deg", 0, 89, 4, Spacing::Cos),
                                         make_axis("phi_d", "deg", 0, 180, 5, Spacing::Linear)}));
    out.emplace_back(make_table("params", {make_axis("alpha", "1", 0.01, 1, 4, Spacing::Log),
                                           make_axis("eta", "1", 1, 3, 3, Spacing::Quadratic)}));
    // value = (1 + p) * order1 + p^2 * order2, p in [0, 1].
    TableData head = make_table("combined", {make_axis("mu_i", "1", 0, 1, 3, Spacing::Linear)});
    head.parameters["recombine"] = {
        {"parameter", "c"},
        {"range", {0.0, 1.0}},
        {"terms", {{{"table", "order1"}, {"coeffs", {1.0, 1.0}}},
                   {{"table", "order2"}, {"coeffs", {0.0, 0.0, 1.0}}}}}};
    const std::vector<TableData> pieces = {
        head, make_table("order1", head.axes), make_table("order2", head.axes)};
    out.push_back(LookupTable::from_tables(pieces, "combined"));

    const std::size_t built_in = out.size();
    if (const char* dir = std::getenv("BRDFTAB_FUZZ_TABLES")) {
        std::error_code ec;
        for (const auto& entry : std::filesystem::directory_iterator(dir, ec)) {
            if (entry.path().extension() != ".h5") continue;
            try {
                for (const auto& name : list_tables(entry.path().string()))
                    out.push_back(LookupTable::open(entry.path().string(), name));
            } catch (const Error&) {
                // A corpus file the reader refuses is not a table to query.
            }
        }
    }
    std::fprintf(stderr, "fuzz_query: %zu tables (%zu from $BRDFTAB_FUZZ_TABLES)\n", out.size(),
                 out.size() - built_in);
    return out;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    static const std::vector<LookupTable> tables = make_tables();
    if (size == 0) return 0;
    const LookupTable& lt = tables[(data[0] >> 2) % tables.size()];
    const Interpolation interp = (data[0] & 1) ? Interpolation::Cubic : Interpolation::Linear;
    const OutOfRange mode = (data[0] & 2) ? OutOfRange::Reject : OutOfRange::Clamp;
    const std::string text(reinterpret_cast<const char*>(data) + 1, size - 1);

    fuzz::expect_only_input_errors("query coordinates", [&] {
        std::map<std::string, double> coords;
        std::istringstream lines(text);
        for (std::string arg; std::getline(lines, arg);) {
            // Unqualified: parse_number is brdftab::cli's or brdftab's
            // (host/io/point_file.h), depending on where the CLI keeps it.
            auto [name, value_text] = split_assignment(arg);
            const double v = parse_number(value_text, "argument '" + name + "'");
            if (!coords.emplace(name, v).second)
                throw InputError("argument '" + name + "' is given twice");
        }
        const double v = lt.eval(coords, interp, mode);
        // Finite coordinates in a table of finite values give a finite value.
        if (!std::isfinite(v)) {
            std::fprintf(stderr, "fuzz: query returned %g\n", v);
            std::abort();
        }
    });
    return 0;
}
