#include "host/core/atomic_file.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
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

const char* kind_of(mode_t mode) {
    if (S_ISDIR(mode)) return "a directory";
    if (S_ISFIFO(mode)) return "a FIFO";
    if (S_ISCHR(mode)) return "a character device";
    if (S_ISBLK(mode)) return "a block device";
    if (S_ISSOCK(mode)) return "a socket";
    return "not a regular file";
}

// Removes `<target>.tmp-<pid>-<n>` files whose process is gone.  Best effort:
// a file we cannot remove is left alone.
void remove_stale_temporaries(const std::string& target) {
    namespace fs = std::filesystem;
    const fs::path p(target);
    const fs::path dir = p.has_parent_path() ? p.parent_path() : fs::path(".");
    const std::string prefix = p.filename().string() + ".tmp-";
    std::error_code ec;
    for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
        const std::string name = it->path().filename().string();
        if (name.compare(0, prefix.size(), prefix) != 0) continue;
        const std::string rest = name.substr(prefix.size());
        const std::size_t dash = rest.find('-');
        if (dash == 0 || dash == std::string::npos) continue;
        if (rest.find_first_not_of("0123456789-") != std::string::npos) continue;
        const long pid = std::strtol(rest.substr(0, dash).c_str(), nullptr, 10);
        if (pid <= 0 || pid == static_cast<long>(::getpid())) continue;
        if (::kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH) continue;  // still running
        std::error_code ignored;
        fs::remove(it->path(), ignored);
    }
}

}  // namespace

std::string resolve_output_path(const std::string& target) {
    if (target.empty()) throw InputError("the output path is empty");
    std::string path = target;
    // Follow links by hand (not realpath): the final file may not exist yet.
    for (int depth = 0;; ++depth) {
        struct stat st;
        if (::lstat(path.c_str(), &st) != 0) return path;  // nothing there yet
        if (S_ISREG(st.st_mode)) return path;
        if (!S_ISLNK(st.st_mode))
            throw InputError("output '" + target + "'" +
                             (path == target ? "" : " (through links, '" + path + "')") + " is " +
                             kind_of(st.st_mode) +
                             "; brdftab replaces only regular files, give a file path");
        if (depth >= 40) throw InputError("output '" + target + "': too many levels of links");
        char buf[4096];
        const ssize_t n = ::readlink(path.c_str(), buf, sizeof buf - 1);
        if (n < 0) throw InputError("output '" + target + "': cannot read link '" + path + "'");
        std::string link(buf, static_cast<std::size_t>(n));
        if (link.empty() || link[0] != '/') {
            const std::size_t slash = path.rfind('/');
            if (slash != std::string::npos) link = path.substr(0, slash + 1) + link;
        }
        path = link;
    }
}

AtomicOutput::AtomicOutput(std::string target)
    : target_(resolve_output_path(target)), temp_(temporary_name(target_)) {
    remove_stale_temporaries(target_);
}

AtomicOutput::~AtomicOutput() {
    if (!committed_) std::remove(temp_.c_str());
}

void AtomicOutput::commit() {
    sync_file(temp_);
    if (std::rename(temp_.c_str(), target_.c_str()) != 0)
        throw Error("cannot rename '" + temp_ + "' to '" + target_ + "': " + std::strerror(errno));
    committed_ = true;
}

OutputLock::OutputLock(const std::string& target) : path_(resolve_output_path(target) + ".lock") {
    // The holder removes the file before it unlocks; a process that opened
    // the file before that removal and locks it after holds a lock on a file
    // no longer at the path, so the lock counts only when the path still
    // names the locked file, and is taken again otherwise.
    for (int attempt = 0;; ++attempt) {
        const int fd = ::open(path_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
        if (fd < 0)
            throw InputError("output '" + target + "': cannot create the lock file '" + path_ +
                             "': " + std::strerror(errno));
        if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
            const int err = errno;
            char pid[32] = {0};
            const ssize_t n = ::pread(fd, pid, sizeof pid - 1, 0);
            ::close(fd);
            if (err != EWOULDBLOCK)
                throw InputError("output '" + target + "': cannot lock '" + path_ +
                                 "': " + std::strerror(err));
            std::string holder = n > 0 ? std::string(pid, std::size_t(n)) : std::string();
            holder.erase(holder.find_last_not_of(" \n") + 1);
            throw InputError("output '" + target + "' is being written by another running brdftab" +
                             (holder.empty() ? std::string() : " (process " + holder + ")") +
                             ", which holds the lock '" + path_ +
                             "'; wait for it to finish, or write elsewhere (-o)");
        }
        struct stat held {}, named {};
        if (::fstat(fd, &held) == 0 && ::stat(path_.c_str(), &named) == 0 &&
            held.st_dev == named.st_dev && held.st_ino == named.st_ino) {
            fd_ = fd;
            break;
        }
        ::close(fd);
        if (attempt == 100)
            throw Error("output '" + target + "': the lock file '" + path_ +
                        "' keeps being replaced; is another program removing it?");
    }
    // Who holds it, for the message of a refused second writer (which only
    // lacks the process id if this fails).
    const std::string pid = std::to_string(static_cast<long>(::getpid())) + "\n";
    const bool recorded =
        ::ftruncate(fd_, 0) == 0 && ::pwrite(fd_, pid.data(), pid.size(), 0) > 0;
    (void)recorded;
}

OutputLock::~OutputLock() {
    if (fd_ < 0) return;
    ::unlink(path_.c_str());  // while still locked: see the constructor
    ::close(fd_);
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
    const std::string resolved = resolve_output_path(target);  // refuses non-regular files
    const fs::path p(resolved);
    const fs::path dir = p.has_parent_path() ? p.parent_path() : fs::path(".");
    std::error_code ec;
    if (!fs::is_directory(dir, ec))
        throw InputError("output '" + target + "': directory '" + dir.string() + "' does not exist");
    if (::access(dir.c_str(), W_OK) != 0)
        throw InputError("output '" + target + "': directory '" + dir.string() + "' is not writable");
    // The probe finds what access() cannot: a name too long for the file
    // system (with the temporary suffix), a read-only mount, a full inode table.
    const std::string probe = temporary_name(resolved);
    const int fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_EXCL, 0644);
    if (fd < 0)
        throw InputError("output '" + target + "' cannot be created: " + std::strerror(errno));
    ::close(fd);
    ::unlink(probe.c_str());
}

}  // namespace brdftab
