// libFuzzer target for the UI strings file (appliance/ui/strings.hpp): arbitrary bytes as the
// TOML file (written to a scratch file in /dev/shm: Strings::load reads a path), once with no
// required keys and once with the code's keys. Checks, besides memory safety under ASan and
// UBSan: a refused file is an InputError naming the file; every key of an accepted file is found
// by get() and format() of it does not fail.
#include <cstddef>
#include <cstdint>
#include <string>

#include "appliance/core/errors.hpp"
#include "appliance/ui/strings.hpp"
#include "tests/fuzz/fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace glint;
    const auto file = fuzz::scratch_dir("strings") / "strings.toml";
    fuzz::write_file(file, fuzz::as_text(data, size));
    try {
        const ui::Strings s = ui::Strings::load(file, {});
        for (const std::string& key : s.keys()) {
            fuzz::check(s.has(key));
            (void)s.format(key, {{"s", "12"}, {"n", "3"}});
        }
    } catch (const InputError& e) {
        fuzz::check(std::string(e.what()).find(file.string()) == 0);
    }
    try {
        (void)ui::Strings::load(file);
    } catch (const InputError&) {
    }
    return 0;
}
