// libFuzzer target for OpenEXR input through the project's loader (appliance/core/exr_io.hpp
// load_exr): arbitrary bytes written as in.exr in /dev/shm (the loader reads a path). OpenEXR is
// Debian's build and not instrumented; the loader's own checks of what OpenEXR returns are.
// Checks, besides memory safety under ASan and UBSan: a refused file is an InputError naming it
// and nothing else; an accepted image has a positive size and, sanitised, only finite
// non-negative texels.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>

#include "appliance/core/errors.hpp"
#include "appliance/core/exr_io.hpp"
#include "tests/fuzz/fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace glint;
    const auto file = fuzz::scratch_dir("exr") / "in.exr";
    fuzz::write_file(file, fuzz::as_text(data, size));
    LoadedExr exr;
    try {
        exr = load_exr(file);
    } catch (const InputError& e) {
        fuzz::check(std::string(e.what()).find(file.string()) != std::string::npos);
        return 0;
    }
    fuzz::check(exr.image.width() > 0 && exr.image.height() > 0);
    for (const float v : exr.image.data()) fuzz::check(std::isfinite(v) && v >= 0);
    return 0;
}
