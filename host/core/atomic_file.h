// atomic_file.h — how every brdftab output reaches the disk: written under a
// temporary name beside the target, synced, and renamed over the target only
// when complete.  A failed run never leaves a partial file, nor damages a file
// the user already had.
#pragma once

#include <string>

namespace brdftab {

// RAII temporary path: `path()` is where to write; `commit()` syncs the file
// and renames it over the target; the destructor removes the temporary file
// unless committed.
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

// Whole text file, atomically.
void write_text_atomically(const std::string& target, const std::string& text);

// Fails early (InputError) when `target` cannot be written: missing or
// unwritable directory, or a directory in its place.
void check_output_writable(const std::string& target);

}  // namespace brdftab
