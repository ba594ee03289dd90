// read_guard.cpp — the forked, time-limited trial read of read_guard.h.
#include "host/cli/read_guard.h"

#include "host/adaptive/adaptive_io.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <memory>
#include <string>
#include <vector>
#include <thread>

#include "host/core/error.h"
#include "host/engine/engine_tuning.h"
#include "host/io/table_io.h"
#include "host/plan/certify.h"

namespace brdftab::cli {

double read_timeout_seconds() {
    const char* env = environment_setting("BRDFTAB_READ_TIMEOUT");
    if (!env || !*env) return kDefaultReadTimeout;
    char* end = nullptr;
    const double s = std::strtod(env, &end);
    if (end == env || *end != '\0' || !std::isfinite(s) || s < 0)
        throw InputError(std::string("BRDFTAB_READ_TIMEOUT='") + env +
                         "' is not a number of seconds >= 0 (0 switches the guard off)");
    return s;
}

namespace {

// Exit statuses of the trial read's child besides 0 (every object read).
constexpr int kCleanInputError = 3;  // the first failure was an InputError
constexpr int kCleanOtherError = 4;  // ... another brdftab::Error or std::exception

// The child's work: read every object any command may read (the file's
// attributes, and each table and its certificate, in turn), going on past a
// clean failure so that a crash on a later object is still caught here.  The
// first failure's message goes to `report_fd`; returns the exit status.
int trial_read(const std::string& path, int report_fd) {
    std::string first_error;
    bool first_is_input_error = false;
    auto attempt = [&](const std::function<void()>& read_object) {
        try {
            read_object();
        } catch (const InputError& e) {
            if (first_error.empty()) first_error = e.what(), first_is_input_error = true;
        } catch (const std::exception& e) {
            if (first_error.empty()) first_error = e.what();
        } catch (...) {
            if (first_error.empty()) first_error = "reading '" + path + "' failed";
        }
    };
    std::unique_ptr<TableReader> reader;
    std::vector<std::string> names;
    // Opening and listing fail for the whole file: the message stands as it is.
    attempt([&] {
        reader = std::make_unique<TableReader>(path);
        names = reader->table_names();
    });
    if (first_error.empty()) {
        const std::string note =
            " (the file is refused whole: damage that one of its objects shows may crash the "
            "HDF5 library on another; docs/format.md, \"Reading untrusted files\")";
        attempt([&] { (void)reader->file_attributes(); });
        for (const std::string& name : names) {
            attempt([&] {
                if (is_adaptive_table(*reader, name))
                    (void)read_adaptive_table(*reader, name);
                else
                    (void)reader->read(name);
            });
            attempt([&] { (void)read_certificate(*reader, name); });
        }
        if (!first_error.empty()) first_error += note;
    }
    if (first_error.empty()) return 0;
    // A pipe holds at least 4096 bytes: a shorter message never blocks the
    // child, whose parent reads it only after the child has ended.
    const std::string report = first_error.substr(0, 4000);
    for (std::size_t done = 0; done < report.size();) {
        const ssize_t n = write(report_fd, report.data() + done, report.size() - done);
        if (n <= 0) break;
        done += std::size_t(n);
    }
    return first_is_input_error ? kCleanInputError : kCleanOtherError;
}

}  // namespace

void guard_table_file(const std::string& path) {
    const double limit = read_timeout_seconds();
    if (limit == 0) return;
    std::fflush(stdout);
    std::fflush(stderr);
    // The child reports its first clean error through a pipe: the parent
    // refuses the file with that message.
    int report[2];
    if (pipe2(report, O_CLOEXEC) != 0) return;  // no pipe to spare: read unguarded, as before
    const pid_t child = fork();
    if (child < 0) {  // no process to spare: read unguarded, as before
        close(report[0]);
        close(report[1]);
        return;
    }
    if (child == 0) {
        // The child only reads; _exit skips every destructor and atexit
        // handler of the parent's state it shares.
        close(report[0]);
        _exit(trial_read(path, report[1]));
    }
    close(report[1]);
    struct ReportEnd {  // closes the parent's end on every way out
        int fd;
        ~ReportEnd() { close(fd); }
    } report_end{report[0]};
    // Poll with a growing interval: a small file is read in about a
    // millisecond, and a slow one costs at most 20 ms of extra latency.
    using clock = std::chrono::steady_clock;
    const auto deadline = clock::now() + std::chrono::duration<double>(limit);
    auto pause = std::chrono::microseconds(100);
    int status = 0;
    for (;;) {
        const pid_t r = waitpid(child, &status, WNOHANG);
        if (r == child) break;
        if (r < 0) return;  // lost the child (should not happen): go on unguarded
        if (clock::now() >= deadline) {
            kill(child, SIGKILL);
            waitpid(child, &status, 0);
            char secs[32];
            std::snprintf(secs, sizeof secs, "%g", limit);
            throw InputError("reading '" + path + "' did not finish within " + secs +
                             " s; the file is probably damaged (the HDF5 library can loop on "
                             "corrupted metadata). Set BRDFTAB_READ_TIMEOUT to allow more time "
                             "for a very large file (docs/format.md, \"Reading untrusted "
                             "files\")");
        }
        std::this_thread::sleep_for(pause);
        pause = std::min(pause * 2, decltype(pause)(20000));
    }
    // The child ends by one of its own three exits only; any other exit
    // status means something ended it abnormally inside the library (a
    // sanitizer's report, a library's own abort path).
    if (WIFEXITED(status) && (WEXITSTATUS(status) == kCleanInputError ||
                              WEXITSTATUS(status) == kCleanOtherError)) {
        // A file with one unreadable object is refused whole: the damage
        // that made that object fail cleanly in the child may crash the
        // library on another object of the same file (the parent's read,
        // in another order, would not be guarded).
        std::string message;
        char buf[1024];
        for (ssize_t n; (n = read(report_end.fd, buf, sizeof buf)) > 0;) message.append(buf, n);
        if (message.empty()) message = "reading '" + path + "' failed";
        if (WEXITSTATUS(status) == kCleanInputError) throw InputError(message);
        throw Error(message);
    }
    if (WIFEXITED(status) && WEXITSTATUS(status) != 0)
        throw InputError("reading '" + path + "' failed inside the HDF5 library (exit status " +
                         std::to_string(WEXITSTATUS(status)) +
                         "); the file is damaged (docs/format.md, \"Reading untrusted files\")");
    if (WIFSIGNALED(status))
        throw InputError("reading '" + path + "' crashed the HDF5 library (signal " +
                         std::to_string(WTERMSIG(status)) + ", " + strsignal(WTERMSIG(status)) +
                         "); the file is damaged (docs/format.md, \"Reading untrusted files\")");
}

}  // namespace brdftab::cli
