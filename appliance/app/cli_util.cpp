// Strict command-line value parsing.
#include "appliance/app/cli_util.hpp"

#include <cerrno>
#include <cmath>
#include <cstdlib>

#include "appliance/core/errors.hpp"

namespace glint::app {

double parse_number(const std::string& text, const std::string& flag) {
    errno = 0;
    char* end = nullptr;
    const double v = std::strtod(text.c_str(), &end);
    if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE || !std::isfinite(v))
        throw InputError(flag + ": '" + text + "' is not a finite number");
    return v;
}

convolution::Size parse_size(const std::string& text, const std::string& flag) {
    const auto x = text.find('x');
    if (x == std::string::npos) throw InputError(flag + ": '" + text + "' is not WxH (e.g. 512x256)");
    const double w = parse_number(text.substr(0, x), flag);
    const double h = parse_number(text.substr(x + 1), flag);
    if (w != std::floor(w) || h != std::floor(h) || w < 2 || h < 2 || w > 65536 || h > 65536)
        throw InputError(flag + ": '" + text + "' needs whole sizes between 2 and 65536");
    return {int(w), int(h)};
}

std::vector<std::string> split_list(const std::string& text, const std::string& flag) {
    std::vector<std::string> items;
    std::size_t start = 0;
    for (;;) {
        const auto comma = text.find(',', start);
        std::string item = text.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
        while (!item.empty() && item.front() == ' ') item.erase(item.begin());
        while (!item.empty() && item.back() == ' ') item.pop_back();
        if (item.empty()) throw InputError(flag + ": empty item in '" + text + "'");
        items.push_back(item);
        if (comma == std::string::npos) break;
        start = comma + 1;
    }
    return items;
}

}  // namespace glint::app
