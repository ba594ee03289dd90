// atomic_file.h — how every brdftab output reaches the disk: written under a
// temporary name beside the target, synced, and renamed over the target only
// when complete.  A failed run never leaves a partial file, nor damages a file
// the user already had.
#pragma once

#include <string>

namespace brdftab {

// What an output path may name.  A missing file or a regular file is
// replaced; a symbolic link is followed (to any depth) and the file it leads
// to is replaced, the link itself is kept; anything else (directory, FIFO,
// device, socket) is refused with InputError, so `-o /dev/null` can never
// replace a device node.  Returns the path that will be replaced.
std::string resolve_output_path(const std::string& target);

// RAII temporary path: `path()` is where to write; `commit()` syncs the file
// and renames it over the target; the destructor removes the temporary file
// unless committed.  The target is resolved by resolve_output_path().
// Temporary files are named `<target>.tmp-<pid>-<n>`; those left by a process
// that no longer runs (a killed run) are removed when a new AtomicOutput for
// the same target is made.
class AtomicOutput {
public:
    explicit AtomicOutput(std::string target);
    ~AtomicOutput();
    AtomicOutput(const AtomicOutput&) = delete;
    AtomicOutput& operator=(const AtomicOutput&) = delete;

    const std::string& path() const { return temp_; }
    const std::string& target() const { return target_; }
    void commit();  // throws Error

private:
    std::string target_, temp_;
    bool committed_ = false;
};

// The one writer of an output: an advisory lock (flock) on `<target>.lock`
// beside the resolved target, held from construction to destruction, so that
// two runs writing the same output at the same time cannot silently replace
// each other's file.  A second OutputLock of the same target, in this or
// another process, throws InputError naming the output, the lock file and the
// process that holds it.  The destructor removes the lock file.  A killed
// process's lock is released by the kernel with its descriptors, so a lock
// file left behind never blocks a later run.  flock is local to a machine on
// most network file systems.
class OutputLock {
public:
    explicit OutputLock(const std::string& target);
    ~OutputLock();
    OutputLock(const OutputLock&) = delete;
    OutputLock& operator=(const OutputLock&) = delete;

    const std::string& path() const { return path_; }  // the lock file

private:
    std::string path_;
    int fd_ = -1;
};

// Whole text file, atomically.
void write_text_atomically(const std::string& target, const std::string& text);

// Fails early (InputError) when `target` cannot be written: an empty path,
// a missing or unwritable directory, a name the file system refuses (too
// long), or something other than a regular file in its place (see
// resolve_output_path).  Creates and removes a probe file under the
// temporary name, so what passes here can be written after a long compute.
void check_output_writable(const std::string& target);

}  // namespace brdftab
