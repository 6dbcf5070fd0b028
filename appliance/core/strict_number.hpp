// Strict parsing of numbers from text (command-line values, CSV fields, specs): the whole text
// must be the number, nothing before or after it, and it must be finite and in range. Every
// failure is an InputError naming `where` (a flag, a file and line) and the text at fault.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

namespace glint {

// A finite decimal number such as "0.01", "-3", "1e-6".
double parse_double(std::string_view text, const std::string& where);

// A whole decimal number, optionally signed ("42", "-7"); no fraction, no exponent.
std::int64_t parse_int(std::string_view text, const std::string& where);

}  // namespace glint
