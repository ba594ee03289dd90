// fuzz_table — the HDF5 table reader on arbitrary files: the input bytes are
// written to a temporary .h5 file, which is then listed (list_tables), its
// file attributes read (read_file_attributes), every table read (read_table,
// at most 8) and handed to the lookup library with one evaluation at the
// centre of its axes, as `brdftab info` and `query` do.  Corpus: small tables
// written by `brdftab generate` (scripts/fuzz.sh).
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "host/io/table_io.h"
#include "host/lookup/lookup.h"
#include "tests/fuzz/fuzz_common.h"

namespace {

std::string temp_path() {
    const char* dir = std::getenv("TMPDIR");
    return std::string(dir && *dir ? dir : "/tmp") + "/brdftab-fuzz-table-" +
           std::to_string(::getpid()) + ".h5";
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    static const std::string path = temp_path();
    {
        std::FILE* f = std::fopen(path.c_str(), "wb");
        if (!f) std::abort();
        if (size > 0 && std::fwrite(data, 1, size, f) != size) std::abort();
        std::fclose(f);
    }
    using namespace brdftab;
    std::vector<std::string> names;
    fuzz::expect_only_input_errors("list_tables", [&] { names = list_tables(path); });
    // Serialised as a consumer would; strings from the file need not be
    // UTF-8 (dump's default throws on them: tests/fuzz/findings/README.md).
    fuzz::expect_only_input_errors("read_file_attributes", [&] {
        (void)read_file_attributes(path).dump(-1, ' ', false,
                                              nlohmann::json::error_handler_t::replace);
    });
    std::vector<TableData> tables;
    for (std::size_t k = 0; k < names.size() && k < 8; ++k)
        fuzz::expect_only_input_errors("read_table",
                                       [&] { tables.push_back(read_table(path, names[k])); });
    for (const auto& t : tables)
        fuzz::expect_only_input_errors("LookupTable", [&] {
            const LookupTable lt = LookupTable::from_tables(tables, t.name);
            std::vector<double> centre;
            for (const auto& a : lt.axes()) centre.push_back(0.5 * (a.min + a.max));
            if (lt.has_recombination()) centre.push_back(0.5);
            (void)lt.eval(centre);
        });
    std::remove(path.c_str());
    return 0;
}
