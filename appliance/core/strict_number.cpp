// Strict number parsing (strict_number.hpp). std::from_chars rather than strtod: it takes no
// locale, skips no leading blanks and accepts no "+", "inf" or "nan", so a value means one thing.
#include "appliance/core/strict_number.hpp"

#include <charconv>
#include <cmath>
#include <system_error>

#include "appliance/core/errors.hpp"

namespace glint {
namespace {

template <typename T>
T parse_whole(std::string_view text, const std::string& where, const char* what) {
    T value{};
    const char* first = text.data();
    const char* last = text.data() + text.size();
    const auto [end, ec] = std::from_chars(first, last, value);
    if (text.empty() || ec != std::errc() || end != last)
        throw InputError(where + ": '" + std::string(text) + "' is not " + what);
    return value;
}

}  // namespace

double parse_double(std::string_view text, const std::string& where) {
    const double v = parse_whole<double>(text, where, "a finite number");
    if (!std::isfinite(v)) throw InputError(where + ": '" + std::string(text) + "' is not a finite number");
    return v;
}

std::int64_t parse_int(std::string_view text, const std::string& where) {
    return parse_whole<std::int64_t>(text, where, "a whole number");
}

}  // namespace glint
