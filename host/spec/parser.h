// parser.h — the spec parser's shared declarations (internal to host/spec).
//
// Parsing is done in two stages: first every section is read and checked on
// its own (types, names, ranges), keeping the source position of everything;
// then each [[tables]] entry is merged with the global [parameters] and
// [[axes]] and checked against its quantity (which directions it depends on,
// what must be given).  The Parser's members are defined by topic:
//   spec.cpp      the file as a whole (run), [integration], [output]
//   tables.cpp    [parameters] blocks and [[tables]] entries
//   axes.cpp      [[axes]] entries
//   derived.cpp   [[recombined]], [[errors]] and [[inverted]] tables
#pragma once

#include <cstdint>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "host/models/registry.h"
#include "host/spec/spec.h"
#include "host/spec/toml_reader.h"

namespace brdftab::spec_detail {

// Per-cell sample counts and the kernel's cell index are 32-bit.
constexpr std::uint64_t kMaxU32 = std::numeric_limits<std::uint32_t>::max();
constexpr std::size_t kMaxAxisCount = std::size_t(1) << 24;

// Which group of mutually exclusive names a coordinate belongs to: theta and
// mu describe the same direction, phi_d replaces phi_o (CoordinateInfo::direction);
// a parameter is a group of its own.
std::string group_of(const std::string& name);
// Whether quantity `q` depends on the direction a coordinate describes.
bool depends_on(const QuantityInfo& q, const std::string& coordinate);
// "it depends on theta_i, theta_o" (for messages).
std::string depends_text(const QuantityInfo& q);

class Parser : public TomlReader {
public:
    Parser(std::string file, std::string text)
        : TomlReader(std::move(file)), text_(std::move(text)) {}
    Spec run();

private:
    // A fixed value from a [parameters] block.
    struct Fixed {
        std::string name;
        double value = 0;
        Pos pos;
        std::string key;
    };
    struct Choice {
        std::string name, value;
        Pos pos;
        std::string key;
    };
    struct Block {
        std::vector<Fixed> fixed;
        std::vector<Choice> options;
    };
    struct AxisSrc {
        Axis axis;
        Pos pos;          // position of the axis' `name` value
        std::string key;  // e.g. "axes[2]"
    };

    // spec.cpp: the whole file, section by section, and its settings.
    void parse_integration(const toml::table& t, IntegrationSettings& s) const;
    void parse_output(const toml::table& t, OutputSettings& o) const;

    // tables.cpp: fixed values and options, and one [[tables]] entry.
    std::string allowed_names() const;
    Block parse_parameters(const toml::table& t, const std::string& prefix) const;
    TableSpec build_table(const toml::table& t, const std::string& prefix,
                          const Block& global_params, const std::vector<AxisSrc>& global_axes,
                          const IntegrationSettings& integration, Pos method_pos) const;

    // axes.cpp: [[axes]] lists and single axes.
    std::vector<AxisSrc> parse_axes(const toml::array& a, const std::string& prefix) const;
    // A critical axis takes eta from the table's eta axis, or else from its
    // fixed eta (its nodes are then positions); checks its nodes either way.
    void resolve_critical_axes(std::vector<AxisSrc>& axes,
                               const std::map<std::string, double>& fixed) const;
    // free_unit: an axis that is no model coordinate (e.g. the value axis of an
    // [[inverted]] table), with that unit and no range limit.
    AxisSrc parse_axis(const toml::table& t, const std::string& prefix,
                       const char* free_unit = nullptr) const;

    // adaptive_keys.cpp: [adaptive] (spec_level) and a table's `adaptive`,
    // checked against the axes of `tables` (every table the settings apply
    // to): a named axis must be one of theirs, a breakpoint inside its open
    // range and on an axis whose warp depends on nothing else.
    AdaptiveSpecSettings parse_adaptive(const toml::table& t, const std::string& prefix, bool spec_level,
                                        const std::vector<const TableSpec*>& tables) const;

    // derived.cpp: tables formed from other tables of the spec.
    RecombinedSpec parse_recombined(const toml::table& t, const std::string& prefix,
                                    const Spec& spec, std::map<std::string, Pos>& names) const;
    ErrorTableSpec parse_error_table(const toml::table& t, const std::string& prefix,
                                     const Spec& spec, std::map<std::string, Pos>& names) const;
    InvertedSpec parse_inverted(const toml::table& t, const std::string& prefix,
                                const Spec& spec, std::map<std::string, Pos>& names) const;
    // The `name` of a table formed from others: present, valid, unique.
    std::string derived_name(const toml::table& t, const std::string& prefix,
                             std::map<std::string, Pos>& names, const char* what) const;
    // The table a string key names: a [[tables]] entry (for recombined terms),
    // or also a [[recombined]] one (then its first term's axes and quantity).
    const TableSpec& source_table(const toml::table& t, const std::string& prefix,
                                  const char* key, const Spec& spec, bool allow_recombined,
                                  const std::string& hint) const;

    std::string text_;
    const ModelInfo* model_ = nullptr;
};

}  // namespace brdftab::spec_detail
