// test_point_file.cpp — CSV point files (host/io/point_file.h): splitting,
// number parsing, the file:line messages of every rejection, and the order in
// which rows reach a caller.
//
// Oracles: the CSV texts written here and the values and messages expected
// of them, by hand.
#include <doctest/doctest.h>

#include "test_support.h"

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "host/core/error.h"
#include "host/io/point_file.h"

namespace fs = std::filesystem;
using namespace brdftab;

namespace {

// Writes `text` to a fresh file in this test's scratch directory.
std::string write_csv(const std::string& sub, const std::string& text) {
    const fs::path d = test::scratch_dir(BT_BINARY_DIR, "test_point_file", sub);
    const fs::path p = d / "points.csv";
    std::ofstream(p) << text;
    return p.string();
}

}  // namespace

TEST_CASE("split_csv trims cells and keeps empty ones") {
    CHECK(split_csv("a, b ,\tc") == std::vector<std::string>{"a", "b", "c"});
    CHECK(split_csv("a,b,") == std::vector<std::string>{"a", "b", ""});
    CHECK(split_csv("a,,b\r") == std::vector<std::string>{"a", "", "b"});
    CHECK(split_csv("").empty());
}

TEST_CASE("parse_number accepts whole finite numbers only") {
    CHECK(parse_number("1.5", "x") == 1.5);
    CHECK(parse_number("-2e3", "x") == -2000.0);
    CHECK(test::input_error([] { parse_number("abc", "argument 'alpha'"); }) ==
          "argument 'alpha': 'abc' is not a finite number");
    for (const char* bad : {"", "1.5x", "inf", "nan", "1e999"})
        CHECK(test::input_error([&] { parse_number(bad, "x"); }) != "");
}

TEST_CASE("a point file: header, rows with their lines, blank lines skipped") {
    const std::string path = write_csv("good", "\n theta_o , phi_d\r\n60,135\n\n 10 ,45.5\n");
    const PointFile f = read_point_file(path);
    CHECK(f.header == std::vector<std::string>{"theta_o", "phi_d"});
    REQUIRE(f.rows.size() == 2);
    CHECK(f.rows[0].line == 3);
    CHECK(f.rows[1].line == 5);
    CHECK(f.rows[1].cells == std::vector<std::string>{"10", "45.5"});
    CHECK(f.rows[1].values == std::vector<double>{10.0, 45.5});
    CHECK(f.where(f.rows[1]) == path + ":5");
    // Columns lie over the defaults; names the file lacks keep theirs.
    const auto named = f.named(f.rows[0], {{"theta_i", 40.0}, {"phi_d", 1.0}});
    CHECK(named == std::map<std::string, double>{{"theta_i", 40.0}, {"theta_o", 60.0},
                                                 {"phi_d", 135.0}});
}

TEST_CASE("every rejection names the file and line") {
    CHECK(test::input_error([] { read_point_file("/nonexistent/points.csv"); }) ==
          "cannot open points file '/nonexistent/points.csv'");

    std::string p = write_csv("columns", "a,b\n1,2\n1,2,3\n");
    CHECK(test::input_error([&] { read_point_file(p); }) == p + ":3: 3 columns, header has 2");

    p = write_csv("number", "a,b\n1,x\n");
    CHECK(test::input_error([&] { read_point_file(p); }) ==
          p + ":2: column 'b': 'x' is not a finite number");

    p = write_csv("empty", "\n a,b \n\n");
    CHECK(test::input_error([&] { read_point_file(p); }) == "points file '" + p + "' has no rows");

    p = write_csv("rules", "a,z\n1,2\n");
    PointFileRules rules;
    rules.column_problem = [](const std::string& c) {
        return c == "z" ? std::string("is not known") : std::string();
    };
    CHECK(test::input_error([&] { read_point_file(p, rules); }) == p + ":1: column 'z' is not known");

    p = write_csv("twice", "a,a\n1,2\n");
    CHECK_NOTHROW(read_point_file(p));  // repeated columns are allowed unless asked
    rules = PointFileRules{};
    rules.unique_columns = true;
    CHECK(test::input_error([&] { read_point_file(p, rules); }) == p + ":1: column 'a' twice");

    p = write_csv("values", "a,b\n1,2\n1,-2\n");
    rules = PointFileRules{};
    rules.value_problem = [](const std::string&, double v) {
        return v < 0 ? std::string("negative") : std::string();
    };
    CHECK(test::input_error([&] { read_point_file(p, rules); }) == p + ":3: column 'b': negative");
}

TEST_CASE("rows reach on_row in file order, before later lines are read") {
    // Row 3 is malformed: an error the caller raises at row 2 must win.
    const std::string p = write_csv("order", "a\n1\n2\nx\n");
    std::vector<std::size_t> seen;
    PointFileRules rules;
    rules.on_row = [&](const PointFile& f, const PointRow& row) {
        seen.push_back(row.line);
        CHECK(&f.rows.back() == &row);
        if (row.values[0] == 2) throw InputError(f.where(row) + ": caller's error");
    };
    CHECK(test::input_error([&] { read_point_file(p, rules); }) == p + ":3: caller's error");
    CHECK(seen == std::vector<std::size_t>{2, 3});
}
