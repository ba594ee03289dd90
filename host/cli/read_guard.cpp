// read_guard.cpp — the forked, time-limited trial read of read_guard.h.
#include "host/cli/read_guard.h"

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <thread>

#include "host/core/error.h"
#include "host/io/table_io.h"

namespace brdftab::cli {

double read_timeout_seconds() {
    const char* env = std::getenv("BRDFTAB_READ_TIMEOUT");
    if (!env || !*env) return kDefaultReadTimeout;
    char* end = nullptr;
    const double s = std::strtod(env, &end);
    if (end == env || *end != '\0' || !std::isfinite(s) || s < 0)
        throw InputError(std::string("BRDFTAB_READ_TIMEOUT='") + env +
                         "' is not a number of seconds >= 0 (0 switches the guard off)");
    return s;
}

void guard_table_file(const std::string& path) {
    const double limit = read_timeout_seconds();
    if (limit == 0) return;
    std::fflush(stdout);
    std::fflush(stderr);
    const pid_t child = fork();
    if (child < 0) return;  // no process to spare: read unguarded, as before
    if (child == 0) {
        // The child only reads; _exit skips every destructor and atexit
        // handler of the parent's state it shares.
        int status = 0;
        try {
            const TableReader reader(path);
            (void)reader.file_attributes();
            for (const std::string& name : reader.table_names()) (void)reader.read(name);
        } catch (...) {
            status = 3;  // a clean error: the parent's own read reports it
        }
        _exit(status);
    }
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
    // The child ends by _exit(0) or _exit(3) only; any other exit status
    // means something ended it abnormally inside the library (a sanitizer's
    // report, a library's own abort path).
    if (WIFEXITED(status) && WEXITSTATUS(status) != 0 && WEXITSTATUS(status) != 3)
        throw InputError("reading '" + path + "' failed inside the HDF5 library (exit status " +
                         std::to_string(WEXITSTATUS(status)) +
                         "); the file is damaged (docs/format.md, \"Reading untrusted files\")");
    if (WIFSIGNALED(status))
        throw InputError("reading '" + path + "' crashed the HDF5 library (signal " +
                         std::to_string(WTERMSIG(status)) + ", " + strsignal(WTERMSIG(status)) +
                         "); the file is damaged (docs/format.md, \"Reading untrusted files\")");
}

}  // namespace brdftab::cli
