// cmd_certify.cpp — `brdftab certify FILE --table T --accuracy E`: the
// certificate of `generate --accuracy` (host/plan/certify.h) for a table that
// already exists, e.g. one generated from a hand-written spec.  Read-only
// unless --store, which writes the certificate attributes into a copy of the
// file and renames it over the original only when that succeeded.
#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <string>

#include "host/cli/cli_common.h"
#include "host/cli/commands.h"
#include "host/core/atomic_file.h"
#include "host/core/error.h"
#include "host/plan/certify.h"

namespace brdftab::cli {

namespace {

struct CertifyArgs {
    std::string file, table, interpolation = "linear";
    double accuracy = 0, abs_floor = 0;
    bool absolute = false, store = false, quiet = false;
    ComputeOptions compute;
};

void run_certify(const CertifyArgs& st) {
    if (!(st.accuracy > 0) || !std::isfinite(st.accuracy))
        throw InputError("--accuracy must be a finite number > 0 (got " + sci_text(st.accuracy) + ")");
    if (st.abs_floor < 0 || !std::isfinite(st.abs_floor))
        throw InputError("--abs-floor must be a finite number >= 0");
    if (!std::filesystem::is_regular_file(st.file)) throw InputError(st.file + ": no such file");
    CertifyOptions o;
    o.target = st.accuracy;
    o.absolute = st.absolute;
    o.abs_floor = st.abs_floor;
    o.interpolation = st.interpolation == "cubic" ? Interpolation::Cubic : Interpolation::Linear;
    auto backend = st.compute.make_backend();
    std::unique_ptr<ProgressPrinter> printer;
    if (!st.quiet) printer = std::make_unique<ProgressPrinter>("certify " + st.table);
    const ProgressFn progress = [&](const Progress& p) {
        if (printer) (*printer)(p);
    };
    const Certificate c = certify_file_table(st.file, st.table, *backend, o, progress);
    if (printer) printer->finish();
    std::cout << st.file << " table " << c.table << ": certificate " << (c.passed ? "passed" : "FAILED")
              << ": " << certificate_error_text(c) << "; " << c.probes << " probes, " << st.interpolation << " interpolation";
    if (!c.absolute) std::cout << ", floor " << sci_text(c.abs_floor);
    std::cout << ", reference " << c.reference_method;
    if (c.reference_noise > 0) std::cout << " (noise " << sci_text(c.reference_noise) << ")";
    std::cout << ", " << sci_text(c.seconds) << " s\n";
    if (st.store) {
        AtomicOutput out(st.file);
        std::filesystem::copy_file(st.file, out.path(), std::filesystem::copy_options::overwrite_existing);
        write_certificate(out.path(), c);
        out.commit();
        std::cout << "stored the certificate in " << st.file << "\n";
    }
    if (!c.passed)
        throw Error("the certificate missed --accuracy " + sci_text(st.accuracy) + ": max total error " +
                    sci_text(c.max_error));
}

}  // namespace

void register_certify(CLI::App& app) {
    auto* cmd = app.add_subcommand(
        "certify",
        "measure a written table's total error between nodes (what a renderer sees: interpolation "
        "+ integration + storage) with off-grid probes against direct evaluation, and compare it "
        "with a target; exit code 1 when it misses (docs/planning.md, \"Certified generation\")");
    auto st = std::make_shared<CertifyArgs>();
    cmd->add_option("FILE", st->file, "table file (HDF5)")->required();
    cmd->add_option("--table", st->table, "table (group) name in FILE")->required();
    cmd->add_option("--accuracy", st->accuracy,
                    "the target E: max total error, relative to max(|value|, floor) by default, "
                    "absolute with --abs")
        ->required();
    cmd->add_flag("--abs", st->absolute, "absolute errors (default: relative)");
    cmd->add_option("--abs-floor", st->abs_floor,
                    "relative errors divide by max(|value|, floor); default 1e-3 x the table's "
                    "largest |value|");
    cmd->add_option("--interpolation", st->interpolation,
                    "the interpolation a renderer reads the table with: linear (default) or cubic")
        ->check(CLI::IsMember({"linear", "cubic"}));
    cmd->add_flag("--store", st->store,
                  "write the certificate into FILE's table attributes (certificate_*, "
                  "docs/format.md); the file is replaced only when that succeeded");
    cmd->add_flag("-q,--quiet", st->quiet, "no progress display");
    st->compute.add_to(*cmd, false);
    cmd->callback([st] { run_certify(*st); });
}

}  // namespace brdftab::cli
