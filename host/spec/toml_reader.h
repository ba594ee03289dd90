// toml_reader.h — TOML access that reports where a problem is (internal to
// host/spec).
//
// Every value is read through TomlReader, which checks its type and, on any
// problem, throws an InputError of the form
//   FILE:LINE:COL: key 'dotted.key': what is wrong; allowed: ...
// Keys are spelled out with their full dotted path ("tables[1].axes[0].name")
// so the message can be read without the file at hand.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <toml++/toml.h>

namespace brdftab::spec_detail {

// A 1-based source position (line 1, column 1 when toml++ knows none).
struct Pos {
    std::uint32_t line = 1, column = 1;
};

Pos pos_of(const toml::source_region& r);
Pos pos_of(const toml::node& n);

std::string join(const std::vector<std::string>& items);  // "a, b, c"
std::string num(double v);                                // 10 significant digits
std::string sub(const std::string& prefix, const std::string& key);  // "prefix.key"
std::string indexed(const std::string& prefix, std::size_t k);      // "prefix[k]"

// A table's entries in the order they appear in the file (toml++ iterates in
// key order), so that the first problem reported is the first one typed and a
// conflict is reported at the later of the two lines.  `key_pos`, when given,
// receives each key's position.
std::vector<std::pair<std::string, const toml::node*>> in_file_order(const toml::table& t,
                                                                    std::vector<Pos>* key_pos);

class TomlReader {
public:
    explicit TomlReader(std::string file) : file_(std::move(file)) {}

    [[noreturn]] void fail(Pos p, const std::string& key, const std::string& what) const;

    // InputError at the first key of `t` (in file order) not in `allowed`.
    void check_keys(const toml::table& t, const std::string& prefix,
                    const std::vector<std::string>& allowed) const;
    // Typed getters: nullopt / nullptr when the key is absent, InputError when
    // it has another type.  get_number accepts integers too.
    std::optional<std::string> get_string(const toml::table& t, const std::string& prefix,
                                          const char* key) const;
    std::optional<double> get_number(const toml::table& t, const std::string& prefix,
                                     const char* key) const;
    // The number a node holds (an integer or a float); `key` names it in the
    // "must be a number" error.
    double number(const toml::node& n, const std::string& key) const;
    std::optional<std::int64_t> get_integer(const toml::table& t, const std::string& prefix,
                                            const char* key) const;
    const toml::table* get_table(const toml::table& t, const std::string& prefix,
                                 const char* key) const;
    // An array of tables ([[x]] or x = [{...}]); nullptr when absent.
    const toml::array* get_table_array(const toml::table& t, const std::string& prefix,
                                       const char* key) const;

protected:
    std::string file_;  // as given, for messages
};

}  // namespace brdftab::spec_detail
