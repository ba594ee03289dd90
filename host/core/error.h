// error.h — exception types shared by the whole library.
//
// The library never prints: it throws.  The CLI maps InputError (bad spec,
// bad argument, bad file) to exit code 2 and every other brdftab::Error to 1.
#pragma once

#include <stdexcept>
#include <string>

namespace brdftab {

// Base of every error the library raises on purpose.
class Error : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

// The user gave something we cannot accept (spec key, CLI value, input file).
// The message names the file, line and key where known, and the allowed range.
class InputError : public Error {
public:
    using Error::Error;
};

}  // namespace brdftab
