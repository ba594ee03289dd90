// hdf5_handles.cpp — HDF5 error handling and the small handle factories
// declared in hdf5_handles.h.
#include "host/io/hdf5_handles.h"

#include "host/core/error.h"

namespace brdftab::hdf5 {

namespace {

herr_t collect_error(unsigned, const H5E_error2_t* e, void* data) {
    auto* out = static_cast<std::string*>(data);
    // The walk runs from the API call inwards; the innermost entry usually
    // carries the concrete cause (errno text, missing object name).
    if (e && e->desc && *e->desc) *out = e->desc;
    return 0;
}

}  // namespace

void silence_hdf5() {
    // Once per process: HDF5 keeps the setting globally.
    static const bool done = [] {
        H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
        return true;
    }();
    (void)done;
}

[[noreturn]] void fail(const std::string& call, const std::string& what) {
    std::string detail;
    H5Ewalk2(H5E_DEFAULT, H5E_WALK_DOWNWARD, collect_error, &detail);
    H5Eclear2(H5E_DEFAULT);
    std::string msg = "HDF5 " + call + " failed";
    if (!what.empty()) msg += " (" + what + ")";
    if (!detail.empty()) msg += ": " + detail;
    throw Error(msg);
}

herr_t check(herr_t status, const char* call, const std::string& what) {
    if (status < 0) fail(call, what);
    return status;
}

Handle make_plist(hid_t cls, const char* what) {
    return Handle(H5Pcreate(cls), H5Pclose, "H5Pcreate", what);
}
Handle copy_type(hid_t t) { return Handle(H5Tcopy(t), H5Tclose, "H5Tcopy"); }
Handle scalar_space() { return Handle(H5Screate(H5S_SCALAR), H5Sclose, "H5Screate"); }

Handle utf8_string_type() {
    Handle t = copy_type(H5T_C_S1);
    check(H5Tset_size(t, H5T_VARIABLE), "H5Tset_size");
    check(H5Tset_cset(t, H5T_CSET_UTF8), "H5Tset_cset");
    return t;
}

// IEEE binary16 as an HDF5 float type: sign bit 15, exponent bits 10..14,
// mantissa bits 0..9, bias 15.  h5py maps exactly this layout to numpy.float16.
Handle half_type() {
    Handle t = copy_type(H5T_IEEE_F32LE);
    check(H5Tset_fields(t, 15, 10, 5, 0, 10), "H5Tset_fields");
    check(H5Tset_size(t, 2), "H5Tset_size");
    check(H5Tset_ebias(t, 15), "H5Tset_ebias");
    return t;
}

}  // namespace brdftab::hdf5
