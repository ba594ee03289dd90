// vocabulary.cpp — lookups in the name tables of vocabulary.h.
#include "host/core/vocabulary.h"

#include "host/core/error.h"

namespace brdftab {

namespace {

template <class Enum, std::size_t N>
const char* name_in(const NamedValue<Enum> (&table)[N], Enum value) {
    for (const auto& entry : table)
        if (entry.value == value) return entry.name;
    // Every enumerator has a row; reaching here means a row was forgotten.
    throw Error("vocabulary: value " + std::to_string(static_cast<int>(value)) +
                " has no name");
}

template <class Enum, std::size_t N>
std::optional<Enum> value_in(const NamedValue<Enum> (&table)[N], std::string_view name) {
    for (const auto& entry : table)
        if (name == entry.name) return entry.value;
    return std::nullopt;
}

template <class Enum, std::size_t N>
std::vector<std::string> names_in(const NamedValue<Enum> (&table)[N]) {
    std::vector<std::string> out;
    for (const auto& entry : table) out.emplace_back(entry.name);
    return out;
}

std::string join(const std::vector<std::string>& items) {
    std::string out;
    for (std::size_t k = 0; k < items.size(); ++k) out += (k ? ", " : "") + items[k];
    return out;
}

}  // namespace

std::string to_string(Method method) { return name_in(kMethodNames, method); }

std::optional<Method> find_method(std::string_view name) { return value_in(kMethodNames, name); }

Method parse_method(const std::string& name) {
    if (const auto m = find_method(name)) return *m;
    throw InputError("integration method '" + name + "' is not valid; allowed: " +
                     join(method_names()));
}

std::vector<std::string> method_names() { return names_in(kMethodNames); }

const char* spacing_name(Spacing s) { return name_in(kSpacingNames, s); }

Spacing parse_spacing(const std::string& name) {
    if (const auto s = value_in(kSpacingNames, name)) return *s;
    throw InputError("unknown spacing '" + name + "'; allowed: " + join(names_in(kSpacingNames)));
}

std::string to_string(TableKind kind) { return name_in(kTableKindNames, kind); }

std::optional<TableKind> find_table_kind(std::string_view name) {
    return value_in(kTableKindNames, name);
}

TableKind parse_table_kind(const std::string& name) {
    if (const auto k = find_table_kind(name)) return *k;
    throw InputError("unknown table kind '" + name + "'; allowed: " +
                     join(names_in(kTableKindNames)));
}

const CoordinateInfo& coordinate_info(Coordinate c) {
    for (const CoordinateInfo& info : kCoordinates)
        if (info.id == c) return info;
    throw Error("vocabulary: coordinate " + std::to_string(static_cast<int>(c)) +
                " has no table row");
}

const CoordinateInfo* find_coordinate(std::string_view name) {
    for (const CoordinateInfo& info : kCoordinates)
        if (name == info.name) return &info;
    return nullptr;
}

std::string to_string(Coordinate c) { return coordinate_info(c).name; }

std::vector<std::string> coordinate_names() {
    std::vector<std::string> out;
    for (const CoordinateInfo& info : kCoordinates) out.emplace_back(info.name);
    return out;
}

}  // namespace brdftab
