// read_guard.h — bound the damage of reading an untrusted table file.
//
// libhdf5 (1.10) can loop forever or crash on damaged metadata, inside calls
// our own checks (host/io/table_io.h) cannot protect.  Before a command reads
// a table file in-process, guard_table_file() reads the whole file once in a
// forked child under a time limit: a child that hangs is killed and a child
// that crashes is reported, each as an InputError (exit code 2) naming the
// file, instead of a hung or crashed brdftab.  docs/format.md, "Reading
// untrusted files", documents the limit and its cost.
#pragma once

#include <string>

namespace brdftab::cli {

// Seconds a guarded read may take: $BRDFTAB_READ_TIMEOUT when set (0
// switches the guard off), otherwise kDefaultReadTimeout.  Throws InputError
// for a malformed value.
constexpr double kDefaultReadTimeout = 60;
double read_timeout_seconds();

// Read every table, certificate and attribute of `path` in a child process;
// throws InputError when the child does not finish within
// read_timeout_seconds(), dies from a signal or exits other than through its
// own exits.  A clean error on any object (the child reads on past it, so
// that a crash on a later object is caught too) refuses the whole file: it is
// thrown here with the reader's message, as InputError when the reader threw
// one, Error otherwise, so the caller never reads a file the child could not
// read whole.  Call before the process starts threads (OpenCL): fork copies
// only the calling thread.
void guard_table_file(const std::string& path);

}  // namespace brdftab::cli
