// fuzz_common.h — what every fuzz target treats as a finding.
//
// A target feeds untrusted input to a library entry point.  A brdftab::Error
// (or only an InputError under BRDFTAB_FUZZ_STRICT=1, the documented contract
// for bad input) is the correct answer to bad input; any other exception
// escaping the library is an unchecked path and aborts, so libFuzzer records
// the input as a crash, as it does for ASan/UBSan reports and timeouts.
#pragma once

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <typeinfo>

#include "host/core/error.h"

namespace brdftab::fuzz {

inline bool strict_mode() {
    static const bool strict = [] {
        const char* s = std::getenv("BRDFTAB_FUZZ_STRICT");
        return s != nullptr && s[0] == '1';
    }();
    return strict;
}

// Runs `body`; returns normally for the accepted error types, aborts for others.
template <class Body>
void expect_only_input_errors(const char* what, Body&& body) {
    try {
        body();
    } catch (const InputError&) {
    } catch (const Error& e) {
        if (strict_mode()) {
            std::fprintf(stderr, "fuzz: %s threw brdftab::Error (not InputError): %s\n", what,
                         e.what());
            std::abort();
        }
    } catch (const std::exception& e) {
        std::fprintf(stderr, "fuzz: %s threw %s: %s\n", what, typeid(e).name(), e.what());
        std::abort();
    }
}

}  // namespace brdftab::fuzz
