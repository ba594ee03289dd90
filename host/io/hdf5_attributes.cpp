// hdf5_attributes.cpp — attribute helpers declared in hdf5_attributes.h.
#include "host/io/hdf5_attributes.h"

#include <cstring>

#include "host/core/error.h"

namespace brdftab::hdf5 {

void write_string_attr(hid_t obj, const char* name, const std::string& value) {
    Handle type = utf8_string_type();
    Handle space = scalar_space();
    Handle attr(H5Acreate2(obj, name, type, space, H5P_DEFAULT, H5P_DEFAULT), H5Aclose,
                "H5Acreate2", name);
    const char* p = value.c_str();
    check(H5Awrite(attr, type, &p), "H5Awrite", name);
}

void write_attr(hid_t obj, const char* name, hid_t file_type, hid_t mem_type,
                const void* value) {
    Handle space = scalar_space();
    Handle attr(H5Acreate2(obj, name, file_type, space, H5P_DEFAULT, H5P_DEFAULT), H5Aclose,
                "H5Acreate2", name);
    check(H5Awrite(attr, mem_type, value), "H5Awrite", name);
}

void write_double_attr(hid_t obj, const char* name, double v) {
    write_attr(obj, name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, &v);
}
void write_u64_attr(hid_t obj, const char* name, std::uint64_t v) {
    write_attr(obj, name, H5T_STD_U64LE, H5T_NATIVE_UINT64, &v);
}
void write_i32_attr(hid_t obj, const char* name, std::int32_t v) {
    write_attr(obj, name, H5T_STD_I32LE, H5T_NATIVE_INT32, &v);
}

bool has_attr(hid_t obj, const char* name) {
    htri_t r = H5Aexists(obj, name);
    check(r, "H5Aexists", name);
    return r > 0;
}

Handle open_attr(hid_t obj, const char* name) {
    return Handle(H5Aopen(obj, name, H5P_DEFAULT), H5Aclose, "H5Aopen", name);
}

// "'t.h5', object '/brdf', attribute 'seed'": where a bad attribute lives, for
// messages about files that someone else wrote or tampered with.
std::string attr_location(hid_t obj, const std::string& name) {
    std::string file, object;
    ssize_t n = H5Fget_name(obj, nullptr, 0);
    if (n > 0) {
        file.resize(static_cast<std::size_t>(n) + 1);
        H5Fget_name(obj, file.data(), file.size());
        file.resize(static_cast<std::size_t>(n));
    }
    n = H5Iget_name(obj, nullptr, 0);
    if (n > 0) {
        object.resize(static_cast<std::size_t>(n) + 1);
        H5Iget_name(obj, object.data(), object.size());
        object.resize(static_cast<std::size_t>(n));
    }
    H5Eclear2(H5E_DEFAULT);
    std::string out;
    if (!file.empty()) out += "'" + file + "', ";
    if (!object.empty()) out += "object '" + object + "', ";
    return out + "attribute '" + name + "'";
}

namespace {

// `s` with every byte that does not start or continue a well-formed UTF-8
// sequence (RFC 3629: no overlong forms, no surrogates, at most U+10FFFF)
// replaced by U+FFFD.  A damaged file can hold any bytes in a string
// attribute, and nlohmann::json refuses to serialise invalid UTF-8.
std::string valid_utf8(const std::string& s) {
    std::string out;
    out.reserve(s.size());
    std::size_t i = 0;
    while (i < s.size()) {
        const auto b = static_cast<unsigned char>(s[i]);
        std::size_t len = b < 0x80 ? 1 : (b >> 5) == 0x6 ? 2 : (b >> 4) == 0xE ? 3
                                   : (b >> 3) == 0x1E ? 4 : 0;
        bool ok = len > 0 && i + len <= s.size();
        std::uint32_t cp = len == 1 ? b : len == 2 ? (b & 0x1F) : len == 3 ? (b & 0x0F) : (b & 0x07);
        for (std::size_t k = 1; ok && k < len; ++k) {
            const auto c = static_cast<unsigned char>(s[i + k]);
            ok = (c >> 6) == 0x2;
            cp = (cp << 6) | (c & 0x3F);
        }
        if (ok) {
            static const std::uint32_t min_for_len[5] = {0, 0, 0x80, 0x800, 0x10000};
            ok = cp >= min_for_len[len] && cp <= 0x10FFFF && !(cp >= 0xD800 && cp <= 0xDFFF);
        }
        if (ok) {
            out.append(s, i, len);
            i += len;
        } else {
            out += "\xEF\xBF\xBD";  // U+FFFD REPLACEMENT CHARACTER
            ++i;
        }
    }
    return out;
}

// Number of elements of an attribute's dataspace (1 for a scalar).
hssize_t attr_elements(hid_t attr, hid_t obj, const std::string& name) {
    Handle space(H5Aget_space(attr), H5Sclose, "H5Aget_space", name);
    const hssize_t n = H5Sget_simple_extent_npoints(space);
    if (n < 0) throw InputError(attr_location(obj, name) + ": unreadable dataspace");
    return n;
}

// Open an attribute that must hold exactly one element (scalar or 1-element
// array) of class `want`, or of either numeric class when `want` is
// H5T_NO_CLASS.  Every read below then writes one element into a buffer of
// one element: an array stored where a scalar belongs (a hostile or foreign
// file) is refused instead of overrunning the buffer.
Handle open_single_attr(hid_t obj, const char* name, H5T_class_t want, const char* expected) {
    Handle attr = open_attr(obj, name);
    Handle ftype(H5Aget_type(attr), H5Tclose, "H5Aget_type", name);
    const H5T_class_t cls = H5Tget_class(ftype);
    const bool class_ok = want == H5T_NO_CLASS ? (cls == H5T_INTEGER || cls == H5T_FLOAT)
                                               : cls == want;
    if (!class_ok)
        throw InputError(attr_location(obj, name) + ": expected " + expected +
                         ", the file stores another type");
    const hssize_t n = attr_elements(attr, obj, name);
    if (n != 1)
        throw InputError(attr_location(obj, name) + ": expected a single " + expected +
                         ", the file stores " + std::to_string(n) + " elements");
    return attr;
}

}  // namespace

// Reads variable- or fixed-length string attributes alike, so files touched
// by other tools still load.
std::string read_string_attr(hid_t obj, const char* name) {
    Handle attr = open_single_attr(obj, name, H5T_STRING, "string");
    Handle ftype(H5Aget_type(attr), H5Tclose, "H5Aget_type", name);
    htri_t var = H5Tis_variable_str(ftype);
    check(var, "H5Tis_variable_str", name);
    if (var > 0) {
        Handle mtype = utf8_string_type();
        check(H5Tset_cset(mtype, H5Tget_cset(ftype)), "H5Tset_cset", name);
        char* p = nullptr;
        check(H5Aread(attr, mtype, &p), "H5Aread", name);
        std::string s = p ? p : "";
        if (p) H5free_memory(p);
        return s;
    }
    std::size_t n = H5Tget_size(ftype);
    std::string s(n, '\0');
    Handle mtype = copy_type(ftype);
    check(H5Aread(attr, mtype, s.data()), "H5Aread", name);
    s.resize(std::strlen(s.c_str()));  // fixed-length strings may be NUL padded
    return s;
}

double read_double_attr(hid_t obj, const char* name) {
    Handle attr = open_single_attr(obj, name, H5T_NO_CLASS, "number");
    double v = 0;
    check(H5Aread(attr, H5T_NATIVE_DOUBLE, &v), "H5Aread", name);
    return v;
}

std::uint64_t read_u64_attr(hid_t obj, const char* name) {
    Handle attr = open_single_attr(obj, name, H5T_INTEGER, "integer");
    Handle ftype(H5Aget_type(attr), H5Tclose, "H5Aget_type", name);
    if (H5Tget_sign(ftype) == H5T_SGN_NONE) {
        std::uint64_t v = 0;
        check(H5Aread(attr, H5T_NATIVE_UINT64, &v), "H5Aread", name);
        return v;
    }
    // Signed storage (h5py writes int64 by default): a negative count or seed
    // is malformed, not a huge unsigned number.
    std::int64_t v = 0;
    check(H5Aread(attr, H5T_NATIVE_INT64, &v), "H5Aread", name);
    if (v < 0)
        throw InputError(attr_location(obj, name) + ": expected a non-negative integer, got " +
                         std::to_string(v));
    return static_cast<std::uint64_t>(v);
}

// Any single string, or scalar or 1-D integer/float attribute as JSON
// (others: null).  Numeric buffers are sized from the dataspace.
nlohmann::json attr_to_json(hid_t obj, const std::string& name) {
    Handle attr = open_attr(obj, name.c_str());
    Handle ftype(H5Aget_type(attr), H5Tclose, "H5Aget_type", name);
    Handle space(H5Aget_space(attr), H5Sclose, "H5Aget_space", name);
    H5T_class_t cls = H5Tget_class(ftype);
    hssize_t n = H5Sget_simple_extent_npoints(space);
    int rank = H5Sget_simple_extent_ndims(space);
    if (n < 0 || rank < 0 || rank > 1) return nullptr;
    if (cls == H5T_STRING)
        return n == 1 ? nlohmann::json(valid_utf8(read_string_attr(obj, name.c_str())))
                      : nlohmann::json(nullptr);
    nlohmann::json out;
    if (cls == H5T_INTEGER) {
        if (H5Tget_sign(ftype) == H5T_SGN_NONE) {
            std::vector<std::uint64_t> v(static_cast<std::size_t>(n));
            check(H5Aread(attr, H5T_NATIVE_UINT64, v.data()), "H5Aread", name);
            out = v;
        } else {
            std::vector<std::int64_t> v(static_cast<std::size_t>(n));
            check(H5Aread(attr, H5T_NATIVE_INT64, v.data()), "H5Aread", name);
            out = v;
        }
    } else if (cls == H5T_FLOAT) {
        std::vector<double> v(static_cast<std::size_t>(n));
        check(H5Aread(attr, H5T_NATIVE_DOUBLE, v.data()), "H5Aread", name);
        out = v;
    } else {
        return nullptr;
    }
    if (rank == 0 && out.size() == 1) return out[0];
    return out;
}
namespace {

herr_t collect_name(hid_t, const char* name, const H5A_info_t*, void* data) noexcept {
    try {
        static_cast<std::vector<std::string>*>(data)->emplace_back(name);
        return 0;
    } catch (...) {
        return -1;
    }
}

}  // namespace

std::vector<std::string> attr_names(hid_t obj) {
    std::vector<std::string> names;
    hsize_t idx = 0;
    check(H5Aiterate2(obj, H5_INDEX_NAME, H5_ITER_INC, &idx, collect_name, &names),
          "H5Aiterate2");
    return names;
}

}  // namespace brdftab::hdf5
