// hdf5_handles.cpp — HDF5 error handling and the small handle factories
// declared in hdf5_handles.h.
#include "host/io/hdf5_handles.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "host/core/error.h"
#include "host/io/table_io.h"

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

namespace {

// The descriptor of `file` when it is open through HDF5's default POSIX
// driver, otherwise -1.
int posix_descriptor(hid_t file) {
    bool posix = false;
    const hid_t fapl = H5Fget_access_plist(file);
    if (fapl >= 0) {
        posix = H5Pget_driver(fapl) == H5FD_SEC2;
        H5Pclose(fapl);
    }
    void* handle = nullptr;
    if (!posix || H5Fget_vfd_handle(file, H5P_DEFAULT, &handle) < 0 || !handle) {
        H5Eclear2(H5E_DEFAULT);
        return -1;
    }
    return *static_cast<int*>(handle);
}

}  // namespace

void detach_from_disk(hid_t file) noexcept {
    const int fd = posix_descriptor(file);
    if (fd < 0) return;
    const int scratch = memfd_create("brdftab-discarded", MFD_CLOEXEC);
    if (scratch < 0) return;
    // `fd` now names the in-memory file; HDF5 closes it with the file.
    dup2(scratch, fd);
    close(scratch);
}

void close_written_file(Handle& file, const std::string& what) {
    if (file.get() < 0) return;
    // A flush that fails leaves libhdf5 1.10 unable to flush or close the
    // file ever after ("slist already enabled"), so the close must not be
    // the first to find the disk full: the disk space of the whole file (up
    // to its end of allocation, which the close's writes stay within) is
    // reserved first.  Where that fails, the file is detached and closed, and
    // the reservation's error reported.  A file system without fallocate
    // goes on unreserved.
    haddr_t eoa = 0;
    const int fd = posix_descriptor(file);
    if (fd >= 0 && H5Fget_eoa(file, &eoa) >= 0 && eoa > 0 &&
        fallocate(fd, 0, 0, static_cast<off_t>(eoa)) != 0 && errno != EOPNOTSUPP &&
        errno != ENOSYS && errno != EINTR) {
        const std::string why = std::strerror(errno);
        detach_from_disk(file);
        file = Handle();  // closes, into the in-memory file
        H5Eclear2(H5E_DEFAULT);
        throw Error("cannot write '" + what + "' (" + std::to_string(eoa) + " bytes): " + why);
    }
    H5Eclear2(H5E_DEFAULT);
    file.close("H5Fclose", what);
}

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

namespace brdftab {

void disable_hdf5_exit_cleanup() { H5dont_atexit(); }

}  // namespace brdftab
