// chunked.cpp — computing tables in chunks of cells and streaming them to the
// output file (chunked.h).
#include "host/generate/chunked.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <mutex>
#include <optional>
#include <set>

#include "host/core/error.h"
#include "host/generate/checkpoint.h"
#include "host/generate/derived.h"
#include "host/io/table_io.h"

namespace brdftab {

std::size_t chunk_cells_for(std::size_t table_cells, std::size_t chunk_cells, int ranks) {
    if (chunk_cells) return chunk_cells;
    if (ranks <= 1) return kDefaultChunkCells;
    const std::size_t per = (table_cells + 8 * static_cast<std::size_t>(ranks) - 1) /
                            (8 * static_cast<std::size_t>(ranks));
    return std::clamp(per, kMinChunkCells, kDefaultChunkCells);
}

std::vector<CellChunk> plan_chunks(const Spec& spec, std::size_t chunk_cells, int ranks) {
    std::vector<CellChunk> plan;
    for (std::size_t t = 0; t < spec.tables.size(); ++t) {
        const std::size_t n = checked_cell_count(spec.tables[t].axes,
                                                 spec.file + ": table '" + spec.tables[t].name + "': ");
        const std::size_t per = chunk_cells_for(n, chunk_cells, ranks);
        for (std::size_t first = 0; first < n; first += per)
            plan.push_back({t, first, std::min(per, n - first)});
    }
    return plan;
}

std::vector<std::string> tables_read_by_derived(const Spec& spec) {
    std::set<std::string> names;
    for (const RecombinedSpec& rs : spec.recombined)
        for (const auto& term : rs.terms) names.insert(term.first);
    for (const ErrorTableSpec& es : spec.errors) {
        names.insert(es.table);
        names.insert(es.reference);
    }
    for (const InvertedSpec& is : spec.inverted) names.insert(is.table);
    std::vector<std::string> computed;
    for (const TableSpec& ts : spec.tables)
        if (names.count(ts.name)) computed.push_back(ts.name);
    return computed;
}

// ---------------------------------------------------------- ChunkComputer --

struct ChunkComputer::Impl {
    const Spec& spec;
    Backend& backend;
    IntegrationSettings settings;
    const ModelInfo& model;
    struct Table {
        const QuantityInfo* quantity = nullptr;
        std::vector<int> options;
        std::optional<CellPoints> points;
        IntegrationSettings settings;
        Method method = Method::ClosedForm;
    };
    std::vector<Table> tables;
    Impl(const Spec& s, Backend& b, const IntegrationSettings& is)
        : spec(s), backend(b), settings(is), model(find_model(s.model)) {}
};

ChunkComputer::ChunkComputer(const Spec& spec, Backend& backend,
                             const IntegrationSettings& settings)
    : impl_(std::make_unique<Impl>(spec, backend, settings)) {
    // The same preparation, and the same messages, as generate_tables().
    for (const TableSpec& ts : spec.tables) {
        Impl::Table t;
        t.quantity = &impl_->model.quantity(ts.quantity);
        t.options = resolve_options(impl_->model, ts.options,
                                    spec.file + ": table '" + ts.name + "'");
        try {
            t.points.emplace(impl_->model, *t.quantity, ts);
        } catch (const InputError& e) {
            throw InputError(spec.file + ": table '" + ts.name + "': " + e.what());
        }
        t.settings = settings;
        t.settings.method = resolve_table_method(*t.quantity, settings.method);
        t.method = resolve_method(*t.quantity, t.settings.method);
        impl_->tables.push_back(std::move(t));
    }
}

ChunkComputer::~ChunkComputer() = default;

std::size_t ChunkComputer::table_count() const { return impl_->tables.size(); }

std::size_t ChunkComputer::cell_count(std::size_t table) const {
    return impl_->tables.at(table).points->cell_count();
}

TableData ChunkComputer::describe(std::size_t table) const {
    const Impl::Table& t = impl_->tables.at(table);
    return generate_detail::describe_table(impl_->spec, impl_->backend, impl_->settings, table,
                                           t.options, t.method);
}

ChunkResult ChunkComputer::compute(const CellChunk& chunk, Checkpoint* checkpoint,
                                   const ProgressFn& after_launch) {
    const Impl::Table& t = impl_->tables.at(chunk.table);
    const CellPoints& points = *t.points;
    const std::size_t n = points.cell_count();
    if (chunk.first > n || chunk.count > n - chunk.first || chunk.count == 0)
        throw Error("chunk of cells " + std::to_string(chunk.first) + " + " +
                    std::to_string(chunk.count) + " outside a table of " + std::to_string(n));
    if (n > 0xFFFFFFFFull)
        throw InputError("table has " + std::to_string(n) +
                         " cells; at most 2^32 - 1 are supported");
    // The chunk's cells draw the random numbers of their places in the
    // whole table.
    IntegrationSettings settings = t.settings;
    settings.cell_base = chunk.first;
    const std::string& name = impl_->spec.tables[chunk.table].name;
    EstimateCheckpoint stored;
    if (checkpoint) stored = checkpoint->chunk(chunk.table, name, chunk.first, chunk.count, n);
    // A cell the model refuses (check_cell) is found only here: the message
    // names the spec file and the table, as the set-up's messages do.
    EstimateResult r;
    try {
        r = estimate(
            impl_->backend, impl_->model, *t.quantity, t.options, chunk.count,
            [&](std::size_t first, std::size_t count, double* p) {
                points.points(chunk.first + first, count, p);
            },
            settings,
            after_launch, checkpoint ? &stored : nullptr);
    } catch (const InputError& e) {
        throw InputError(impl_->spec.file + ": table '" + name + "': " + e.what());
    }
    ChunkResult out;
    out.chunk = chunk;
    out.value = std::move(r.value);
    out.stderr_ = std::move(r.stderr_);
    if (r.method != Method::ClosedForm) out.samples = std::move(r.samples);
    out.total_samples = r.total_samples;
    out.tolerance_achieved = r.tolerance_achieved;
    out.cells_unconverged = r.cells_unconverged;
    out.elapsed_seconds = r.elapsed_seconds;
    return out;
}

// ------------------------------------------------------- generate_to_file --

std::vector<GeneratedTable> generate_to_file(const Spec& spec, Backend& backend,
                                             const IntegrationSettings& settings,
                                             const std::string& output_path,
                                             const GenerateProgressFn& progress,
                                             const StreamOptions& options) {
    TableFileWriter writer(output_path);
    if (options.temporary_created) options.temporary_created(writer.temporary_path());
    std::vector<GeneratedTable> out = generate_into(spec, backend, settings, writer, progress, options);
    writer.commit();
    return out;
}

std::vector<GeneratedTable> generate_into(const Spec& spec, Backend& backend,
                                          const IntegrationSettings& settings,
                                          TableFileWriter& writer,
                                          const GenerateProgressFn& progress,
                                          const StreamOptions& options) {
    ChunkComputer computer(spec, backend, settings);
    const std::vector<CellChunk> plan = plan_chunks(spec, options.chunk_cells, options.ranks);
    const std::vector<std::string> keep = tables_read_by_derived(spec);
    // Every computed table, its file objects and what its chunks add up to.
    struct Table {
        GeneratedTable g;  // data.value etc. filled only when kept
        std::size_t handle = 0, cells = 0, cells_done = 0;
        bool kept = false, finished = false, first_nan = false;
        double lo = INFINITY, hi = -INFINITY;
        // The chunk in progress here: its fraction done (in cells), cells
        // done and samples drawn so far.
        double partial_fraction = 0;
        std::size_t partial_cells = 0;
        std::uint64_t partial_samples = 0;
        bool reported = false;  // progress shown yet; since `started`
        std::chrono::steady_clock::time_point started;
    };
    std::vector<Table> tables(computer.table_count());
    for (std::size_t t = 0; t < tables.size(); ++t) {
        Table& tb = tables[t];
        tb.g.data = computer.describe(t);
        tb.cells = computer.cell_count(t);
        tb.kept = std::find(keep.begin(), keep.end(), tb.g.data.name) != keep.end();
        const bool closed = tb.g.data.method == Method::ClosedForm;
        // As write_tables: stderr when kept (never for closed forms),
        // samples for estimated tables.
        tb.handle = writer.begin_table(tb.g.data, tb.g.data.keep_stderr, !closed);
        if (tb.kept) {
            tb.g.data.value.resize(tb.cells);
            tb.g.data.stderr_.resize(tb.cells);
            if (!closed) tb.g.data.samples.resize(tb.cells);
        }
    }

    // Progress of the first table not finished (chunks finish out of order
    // when shared).
    auto report = [&] {
        if (!progress) return;
        for (std::size_t t = 0; t < tables.size(); ++t) {
            if (tables[t].finished) continue;
            GenerateEvent e;
            e.table_index = t;
            e.table_count = spec.tables.size();
            e.table = &spec.tables[t];
            Table& tb = tables[t];
            const auto now = std::chrono::steady_clock::now();
            if (!tb.reported) {
                tb.reported = true;
                tb.started = now;
            }
            e.progress.cells_total = tb.cells;
            e.progress.cells_done = tb.cells_done + tb.partial_cells;
            e.progress.samples_done = tb.g.data.total_samples + tb.partial_samples;
            e.progress.elapsed_seconds = std::chrono::duration<double>(now - tb.started).count();
            e.progress.fraction = std::min(
                1.0, (static_cast<double>(tables[t].cells_done) + tables[t].partial_fraction) /
                         static_cast<double>(std::max<std::size_t>(tables[t].cells, 1)));
            progress(e);
            return;
        }
    };

    // A chunk's results: into the file, the totals and (when kept) memory.
    // Chunks arrive in any order; the totals do not depend on it: sums of
    // integers, and the largest achieved tolerance (std::max drops NaNs
    // whatever the order, as the engine's own maximum does).  The elapsed
    // time is a sum of seconds (an attribute that differs between runs
    // anyway).
    std::vector<bool> received(plan.size(), false);
    std::size_t received_count = 0;
    // Chunks of a table are consecutive in the plan and of equal size but
    // the last: a chunk's place is its table's first plus first / size.
    std::vector<std::size_t> table_start(tables.size(), plan.size());
    for (std::size_t k = plan.size(); k-- > 0;) table_start[plan[k].table] = k;
    auto place_of = [&](const CellChunk& c) -> std::size_t {
        if (c.table >= tables.size() || table_start[c.table] >= plan.size()) return plan.size();
        const std::size_t size = plan[table_start[c.table]].count;
        const std::size_t k = table_start[c.table] + c.first / size;
        if (k >= plan.size() || plan[k].table != c.table || plan[k].first != c.first ||
            plan[k].count != c.count)
            return plan.size();
        return k;
    };
    auto accept = [&](ChunkResult&& r, bool own) {
        const CellChunk& c = r.chunk;
        const std::size_t place = place_of(c);
        if (place >= plan.size() || received[place])
            throw Error("a process returned a chunk that was not handed out (table " +
                        std::to_string(c.table) + ", cells " + std::to_string(c.first) + " + " +
                        std::to_string(c.count) + ")");
        if (r.value.size() != c.count || r.stderr_.size() != c.count ||
            (!r.samples.empty() && r.samples.size() != c.count))
            throw Error("a chunk's results have the wrong size");
        received[place] = true;
        ++received_count;
        Table& tb = tables[c.table];
        TableData& d = tb.g.data;
        writer.write_cells(tb.handle, c.first, c.count, r.value.data(), r.stderr_.data(),
                           r.samples.empty() ? nullptr : r.samples.data());
        if (tb.kept) {
            std::copy(r.value.begin(), r.value.end(), d.value.begin() + c.first);
            std::copy(r.stderr_.begin(), r.stderr_.end(), d.stderr_.begin() + c.first);
            if (!r.samples.empty())
                std::copy(r.samples.begin(), r.samples.end(), d.samples.begin() + c.first);
        }
        d.total_samples += r.total_samples;
        d.tolerance_achieved = std::max(d.tolerance_achieved, r.tolerance_achieved);
        d.elapsed_seconds += r.elapsed_seconds;
        tb.g.cells_unconverged += r.cells_unconverged;
        tb.cells_done += c.count;
        // The value range (summary only) as set_value_range's fold gives it
        // in cell order, from pieces in any order: the smallest and largest
        // number, or NaN when the first cell is NaN (std::min and std::max
        // keep their first argument when a comparison with NaN fails).
        for (double v : r.value) {
            if (v != v) continue;
            tb.lo = std::min(tb.lo, v);
            tb.hi = std::max(tb.hi, v);
        }
        if (c.first == 0 && !r.value.empty() && r.value[0] != r.value[0]) tb.first_nan = true;
        if (r.stderr_.size() == r.value.size())
            fold_stderr_max(r.value.data(), r.stderr_.data(), r.value.size(), tb.g.stderr_max_abs,
                            tb.g.stderr_max_rel);
        if (tb.cells_done == tb.cells) {
            writer.finish_table(tb.handle, d);
            tb.finished = true;
        }
        if (own) {
            tb.partial_fraction = 0;
            tb.partial_cells = 0;
            tb.partial_samples = 0;
        }
        report();
    };

    // With sharing, `take` and `accept` also run on the thread that answers
    // the other processes: one lock serialises them (and the file, as
    // libhdf5 is not built thread-safe) with this thread's use.
    std::mutex lock;
    std::size_t next = 0;
    auto take = [&](std::size_t& index) {
        if (next >= plan.size()) return false;
        index = next++;
        return true;
    };
    auto take_locked = [&](std::size_t& index) {
        std::lock_guard<std::mutex> hold(lock);
        return take(index);
    };
    auto accept_locked = [&](ChunkResult&& r) {
        std::lock_guard<std::mutex> hold(lock);
        accept(std::move(r), false);
    };
    report();
    if (options.sharing) options.sharing->start(take_locked, accept_locked);
    // On a failure here, the thread must stop before the objects its
    // functions use are gone.
    struct StopSharing {
        ChunkSharing* sharing;
        ~StopSharing() {
            if (sharing) sharing->abandon();
        }
    } stop_sharing{options.sharing};
    std::size_t mine = 0;
    while (take_locked(mine)) {
        const CellChunk& c = plan[mine];
        ProgressFn after_launch = [&](const Progress& p) {
            if (options.sharing) options.sharing->check();
            std::lock_guard<std::mutex> hold(lock);
            Table& tb = tables[c.table];
            tb.partial_fraction = p.fraction * static_cast<double>(c.count);
            tb.partial_cells = p.cells_done;
            tb.partial_samples = p.samples_done;
            report();
        };
        ChunkResult r = computer.compute(c, options.checkpoint, after_launch);
        {
            std::lock_guard<std::mutex> hold(lock);
            accept(std::move(r), true);
        }
        if (options.sharing) options.sharing->computed_here(c.count);
    }
    if (options.sharing) options.sharing->finish();
    stop_sharing.sharing = nullptr;
    if (received_count != plan.size())
        throw Error("only " + std::to_string(received_count) + " of " +
                    std::to_string(plan.size()) + " chunks came back");

    // Derived tables from the kept ones, in memory, written whole.
    std::vector<GeneratedTable> out;
    for (Table& tb : tables) {
        // (lo > hi only when every value is NaN, the first one included.)
        if (tb.first_nan || tb.lo > tb.hi)
            tb.g.value_min = tb.g.value_max = NAN;
        else
            tb.g.value_min = tb.lo, tb.g.value_max = tb.hi;
        out.push_back(std::move(tb.g));
    }
    for (const RecombinedSpec& rs : spec.recombined)
        out.push_back(generate_detail::recombine(rs, out, spec));
    for (const ErrorTableSpec& es : spec.errors)
        out.push_back(generate_detail::compare(es, out, spec));
    for (const InvertedSpec& is : spec.inverted)
        out.push_back(generate_detail::invert(is, out, spec));
    for (std::size_t k = tables.size(); k < out.size(); ++k) {
        set_value_range(out[k]);
        writer.add_table(out[k].data);
    }
    // The summary needs no data: release what was kept.
    for (GeneratedTable& g : out) {
        std::vector<double>().swap(g.data.value);
        std::vector<double>().swap(g.data.stderr_);
        std::vector<std::uint32_t>().swap(g.data.samples);
    }
    return out;
}

}  // namespace brdftab
