#include "host/core/atomic_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "host/core/error.h"

namespace brdftab {

namespace {

// pid + a per-process counter: unique across processes and across threads
// of one process writing the same target.
std::string temporary_name(const std::string& target) {
    static std::atomic<unsigned> counter{0};
    return target + ".tmp-" + std::to_string(static_cast<long>(::getpid())) + "-" +
           std::to_string(counter++);
}

void sync_file(const std::string& path) {
    // The rename must not overtake the data on a crash: flush it first.
    const int fd = ::open(path.c_str(), O_RDONLY);
    if (fd < 0) throw Error("cannot reopen '" + path + "' to sync it: " + std::strerror(errno));
    const int rc = ::fsync(fd);
    const int err = errno;
    ::close(fd);
    if (rc != 0) throw Error("fsync of '" + path + "' failed: " + std::strerror(err));
}

}  // namespace

AtomicOutput::AtomicOutput(std::string target)
    : target_(std::move(target)), temp_(temporary_name(target_)) {}

AtomicOutput::~AtomicOutput() {
    if (!committed_) std::remove(temp_.c_str());
}

void AtomicOutput::commit() {
    sync_file(temp_);
    if (std::rename(temp_.c_str(), target_.c_str()) != 0)
        throw Error("cannot rename '" + temp_ + "' to '" + target_ + "': " + std::strerror(errno));
    committed_ = true;
}

void write_text_atomically(const std::string& target, const std::string& text) {
    AtomicOutput out(target);
    {
        std::ofstream f(out.path());
        f << text;
        f.flush();
        if (!f) throw Error("cannot write '" + out.path() + "'");
    }
    out.commit();
}

void check_output_writable(const std::string& target) {
    namespace fs = std::filesystem;
    const fs::path p(target);
    const fs::path dir = p.has_parent_path() ? p.parent_path() : fs::path(".");
    std::error_code ec;
    if (!fs::is_directory(dir, ec))
        throw InputError("output '" + target + "': directory '" + dir.string() + "' does not exist");
    if (::access(dir.c_str(), W_OK) != 0)
        throw InputError("output '" + target + "': directory '" + dir.string() + "' is not writable");
    if (fs::is_directory(p, ec)) throw InputError("output '" + target + "' is a directory");
}

}  // namespace brdftab
