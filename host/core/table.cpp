// table.cpp — small helpers of the in-memory table (see table.h).
#include "host/core/table.h"

#include <string>

#include "host/core/error.h"

namespace brdftab {

const char* stored_type_name(StoredType t) {
    switch (t) {
    case StoredType::Float64: return "float64";
    case StoredType::Float32: return "float32";
    case StoredType::Float16: return "float16";
    }
    return "unknown";
}

StoredType parse_stored_type(const std::string& name) {
    if (name == "float64") return StoredType::Float64;
    if (name == "float32") return StoredType::Float32;
    if (name == "float16") return StoredType::Float16;
    throw InputError("unknown stored type '" + name +
                     "' (allowed: float64, float32, float16)");
}

std::string method_attribute(const TableData& t) {
    return t.kind == TableKind::Computed ? to_string(t.method) : to_string(t.kind);
}

void set_method_attribute(TableData& t, const std::string& attribute) {
    if (attribute.empty()) {
        t.kind = TableKind::Computed;
        t.method = Method::Auto;
        return;
    }
    if (const std::optional<Method> m = find_method(attribute)) {
        t.kind = TableKind::Computed;
        t.method = *m;
        return;
    }
    // "computed" alone says nothing a method name would not: not a value.
    const std::optional<TableKind> k = find_table_kind(attribute);
    if (k && *k != TableKind::Computed) {
        t.kind = *k;
        t.method = Method::Auto;
        return;
    }
    std::string allowed;
    for (const std::string& name : method_names()) allowed += name + ", ";
    for (const auto& [kind, name] : kTableKindNames)
        if (kind != TableKind::Computed) allowed += name + std::string(", ");
    allowed.resize(allowed.size() - 2);
    throw InputError("unknown method '" + attribute + "'; allowed: " + allowed);
}

std::size_t TableData::cell_count() const {
    return checked_cell_count(axes, "table '" + name + "': ");
}

std::vector<std::size_t> TableData::shape() const {
    std::vector<std::size_t> s;
    s.reserve(axes.size());
    for (const Axis& a : axes) s.push_back(a.count);
    return s;
}

std::size_t TableData::flat_index(const std::vector<std::size_t>& index) const {
    if (index.size() != axes.size())
        throw Error("table '" + name + "': index has " + std::to_string(index.size()) +
                    " components, the table has " + std::to_string(axes.size()) + " axes");
    std::size_t flat = 0;
    for (std::size_t i = 0; i < axes.size(); ++i) {
        if (index[i] >= axes[i].count)
            throw Error("table '" + name + "': index " + std::to_string(index[i]) +
                        " out of range for axis '" + axes[i].name + "' (count " +
                        std::to_string(axes[i].count) + ")");
        flat = flat * axes[i].count + index[i];  // Horner form of the row-major offset
    }
    return flat;
}

}  // namespace brdftab
