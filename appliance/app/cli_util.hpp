// Value parsing shared by the subcommands beyond what CLI11's validators do: sizes and lists,
// each failure an InputError naming the flag. Numbers: appliance/core/strict_number.hpp.
#pragma once

#include <filesystem>

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "appliance/convolution/convolution.hpp"
#include "appliance/core/exr_io.hpp"

namespace glint::app {

// "WxH" with both whole numbers in [2, 65536], or InputError naming `flag`.
convolution::Size parse_size(const std::string& text, const std::string& flag);
// The same rule as a CLI11 validator, so a bad size is rejected while parsing.
CLI::Validator size_validator();

// Numbers >= 0 and > 0, as CLI11's NonNegativeNumber and PositiveNumber but with a short
// message ("must be >= 0, not -1"; CLI11's range message prints the largest double in full).
CLI::Validator non_negative_number();
CLI::Validator positive_number();

// Comma-separated list, empty items rejected.
std::vector<std::string> split_list(const std::string& text, const std::string& flag);

// Warnings about an environment map as loaded from `path`, on stderr: the values the loader
// sanitised, and a size that is not 2:1 (an equirect map is; a square one is more likely a
// light probe or a cube face, which is read as equirect all the same).
void warn_about_environment(const std::string& path, const LoadedExr& loaded);

// A file the appliance ships (`relative`, e.g. "data/ui/strings.toml"): under $GLINT_DATA_DIR when
// set, else beside the installed executable (<prefix>/share/glint/), else, for an executable in
// its build tree, in the source tree it was built from. Throws InputError listing every place
// looked in.
std::filesystem::path find_data_file(const std::string& relative);

}  // namespace glint::app
