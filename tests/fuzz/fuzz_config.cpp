// libFuzzer target for the kiosk's configuration (appliance/ui/config.hpp): arbitrary bytes as
// the TOML file, through parse_config(), the text entry that load_config() uses. Checks, besides
// memory safety under ASan and UBSan: a refused file is a ConfigError and nothing else; an
// accepted one, written back with to_toml(), reads back to the same values.
#include <cstddef>
#include <cstdint>
#include <string>

#include "appliance/ui/config.hpp"
#include "appliance/ui/config_keys.hpp"
#include "tests/fuzz/fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace glint;
    const std::string text(fuzz::as_text(data, size));
    ui::Config config;
    try {
        config = ui::parse_config(text, "fuzz.toml");
    } catch (const ui::ConfigError& e) {
        fuzz::check(std::string(e.what()).rfind("fuzz.toml", 0) == 0);  // the message names the file
        return 0;
    }
    const ui::Config again = ui::parse_config(ui::to_toml(config), "again.toml");
    fuzz::check(ui::same_values(config, again));
    return 0;
}
