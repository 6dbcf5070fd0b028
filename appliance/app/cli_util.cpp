#include <cstdlib>
// Sizes and lists on the command line (cli_util.hpp).
#include "appliance/app/cli_util.hpp"

#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "appliance/core/errors.hpp"
#include "appliance/core/strict_number.hpp"

namespace glint::app {

namespace {

// Why `text` is not a size ("" when it is one, then stored in `size`).
std::string size_problem(const std::string& text, convolution::Size& size) {
    const auto x = text.find('x');
    if (x == std::string::npos) return "'" + text + "' is not WxH (e.g. 512x256)";
    try {
        const std::int64_t w = parse_int(std::string_view(text).substr(0, x), "width");
        const std::int64_t h = parse_int(std::string_view(text).substr(x + 1), "height");
        if (w < 2 || h < 2 || w > 65536 || h > 65536) return "'" + text + "' needs whole sizes between 2 and 65536";
        size = {int(w), int(h)};
    } catch (const InputError&) {
        return "'" + text + "' is not WxH with whole numbers (e.g. 512x256)";
    }
    return {};
}

}  // namespace

convolution::Size parse_size(const std::string& text, const std::string& flag) {
    convolution::Size size;
    const std::string problem = size_problem(text, size);
    if (!problem.empty()) throw InputError(flag + ": " + problem);
    return size;
}

CLI::Validator size_validator() {
    return CLI::Validator(
        [](std::string& text) {
            convolution::Size size;
            return size_problem(text, size);
        },
        "WxH");
}

namespace {
CLI::Validator bounded_below(bool strict) {
    return CLI::Validator(
        [strict](std::string& text) -> std::string {
            char* end = nullptr;
            const double v = text.empty() ? 0.0 : std::strtod(text.c_str(), &end);  // 1e-320: denormal, fine
            if (text.empty() || end != text.c_str() + text.size() || !std::isfinite(v))
                return "must be a number, not '" + text + "'";
            if (strict ? !(v > 0) : !(v >= 0)) return std::string("must be ") + (strict ? "> 0" : ">= 0") + ", not " + text;
            return {};
        },
        strict ? "POSITIVE" : "NONNEGATIVE");
}
}  // namespace

CLI::Validator non_negative_number() { return bounded_below(false); }
CLI::Validator positive_number() { return bounded_below(true); }

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

void warn_about_environment(const std::string& path, const LoadedExr& loaded) {
    const SanitiseCounts& s = loaded.sanitised;
    if (s.total() > 0)
        std::fprintf(stderr, "glint: warning: %s: sanitised %zu channel values (NaN %zu, +Inf %zu, -Inf %zu, negative %zu)\n",
                     path.c_str(), s.total(), s.nan, s.pos_inf, s.neg_inf, s.negative);
    const int w = loaded.image.width(), h = loaded.image.height();
    if (std::abs(w - 2 * h) > 1)
        std::fprintf(stderr,
                     "glint: warning: %s: %dx%d is not 2:1; it is read as an equirectangular map all the same "
                     "(docs/conventions.md)\n",
                     path.c_str(), w, h);
}

}  // namespace glint::app

namespace glint::app {

std::filesystem::path find_data_file(const std::string& relative) {
    namespace fs = std::filesystem;
    std::vector<fs::path> places;
    if (const char* dir = std::getenv("GLINT_DATA_DIR"); dir && *dir) places.push_back(fs::path(dir) / relative);
    std::error_code ec;
    const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
    // GLINT_DATA_FROM_BIN: the install's data directory seen from its bin directory
    // ("../share/glint" for GNUInstallDirs' defaults), so any prefix works.
    if (!ec) places.push_back((exe.parent_path() / GLINT_DATA_FROM_BIN / relative).lexically_normal());
    // The source tree only for an executable still in its build tree: an installed one that
    // lacks its data must say so, not quietly read the build machine's checkout.
    const fs::path build_tree = fs::path(GLINT_BINARY_DIR).lexically_normal();
    if (ec || exe.lexically_normal().string().rfind(build_tree.string() + "/", 0) == 0)
        places.push_back(fs::path(GLINT_SOURCE_DIR) / relative);
    for (const fs::path& p : places)
        if (fs::is_regular_file(p, ec)) return p;
    std::string tried;
    for (const fs::path& p : places) tried += (tried.empty() ? "" : ", ") + p.string();
    throw InputError(relative + ": not found (looked in " + tried + ")");
}

}  // namespace glint::app
