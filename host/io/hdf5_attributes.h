// hdf5_attributes.h — scalar attributes of HDF5 objects (strings, doubles,
// integers) written and read through the handles of hdf5_handles.h.  The table
// file schema (table_io.cpp) stores all provenance this way.  Not installed.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "host/io/hdf5_handles.h"

namespace brdftab::hdf5 {

void write_string_attr(hid_t obj, const char* name, const std::string& value);
void write_attr(hid_t obj, const char* name, hid_t file_type, hid_t mem_type,
                const void* value);
void write_double_attr(hid_t obj, const char* name, double v);
void write_u64_attr(hid_t obj, const char* name, std::uint64_t v);
void write_i32_attr(hid_t obj, const char* name, std::int32_t v);

bool has_attr(hid_t obj, const char* name);
Handle open_attr(hid_t obj, const char* name);
// "'FILE', object 'PATH', attribute 'NAME'", for messages.
std::string attr_location(hid_t obj, const std::string& name);

// The readers below accept a scalar or a 1-element array of the right class
// only, and throw InputError naming the file, the object and the attribute
// otherwise (an array where one value belongs would overrun the buffer).
// Variable- or fixed-length string attributes alike.
std::string read_string_attr(hid_t obj, const char* name);
// Integer or float.
double read_double_attr(hid_t obj, const char* name);
// Integer class only; a negative signed value is refused.
std::uint64_t read_u64_attr(hid_t obj, const char* name);
// A single string (bytes that are not UTF-8 replaced by U+FFFD), or a scalar
// or 1-D integer/float attribute as JSON (others, string arrays included:
// null).
nlohmann::json attr_to_json(hid_t obj, const std::string& name);
// Names of all attributes of `obj`, in name order.
std::vector<std::string> attr_names(hid_t obj);

}  // namespace brdftab::hdf5
