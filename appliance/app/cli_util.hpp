// Parsing helpers shared by the subcommands: strict numbers and sizes, each
// failure an InputError naming the flag.
#pragma once

#include <string>
#include <vector>

#include "appliance/convolution/convolution.hpp"

namespace glint::app {

// A finite number parsed from the whole of `text`, or InputError naming `flag`.
double parse_number(const std::string& text, const std::string& flag);

// "WxH" with both at least 2, or InputError naming `flag`.
convolution::Size parse_size(const std::string& text, const std::string& flag);

// Comma-separated list, empty items rejected.
std::vector<std::string> split_list(const std::string& text, const std::string& flag);

}  // namespace glint::app
