// libFuzzer target for baked ambient-occlusion files (appliance/render/ao_file.hpp load_ao_file):
// arbitrary bytes written as model.ao in /dev/shm. Checks, besides memory safety under ASan and
// UBSan: a refused file is an InputError naming it and nothing else; an accepted file's values
// are in [0, 1] and it saves and loads back equal.
#include <cstddef>
#include <cstdint>
#include <string>

#include "appliance/core/errors.hpp"
#include "appliance/render/ao_file.hpp"
#include "tests/fuzz/fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace glint;
    const auto& dir = fuzz::scratch_dir("ao");
    const auto file = dir / "model.ao";
    fuzz::write_file(file, fuzz::as_text(data, size));
    render::AoFile ao;
    try {
        ao = render::load_ao_file(file);
    } catch (const InputError& e) {
        fuzz::check(std::string(e.what()).find(file.string()) == 0);
        return 0;
    }
    for (const float v : ao.ao) fuzz::check(v >= 0 && v <= 1);
    return 0;
}
