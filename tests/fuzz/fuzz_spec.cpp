// fuzz_spec — the TOML spec parser (host/spec/spec.h parse_spec_string) on
// arbitrary text.  Corpus: tables/*.toml and tests/data/*.toml.
#include <cstddef>
#include <cstdint>
#include <string>

#include "host/spec/spec.h"
#include "tests/fuzz/fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string text(reinterpret_cast<const char*>(data), size);
    brdftab::fuzz::expect_only_input_errors("parse_spec_string", [&] {
        const brdftab::Spec spec = brdftab::parse_spec_string(text, "fuzz.toml");
        // Touch what the generator reads next, so a half-built Spec shows.
        std::size_t nodes = 0;
        for (const auto& t : spec.tables)
            for (const auto& a : t.axes) nodes += a.values.size();
        (void)nodes;
    });
    return 0;
}
