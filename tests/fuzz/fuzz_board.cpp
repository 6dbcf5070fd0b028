// libFuzzer target for the tracking board file (appliance/tracking/board.hpp): arbitrary bytes
// through board_spec_from_json(). Checks, besides memory safety under ASan and UBSan: a refused
// file is an InputError naming the source and nothing else; an accepted spec builds a Board
// whose marker ids map to indices and whose size is positive.
#include <cstddef>
#include <cstdint>
#include <string>

#include "appliance/core/errors.hpp"
#include "appliance/tracking/board.hpp"
#include "tests/fuzz/fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace glint;
    tracking::BoardSpec spec;
    try {
        spec = tracking::board_spec_from_json(std::string(fuzz::as_text(data, size)), "fuzz.json");
    } catch (const InputError& e) {
        fuzz::check(std::string(e.what()).rfind("fuzz.json", 0) == 0);
        return 0;
    }
    const tracking::Board board(spec);
    fuzz::check(board.index_of(spec.first_id) == 0 && board.index_of(spec.first_id + board.marker_count()) == -1);
    fuzz::check(board.width_m() > 0 && board.height_m() > 0);
    return 0;
}
