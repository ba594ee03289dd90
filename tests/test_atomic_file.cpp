// host/core/atomic_file.h: what an output path may name, early failure before
// a long compute, and the clean-up of temporary files left by killed runs.
#include <doctest/doctest.h>

#include <sys/stat.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "host/core/atomic_file.h"
#include "host/core/error.h"
#include "test_support.h"

using namespace brdftab;
namespace fs = std::filesystem;

namespace {

std::string read_text(const fs::path& p) {
    std::ifstream in(p);
    return std::string(std::istreambuf_iterator<char>(in), {});
}

// A pid that certainly ran no brdftab and is no longer running: a child that
// has exited and been reaped.
pid_t dead_pid() {
    const pid_t pid = ::fork();
    if (pid == 0) ::_exit(0);
    int status = 0;
    ::waitpid(pid, &status, 0);
    return pid;
}

}  // namespace

TEST_CASE("a regular file is replaced whole, a missing one created") {
    const fs::path dir = test::scratch_dir(BT_BINARY_DIR, "atomic_file", "regular");
    write_text_atomically((dir / "a.txt").string(), "first");
    CHECK(read_text(dir / "a.txt") == "first");
    write_text_atomically((dir / "a.txt").string(), "second");
    CHECK(read_text(dir / "a.txt") == "second");
    CHECK(std::distance(fs::directory_iterator(dir), fs::directory_iterator()) == 1);
}

TEST_CASE("non-regular targets are refused, links are followed") {
    const fs::path dir = test::scratch_dir(BT_BINARY_DIR, "atomic_file", "kinds");
    SUBCASE("FIFO") {
        const fs::path fifo = dir / "fifo";
        REQUIRE(::mkfifo(fifo.c_str(), 0644) == 0);
        CHECK_THROWS_AS(check_output_writable(fifo.string()), InputError);
        CHECK_THROWS_AS(AtomicOutput(fifo.string()), InputError);
        CHECK(fs::is_fifo(fs::symlink_status(fifo)));
    }
    SUBCASE("device node, also through a link") {
        CHECK_THROWS_AS(check_output_writable("/dev/null"), InputError);
        const fs::path link = dir / "null-link";
        fs::create_symlink("/dev/null", link);
        CHECK_THROWS_AS(check_output_writable(link.string()), InputError);
        CHECK(fs::is_symlink(fs::symlink_status(link)));
    }
    SUBCASE("directory") {
        CHECK_THROWS_AS(check_output_writable(dir.string()), InputError);
    }
    SUBCASE("empty path") {
        CHECK_THROWS_AS(check_output_writable(""), InputError);
        CHECK_THROWS_AS(AtomicOutput(""), InputError);
    }
    SUBCASE("a link to a regular file: the file is replaced, the link kept") {
        write_text_atomically((dir / "real.txt").string(), "old");
        fs::create_symlink("real.txt", dir / "link.txt");
        check_output_writable((dir / "link.txt").string());
        write_text_atomically((dir / "link.txt").string(), "new");
        CHECK(fs::is_symlink(fs::symlink_status(dir / "link.txt")));
        CHECK(read_text(dir / "real.txt") == "new");
    }
    SUBCASE("a dangling link: the file it names is created") {
        fs::create_symlink("target.txt", dir / "dangling.txt");
        write_text_atomically((dir / "dangling.txt").string(), "made");
        CHECK(read_text(dir / "target.txt") == "made");
    }
}

TEST_CASE("names the file system refuses fail before any work") {
    const fs::path dir = test::scratch_dir(BT_BINARY_DIR, "atomic_file", "names");
    // 255 bytes is the longest name on Linux file systems; with the temporary
    // suffix it no longer fits.
    const std::string long_name(250, 'x');
    CHECK_THROWS_AS(check_output_writable((dir / long_name).string()), InputError);
    CHECK_THROWS_AS(check_output_writable((dir / "missing" / "a.h5").string()), InputError);
    CHECK(std::distance(fs::directory_iterator(dir), fs::directory_iterator()) == 0);
}

TEST_CASE("temporary files of dead processes are removed, live ones kept") {
    const fs::path dir = test::scratch_dir(BT_BINARY_DIR, "atomic_file", "stale");
    const fs::path target = dir / "out.h5";
    const fs::path stale = dir / ("out.h5.tmp-" + std::to_string(dead_pid()) + "-0");
    const fs::path live = dir / ("out.h5.tmp-" + std::to_string(::getppid()) + "-3");
    const fs::path other = dir / "other.h5.tmp-1-0";
    for (const auto& p : {stale, live, other}) std::ofstream(p) << "partial";
    write_text_atomically(target.string(), "done");
    CHECK(!fs::exists(stale));
    CHECK(fs::exists(live));
    CHECK(fs::exists(other));
    CHECK(read_text(target) == "done");
}

TEST_CASE("one writer per output: a second lock is refused, a dead holder's is taken over") {
    const fs::path dir = test::scratch_dir(BT_BINARY_DIR, "atomic_file", "lock");
    const fs::path target = dir / "out.h5";
    const std::string lock_file = target.string() + ".lock";
    {
        const OutputLock first(target.string());
        CHECK(first.path() == lock_file);
        CHECK(fs::exists(lock_file));
        CHECK(read_text(lock_file) == std::to_string(::getpid()) + "\n");
        // A second writer, in this process (flock locks belong to the open
        // file, not the process) and in another one.
        std::string message;
        try {
            const OutputLock second(target.string());
        } catch (const InputError& e) {
            message = e.what();
        }
        CHECK(message.find("is being written by another running brdftab (process " +
                           std::to_string(::getpid()) + ")") != std::string::npos);
        CHECK(message.find(lock_file) != std::string::npos);
        const pid_t child = ::fork();
        if (child == 0) {
            try {
                const OutputLock other(target.string());
            } catch (const InputError&) {
                ::_exit(7);
            }
            ::_exit(0);
        }
        int status = 0;
        ::waitpid(child, &status, 0);
        CHECK((WIFEXITED(status) && WEXITSTATUS(status) == 7));
        CHECK(fs::exists(lock_file));  // the refused writers left it alone
    }
    CHECK(!fs::exists(lock_file));  // removed by its holder
    // A lock file left by a killed holder (no process holds the lock): taken.
    std::ofstream(lock_file) << dead_pid() << "\n";
    {
        const OutputLock again(target.string());
        CHECK(read_text(lock_file) == std::to_string(::getpid()) + "\n");
    }
    CHECK(!fs::exists(lock_file));
    // A lock through a link sits beside the file the link leads to.
    const fs::path real = dir / "real.h5";
    std::ofstream(real) << "x";
    fs::create_symlink(real, dir / "link.h5");
    {
        const OutputLock via_link((dir / "link.h5").string());
        CHECK(via_link.path() == real.string() + ".lock");
        CHECK_THROWS_AS(OutputLock(real.string()), InputError);
    }
}
