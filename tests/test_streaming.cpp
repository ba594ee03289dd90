// Streaming generate (issue #15): tables computed in chunks of cells and
// written piece by piece (host/generate/chunked.h, TableFileWriter) give the
// same file as the whole-table path, generate_tables() + write_tables().
#include <doctest/doctest.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <random>

#include "host/core/error.h"
#include "host/core/grid.h"
#include "host/generate/chunked.h"
#include "host/generate/generate.h"
#include "host/io/table_io.h"
#include "host/spec/spec.h"
#include "test_support.h"

using namespace brdftab;

namespace {

bool same_bits(const std::vector<double>& a, const std::vector<double>& b) {
    return a.size() == b.size() &&
           (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0);
}

// Every field of two tables read back from files, the timing excepted.
void check_same_table(const TableData& a, const TableData& b) {
    CAPTURE(a.name);
    CHECK(a.name == b.name);
    CHECK(same_bits(a.value, b.value));
    CHECK(same_bits(a.stderr_, b.stderr_));
    CHECK(a.samples == b.samples);
    REQUIRE(a.axes.size() == b.axes.size());
    for (std::size_t k = 0; k < a.axes.size(); ++k) {
        CHECK(a.axes[k].name == b.axes[k].name);
        CHECK(same_bits(a.axes[k].values, b.axes[k].values));
    }
    CHECK(a.parameters == b.parameters);
    CHECK(method_attribute(a) == method_attribute(b));
    CHECK(a.samples_requested == b.samples_requested);
    CHECK(a.tolerance_requested == b.tolerance_requested);
    CHECK(a.tolerance_achieved == b.tolerance_achieved);
    CHECK(a.total_samples == b.total_samples);
    CHECK(a.seed == b.seed);
    CHECK(a.device == b.device);
    CHECK(a.stored_type == b.stored_type);
    CHECK(a.compression == b.compression);
    CHECK(a.description == b.description);
    CHECK(a.units == b.units);
}

void check_same_file(const std::string& a, const std::string& b) {
    TableReader ra(a), rb(b);
    REQUIRE(ra.table_names() == rb.table_names());
    for (const std::string& name : ra.table_names()) check_same_table(ra.read(name), rb.read(name));
}

}  // namespace

TEST_CASE("TableFileWriter: cells written in any order and any pieces equal a whole write") {
    // A 4-D table whose pieces cross rows of every axis; the oracle is the
    // whole-table writer and the values themselves.
    const std::filesystem::path dir = test::scratch_dir(BT_BINARY_DIR, "streaming", "writer");
    TableData t;
    t.name = "t";
    t.model = "m";
    t.quantity = "q";
    t.axes = {make_axis("a", "1", 0, 1, 3, Spacing::Linear),
              make_axis("b", "1", 0, 1, 4, Spacing::Linear),
              make_axis("c", "1", 0, 1, 5, Spacing::Linear),
              make_axis("d", "1", 0, 1, 2, Spacing::Linear)};
    const std::size_t n = 3 * 4 * 5 * 2;
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> u(-1, 1);
    for (std::size_t k = 0; k < n; ++k) {
        t.value.push_back(u(rng));
        t.stderr_.push_back(std::fabs(u(rng)));
        t.samples.push_back(static_cast<std::uint32_t>(k * 7 + 1));
    }
    t.keep_stderr = true;
    for (StoredType type : {StoredType::Float64, StoredType::Float32, StoredType::Float16}) {
        for (int compression : {0, 4}) {
            CAPTURE(static_cast<int>(type));
            CAPTURE(compression);
            t.stored_type = type;
            t.compression = compression;
            const std::string whole = (dir / "whole.h5").string(), pieces = (dir / "pieces.h5").string();
            write_tables(whole, {t});
            // Pieces of 1 to 17 cells, written in a shuffled order.
            std::vector<std::pair<std::size_t, std::size_t>> ranges;
            for (std::size_t first = 0; first < n;) {
                const std::size_t count = std::min<std::size_t>(n - first, 1 + rng() % 17);
                ranges.emplace_back(first, count);
                first += count;
            }
            std::shuffle(ranges.begin(), ranges.end(), rng);
            {
                TableFileWriter w(pieces);
                TableData meta = t;
                meta.value.clear();
                meta.stderr_.clear();
                meta.samples.clear();
                const std::size_t h = w.begin_table(meta, true, true);
                for (auto [first, count] : ranges)
                    w.write_cells(h, first, count, t.value.data() + first, t.stderr_.data() + first,
                                  t.samples.data() + first);
                CHECK_THROWS_AS(w.write_cells(h, n - 1, 2, t.value.data(), t.stderr_.data(),
                                              t.samples.data()),
                                Error);
                w.finish_table(h, meta);
                w.commit();
            }
            check_same_file(whole, pieces);
            if (type == StoredType::Float64) CHECK(same_bits(read_table(pieces, "t").value, t.value));
        }
    }
    // Not committed: no file, no temporary left.
    const std::string gone = (dir / "gone.h5").string();
    {
        TableFileWriter w(gone);
        w.add_table(t);
    }
    CHECK(!std::filesystem::exists(gone));
    CHECK(std::distance(std::filesystem::directory_iterator(dir), {}) == 2);
}

TEST_CASE("generate_to_file in chunks smaller than a table equals generate_tables + write_tables") {
    // A Monte Carlo table, a closed-form one on a 3-D grid, and the
    // recombination of two computed tables (kept in memory for it).
    const std::filesystem::path dir = test::scratch_dir(BT_BINARY_DIR, "streaming", "generate");
    auto device = make_backend("", Precision::Double);
    const char* mc_text =
        "model = \"rough-dielectric\"\n"
        "[parameters]\neta = 1.5\n"
        "[[axes]]\nname = \"theta_i\"\nrange = [0, 80]\ncount = 6\n"
        "[[axes]]\nname = \"alpha\"\nrange = [0.2, 0.8]\ncount = 3\n"
        "[[axes]]\nname = \"theta_o\"\nrange = [0, 60]\ncount = 4\n"
        "[[tables]]\nquantity = \"brdf\"\n"
        "[[tables]]\nname = \"albedo\"\nquantity = \"albedo_r\"\n"
        "[[tables.axes]]\nname = \"theta_i\"\nrange = [0, 80]\ncount = 6\n"
        "[[tables.axes]]\nname = \"alpha\"\nrange = [0.2, 0.8]\ncount = 3\n"
        "[integration]\nsamples = 512\nseed = 3\n"
        "[output]\ntype = \"float32\"\ncompression = 4\n";
    for (const std::string& text :
         {std::string(mc_text), test::fixture_text("oren_nayar_recombined.toml")}) {
        Spec spec = parse_spec_string(text, "mem.toml");
        const std::string whole = (dir / "whole.h5").string();
        std::vector<TableData> data;
        for (auto& g : generate_tables(spec, *device, spec.integration)) data.push_back(g.data);
        write_tables(whole, data);
        for (std::size_t chunk : {std::size_t(5), std::size_t(16), std::size_t(0)}) {
            CAPTURE(chunk);
            const std::string streamed = (dir / "streamed.h5").string();
            StreamOptions o;
            o.chunk_cells = chunk;
            std::vector<GeneratedTable> summary =
                generate_to_file(spec, *device, spec.integration, streamed, nullptr, o);
            check_same_file(whole, streamed);
            REQUIRE(summary.size() == data.size());
            for (std::size_t k = 0; k < data.size(); ++k) {
                // The summary's value range is the table's min and max.
                CHECK(summary[k].value_min == *std::min_element(data[k].value.begin(), data[k].value.end()));
                CHECK(summary[k].value_max == *std::max_element(data[k].value.begin(), data[k].value.end()));
                CHECK(summary[k].data.value.empty());  // nothing held after the write
            }
        }
    }
}

TEST_CASE("chunk plan: every cell once, in order; automatic sizes") {
    Spec spec = parse_spec_string(test::fixture_text("oren_nayar_recombined.toml"), "mem.toml");
    for (std::size_t chunk : {std::size_t(1), std::size_t(7), std::size_t(125), std::size_t(1000)}) {
        const std::vector<CellChunk> plan = plan_chunks(spec, chunk, 1);
        std::size_t next_table = 0, next_cell = 0, chunks = 0;
        for (const CellChunk& c : plan) {
            if (c.table != next_table) {
                CHECK(next_cell == 125);
                next_table = c.table;
                next_cell = 0;
            }
            CHECK(c.first == next_cell);
            CHECK(c.count <= chunk);
            next_cell += c.count;
            ++chunks;
        }
        CHECK(next_table == 1);
        CHECK(next_cell == 125);
        CHECK(chunks == 2 * ((125 + chunk - 1) / chunk));
    }
    // Automatic: one chunk per table for one process, about 8 per rank
    // (at least kMinChunkCells cells) for several.
    CHECK(chunk_cells_for(125, 0, 1) == kDefaultChunkCells);
    CHECK(chunk_cells_for(1000, 0, 4) == 32);
    CHECK(chunk_cells_for(100, 0, 4) == kMinChunkCells);
    CHECK(chunk_cells_for(1u << 30, 0, 2) == kDefaultChunkCells);
    CHECK(tables_read_by_derived(spec) ==
          std::vector<std::string>{"brdf_direct", "brdf_interreflection"});
}

TEST_CASE("memory estimate: bounded by a chunk, except for tables derived tables read") {
    const std::string text =
        "model = \"rough-dielectric\"\n"
        "[parameters]\nalpha = 0.3\ntheta_o = 10\n"
        "[[axes]]\nname = \"theta_i\"\nrange = [0, 80]\ncount = 65536\n"
        "[[axes]]\nname = \"eta\"\nrange = [1.2, 1.8]\ncount = 65535\n"
        "[[tables]]\nquantity = \"brdf\"\n";
    Spec spec = parse_spec_string(text, "mem.toml");
    const double huge = estimate_resources(spec, spec.integration).memory_bytes;
    spec.tables[0].axes[0] = make_axis("theta_i", "deg", 0, 80, 5, Spacing::Linear);
    spec.tables[0].axes[1] = make_axis("eta", "1", 1.2, 1.8, 3, Spacing::Linear);
    const double small = estimate_resources(spec, spec.integration).memory_bytes;
    // The same once the table exceeds one chunk: 4e9 cells held as 2^18.
    CHECK(huge < small + 300.0 * static_cast<double>(kDefaultChunkCells));
    CHECK(huge < 512.0 * 1024 * 1024);
    // A smaller chunk setting holds less.
    CHECK(estimate_resources(spec, spec.integration, 1024).memory_bytes <= small);
}
