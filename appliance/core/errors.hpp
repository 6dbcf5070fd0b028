// Error types shared by every Glint module. Set-up code throws; main() turns
// them into one line on stderr and a truthful exit code (docs/architecture.md, "Commands").
#pragma once

#include <stdexcept>
#include <string>

namespace glint {

// The user gave something unusable: a file, a flag, a value. Exit code 2.
class InputError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

// Anything else that failed (I/O, resources). Exit code 1.
class RuntimeError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

}  // namespace glint
