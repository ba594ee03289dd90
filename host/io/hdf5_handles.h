// hdf5_handles.h — the thin RAII layer over the HDF5 C API used by the table
// file code (table_io.cpp, hdf5_attributes.cpp).  Not installed.
//
// H5Cpp has no dimension-scale API and HighFive is not packaged on Debian 12,
// so every hid_t lives in a Handle that closes it, and every failing call
// becomes a brdftab::Error naming the call and the innermost message of
// HDF5's error stack.  HDF5's automatic printing of that stack is switched
// off because the library never prints.
#pragma once

#include <hdf5.h>

#include <string>

namespace brdftab::hdf5 {

// Switch off HDF5's printing of its error stack (once per process).
void silence_hdf5();

// Throw brdftab::Error for a failed HDF5 call, with the innermost message of
// HDF5's error stack; `what` names the object (file, dataset, attribute).
[[noreturn]] void fail(const std::string& call, const std::string& what);

// `status` when >= 0, otherwise fail(call, what).
herr_t check(herr_t status, const char* call, const std::string& what = {});

class Handle {
public:
    using Closer = herr_t (*)(hid_t);
    Handle() = default;
    Handle(hid_t id, Closer closer, const char* call, const std::string& what = {})
        : id_(id), closer_(closer) {
        if (id_ < 0) fail(call, what);
    }
    Handle(const Handle&) = delete;
    Handle& operator=(const Handle&) = delete;
    Handle(Handle&& o) noexcept : id_(o.id_), closer_(o.closer_) { o.id_ = -1; }
    Handle& operator=(Handle&& o) noexcept {
        if (this != &o) {
            reset();
            id_ = o.id_;
            closer_ = o.closer_;
            o.id_ = -1;
        }
        return *this;
    }
    ~Handle() { reset(); }

    hid_t get() const { return id_; }
    operator hid_t() const { return id_; }  // NOLINT: handles pass straight to the C API

    // Close now and report failure (the destructor must stay silent).  Used
    // for the file, whose close flushes everything to disk.
    void close(const char* call, const std::string& what = {}) {
        if (id_ < 0) return;
        hid_t id = id_;
        id_ = -1;
        check(closer_(id), call, what);
    }

private:
    void reset() noexcept {
        if (id_ >= 0 && closer_) closer_(id_);
        id_ = -1;
    }
    hid_t id_ = -1;
    Closer closer_ = nullptr;
};

// Files open for writing.  HDF5 1.10 frees a file whose H5Fclose fails (a
// full disk, a file size limit) but keeps its id registered, and its cleanup
// at process exit then crashes on that id (SIGSEGV in H5F__close_cb); a
// failed flush leaves the file unable to flush or close at all.  So a file
// to be kept reserves its disk space before it is closed, and a file whose
// contents are to be thrown away is detached from the disk first: its close
// then has nothing to write that can fail.  As a last resort a program can
// switch the library's exit-time cleanup off (disable_hdf5_exit_cleanup,
// table_io.h; brdftab's main does): the operating system then releases what
// a failed close could not.

// Points the descriptor of `file` (open for writing through HDF5's default
// POSIX driver) at an anonymous in-memory file, so that whatever HDF5 writes
// from now on (flushes, the close) goes nowhere and cannot fail for lack of
// disk space.  The file on disk keeps what had reached it.  For a file to be
// discarded only; does nothing for another driver or when no anonymous file
// can be made.
void detach_from_disk(hid_t file) noexcept;

// Closes `file` (open for writing), checked.  Its disk space up to its end of
// allocation is reserved first (fallocate): when that fails (no space, a file
// size limit), the file is detached and closed and brdftab::Error names
// `what` and the system's reason, so the id is released whatever the disk
// does.  A file system without fallocate is not reserved.
void close_written_file(Handle& file, const std::string& what);

Handle make_plist(hid_t cls, const char* what);
Handle copy_type(hid_t t);
Handle scalar_space();
// Variable-length UTF-8 string type.
Handle utf8_string_type();
// IEEE binary16 as an HDF5 float type (see hdf5_handles.cpp).
Handle half_type();

}  // namespace brdftab::hdf5
