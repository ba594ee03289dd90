// spec.h — table specifications (TOML).  Full key reference: docs/spec.md.
//
// Every error is an InputError whose message starts with
// "<file>:<line>:<column>: key '<dotted.key>': " and states the allowed values
// or range, so the CLI can print it as is and exit with code 2.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "engine.h"
#include "grid.h"
#include "table.h"

namespace brdftab {

struct OutputSettings {
    std::string path;  // relative paths are relative to the current directory
    StoredType stored_type = StoredType::Float32;
    int compression = 6;  // deflate level 0..9
    bool keep_stderr = true;
};

struct TableSpec {
    std::string name;      // group name in the file (default: the quantity)
    std::string quantity;
    std::string description;
    // Fixed continuous parameters and directions (user units), name -> value.
    std::map<std::string, double> fixed;
    // Categorical options, name -> choice (validated against the model).
    nlohmann::json options = nlohmann::json::object();
    std::vector<Axis> axes;
};

struct Spec {
    std::string file;  // path as given (for messages); "<string>" when parsed from text
    std::string text;  // the spec's full text (stored in the output file)
    std::string model;
    std::string description;
    std::vector<TableSpec> tables;
    IntegrationSettings integration;
    OutputSettings output;
};

Spec parse_spec_file(const std::string& path);
Spec parse_spec_string(const std::string& text, const std::string& file_name);

}  // namespace brdftab
