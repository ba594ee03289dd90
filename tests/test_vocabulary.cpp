// test_vocabulary.cpp — the name tables of host/core/vocabulary.h and the
// `method` attribute of stored tables.
//
// Oracles: the spellings the file format, the spec format and the CLI have
// always used (docs/spec.md, docs/format.md, `brdftab models --json`),
// written out here by hand, and the geometry of the coordinates (mu = cos
// theta lies in [-1, 1]; theta in [0, 180] deg; phi_d = phi_o - phi_i).
#include <doctest/doctest.h>

#include <string>
#include <vector>

#include "host/core/error.h"
#include "host/core/table.h"
#include "host/core/vocabulary.h"

using namespace brdftab;

TEST_CASE("integration methods: names as in specs, files and --method") {
    const std::vector<std::pair<Method, std::string>> expected = {
        {Method::Auto, "auto"},
        {Method::ClosedForm, "closed-form"},
        {Method::Quadrature, "quadrature"},
        {Method::MonteCarlo, "mc"},
        {Method::Rqmc, "rqmc"},
    };
    std::vector<std::string> names;
    for (const auto& [method, name] : expected) {
        CHECK(to_string(method) == name);
        CHECK(parse_method(name) == method);
        names.push_back(name);
    }
    CHECK(method_names() == names);
    CHECK_FALSE(find_method("MC").has_value());
    try {
        parse_method("simpson");
        FAIL("parse_method accepted 'simpson'");
    } catch (const InputError& e) {
        CHECK(std::string(e.what()) ==
              "integration method 'simpson' is not valid; allowed: auto, closed-form, "
              "quadrature, mc, rqmc");
    }
}

TEST_CASE("table kinds and spacings round-trip; unknown names list the allowed ones") {
    for (const auto& [kind, name] : {std::pair{TableKind::Computed, "computed"},
                                     std::pair{TableKind::Recombined, "recombined"},
                                     std::pair{TableKind::Error, "error"},
                                     std::pair{TableKind::Inverted, "inverted"}}) {
        CHECK(to_string(kind) == name);
        CHECK(parse_table_kind(name) == kind);
    }
    CHECK_THROWS_WITH_AS(parse_table_kind("derived"),
                         "unknown table kind 'derived'; allowed: computed, recombined, error, "
                         "inverted",
                         InputError);
    for (const auto& [spacing, name] : {std::pair{Spacing::Linear, "linear"},
                                        std::pair{Spacing::Cos, "cos"},
                                        std::pair{Spacing::Log, "log"},
                                        std::pair{Spacing::Quadratic, "quadratic"},
                                        std::pair{Spacing::Explicit, "explicit"}}) {
        CHECK(std::string(spacing_name(spacing)) == name);
        CHECK(parse_spacing(name) == spacing);
    }
}

TEST_CASE("direction coordinates: names, units, ranges and the slot each feeds") {
    CHECK(coordinate_names() == std::vector<std::string>{"theta_i", "phi_i", "theta_o", "phi_o",
                                                         "phi_d", "mu_i", "mu_o"});
    CHECK(find_coordinate("alpha") == nullptr);
    CHECK(find_coordinate("Theta_i") == nullptr);
    for (const char* theta : {"theta_i", "theta_o"}) {
        const CoordinateInfo* c = find_coordinate(theta);
        REQUIRE(c != nullptr);
        CHECK(std::string(c->unit) == "deg");
        CHECK(c->min == 0);
        CHECK(c->max == 180);
        CHECK(c->direction == c->id);
    }
    // mu = cos(theta) describes the same direction as theta, unitless in [-1, 1].
    for (const auto& [mu, theta] : {std::pair{"mu_i", "theta_i"}, std::pair{"mu_o", "theta_o"}}) {
        const CoordinateInfo* m = find_coordinate(mu);
        const CoordinateInfo* t = find_coordinate(theta);
        REQUIRE(m != nullptr);
        REQUIRE(t != nullptr);
        CHECK(std::string(m->unit) == "1");
        CHECK(m->min == -1);
        CHECK(m->max == 1);
        CHECK(m->direction == t->id);
        CHECK(m->slot == t->slot);
        CHECK(m->encoding == CoordinateEncoding::Cosine);
    }
    // phi_d = phi_o - phi_i replaces phi_o.
    const CoordinateInfo& phi_d = coordinate_info(Coordinate::PhiD);
    CHECK(phi_d.direction == Coordinate::PhiO);
    CHECK(phi_d.slot == coordinate_info(Coordinate::PhiO).slot);
    CHECK(phi_d.encoding == CoordinateEncoding::AzimuthOffset);
    // The four kernel slots, in the kernel's order.
    CHECK(coordinate_info(Coordinate::ThetaI).slot == 0);
    CHECK(coordinate_info(Coordinate::PhiI).slot == 1);
    CHECK(coordinate_info(Coordinate::ThetaO).slot == 2);
    CHECK(coordinate_info(Coordinate::PhiO).slot == 3);
    for (const CoordinateInfo& c : kCoordinates) CHECK(to_string(c.id) == c.name);
}

TEST_CASE("a table's method attribute: method for computed tables, kind for derived ones") {
    TableData t;
    for (const char* name : {"closed-form", "quadrature", "mc", "rqmc", "auto"}) {
        set_method_attribute(t, name);
        CHECK(t.kind == TableKind::Computed);
        CHECK(t.method == parse_method(name));
        CHECK(method_attribute(t) == name);
    }
    for (const char* name : {"recombined", "error", "inverted"}) {
        set_method_attribute(t, name);
        CHECK(t.kind == parse_table_kind(name));
        CHECK(method_attribute(t) == name);
    }
    // A file that records no method: a computed table whose method is unknown.
    set_method_attribute(t, "");
    CHECK(t.kind == TableKind::Computed);
    CHECK(t.method == Method::Auto);
    CHECK_THROWS_WITH_AS(set_method_attribute(t, "computed"),
                         "unknown method 'computed'; allowed: auto, closed-form, quadrature, mc, "
                         "rqmc, recombined, error, inverted",
                         InputError);
}
