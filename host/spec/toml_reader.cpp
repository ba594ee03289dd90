// toml_reader.cpp — position-aware TOML access (see toml_reader.h).
#include "host/spec/toml_reader.h"

#include <algorithm>

#include "host/core/error.h"
#include "host/core/text.h"

namespace brdftab::spec_detail {

Pos pos_of(const toml::source_region& r) {
    Pos p;
    if (r.begin.line > 0) {
        p.line = r.begin.line;
        p.column = r.begin.column > 0 ? r.begin.column : 1;
    }
    return p;
}
Pos pos_of(const toml::node& n) { return pos_of(n.source()); }

std::string join(const std::vector<std::string>& items) {
    std::string out;
    for (std::size_t k = 0; k < items.size(); ++k) {
        if (k) out += ", ";
        out += items[k];
    }
    return out;
}

std::string num(double v) { return number_text(v, 10); }

std::string sub(const std::string& prefix, const std::string& key) {
    return prefix.empty() ? key : prefix + "." + key;
}

std::string indexed(const std::string& prefix, std::size_t k) {
    return prefix + "[" + std::to_string(k) + "]";
}

std::vector<std::pair<std::string, const toml::node*>> in_file_order(const toml::table& t,
                                                                    std::vector<Pos>* key_pos) {
    struct Entry {
        Pos kpos;
        std::string key;
        const toml::node* node;
    };
    std::vector<Entry> es;
    for (auto&& [k, v] : t) es.push_back({pos_of(k.source()), std::string(k.str()), &v});
    std::stable_sort(es.begin(), es.end(), [](const Entry& a, const Entry& b) {
        return a.kpos.line != b.kpos.line ? a.kpos.line < b.kpos.line
                                          : a.kpos.column < b.kpos.column;
    });
    std::vector<std::pair<std::string, const toml::node*>> out;
    for (const Entry& e : es) {
        out.emplace_back(e.key, e.node);
        if (key_pos) key_pos->push_back(e.kpos);
    }
    return out;
}

void TomlReader::fail(Pos p, const std::string& key, const std::string& what) const {
    throw InputError(file_ + ":" + std::to_string(p.line) + ":" + std::to_string(p.column) +
                     ": key '" + key + "': " + what);
}

void TomlReader::check_keys(const toml::table& t, const std::string& prefix,
                            const std::vector<std::string>& allowed) const {
    std::vector<Pos> kpos;
    const auto entries = in_file_order(t, &kpos);
    for (std::size_t n = 0; n < entries.size(); ++n) {
        const std::string& k = entries[n].first;
        bool ok = false;
        for (const auto& a : allowed) ok = ok || (k == a);
        if (!ok) fail(kpos[n], sub(prefix, k), "unknown key; allowed: " + join(allowed));
    }
}

std::optional<std::string> TomlReader::get_string(const toml::table& t,
                                                  const std::string& prefix,
                                                  const char* key) const {
    const toml::node* n = t.get(key);
    if (!n) return std::nullopt;
    if (!n->is_string()) fail(pos_of(*n), sub(prefix, key), "must be a string");
    return n->as_string()->get();
}

std::optional<double> TomlReader::get_number(const toml::table& t, const std::string& prefix,
                                             const char* key) const {
    const toml::node* n = t.get(key);
    if (!n) return std::nullopt;
    return number(*n, sub(prefix, key));
}

double TomlReader::number(const toml::node& n, const std::string& key) const {
    if (n.is_integer()) return double(n.as_integer()->get());
    if (n.is_floating_point()) return n.as_floating_point()->get();
    fail(pos_of(n), key, "must be a number");
}

std::optional<std::int64_t> TomlReader::get_integer(const toml::table& t,
                                                    const std::string& prefix,
                                                    const char* key) const {
    const toml::node* n = t.get(key);
    if (!n) return std::nullopt;
    if (!n->is_integer()) fail(pos_of(*n), sub(prefix, key), "must be an integer");
    return n->as_integer()->get();
}

const toml::table* TomlReader::get_table(const toml::table& t, const std::string& prefix,
                                         const char* key) const {
    const toml::node* n = t.get(key);
    if (!n) return nullptr;
    if (!n->is_table())
        fail(pos_of(*n), sub(prefix, key),
             std::string("must be a table ([") + sub(prefix, key) + "] section or inline {...})");
    return n->as_table();
}

const toml::array* TomlReader::get_table_array(const toml::table& t, const std::string& prefix,
                                               const char* key) const {
    const toml::node* n = t.get(key);
    if (!n) return nullptr;
    const toml::array* a = n->as_array();
    if (!a)
        fail(pos_of(*n), sub(prefix, key),
             std::string("must be an array of tables ([[") + sub(prefix, key) + "]] sections)");
    for (std::size_t k = 0; k < a->size(); ++k)
        if (!(*a)[k].is_table())
            fail(pos_of((*a)[k]), indexed(sub(prefix, key), k),
                 "must be a table (one [[" + sub(prefix, key) + "]] section)");
    return a;
}

}  // namespace brdftab::spec_detail
