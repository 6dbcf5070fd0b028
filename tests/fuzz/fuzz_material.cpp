// libFuzzer target for material specs (appliance/render/material.hpp parse_material: the
// --material flag and the config's materials list). Checks, besides memory safety under ASan
// and UBSan: a refused spec is an InputError and nothing else; an accepted material has finite,
// non-negative albedos and shininess.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>

#include "appliance/core/errors.hpp"
#include "appliance/render/material.hpp"
#include "tests/fuzz/fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace glint;
    render::Material m;
    try {
        m = render::parse_material(std::string(fuzz::as_text(data, size)), "--material");
    } catch (const InputError&) {
        return 0;
    }
    for (int c = 0; c < 3; ++c) {
        fuzz::check(std::isfinite(m.kd[c]) && m.kd[c] >= 0);
        fuzz::check(std::isfinite(m.ks[c]) && m.ks[c] >= 0);
    }
    fuzz::check(m.mirror || (std::isfinite(m.n) && m.n >= 0));
    return 0;
}
