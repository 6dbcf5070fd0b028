// libFuzzer target for the camera calibration file (appliance/capture/calibration_io.hpp):
// arbitrary bytes through calibration_from_json(). Checks, besides memory safety under ASan and
// UBSan: a refused file is an InputError naming the source and nothing else; an accepted one,
// written with calibration_to_json(), reads back and writes out to the same text.
#include <cstddef>
#include <cstdint>
#include <string>

#include "appliance/capture/calibration_io.hpp"
#include "appliance/core/errors.hpp"
#include "tests/fuzz/fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace glint;
    capture::CameraCalibration c;
    try {
        c = capture::calibration_from_json(std::string(fuzz::as_text(data, size)), "fuzz.json");
    } catch (const InputError& e) {
        fuzz::check(std::string(e.what()).rfind("fuzz.json", 0) == 0);
        return 0;
    }
    const std::string once = capture::calibration_to_json(c);
    const std::string twice = capture::calibration_to_json(capture::calibration_from_json(once, "again.json"));
    fuzz::check(once == twice);
    return 0;
}
