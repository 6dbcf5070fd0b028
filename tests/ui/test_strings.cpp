// The strings resource: the shipped file has exactly the keys the code lists, every key literal in
// the screens' and the menu's sources is listed, and a broken file is an error naming it.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <sstream>

#include "appliance/core/errors.hpp"
#include "appliance/ui/strings.hpp"

namespace fs = std::filesystem;
using namespace glint;

namespace {

const fs::path kSource = GLINT_SOURCE_DIR;

std::string read(const fs::path& file) {
    std::ifstream in(file);
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
}

fs::path write_temp(const std::string& name, const std::string& text) {
    const fs::path dir = fs::temp_directory_path() / "glint_ui_strings_test";
    fs::create_directories(dir);
    const fs::path file = dir / name;
    std::ofstream(file) << text;
    return file;
}

std::string error_of(const fs::path& file, const std::vector<std::string>& required) {
    try {
        ui::Strings::load(file, required);
    } catch (const InputError& e) {
        return e.what();
    }
    return "";
}

}  // namespace

TEST(Strings, TheShippedFileHasExactlyTheCodesKeys) {
    const ui::Strings strings = ui::Strings::load(kSource / ui::kStringsRelativePath);
    const std::vector<std::string> file_keys = strings.keys();
    const std::vector<std::string>& code_keys = ui::ui_string_keys();
    std::vector<std::string> unused, missing;
    std::set_difference(file_keys.begin(), file_keys.end(), code_keys.begin(), code_keys.end(), std::back_inserter(unused));
    std::set_difference(code_keys.begin(), code_keys.end(), file_keys.begin(), file_keys.end(), std::back_inserter(missing));
    EXPECT_TRUE(unused.empty()) << "in strings.toml but not used: " << ::testing::PrintToString(unused);
    EXPECT_TRUE(missing.empty()) << "used but not in strings.toml: " << ::testing::PrintToString(missing);
    for (const std::string& key : code_keys) EXPECT_FALSE(strings.get(key).empty()) << key;
}

// Every key written as a literal in the screens' and the menu's code is in the list; the list is
// therefore the code's, and the file test above covers the file against both.
TEST(Strings, EveryKeyInTheCodeIsListed) {
    const std::regex literal(R"re("((attract|capture|processing|ar|material|message|status|menu)\.[a-z_.]*[a-z_])")re");
    const std::vector<std::string>& listed = ui::ui_string_keys();
    int found = 0;
    for (const char* source : {"appliance/ui/screens.cpp", "appliance/ui/maintenance_menu.cpp"}) {
        const fs::path file = kSource / source;
        if (!fs::exists(file)) continue;  // the menu lands after the screens
        const std::string text = read(file);
        for (auto it = std::sregex_iterator(text.begin(), text.end(), literal); it != std::sregex_iterator(); ++it) {
            const std::string key = (*it)[1].str();
            if (key.back() == '.') continue;  // a prefix completed at run time ("capture.exposure." + state)
            EXPECT_TRUE(std::binary_search(listed.begin(), listed.end(), key)) << source << " uses \"" << key << "\"";
            ++found;
        }
    }
    EXPECT_GT(found, 10);
    // The list is sorted and has no duplicates (binary_search above relies on it).
    EXPECT_TRUE(std::is_sorted(listed.begin(), listed.end()));
    EXPECT_EQ(std::adjacent_find(listed.begin(), listed.end()), listed.end());
}

TEST(Strings, AMissingKeyIsAnErrorNamingFileAndKeys) {
    const fs::path file = write_temp("short.toml", "[attract]\ncall = \"Press\"\n");
    const std::string error = error_of(file, {"attract.call", "attract.subtitle", "menu.title"});
    EXPECT_NE(error.find(file.string()), std::string::npos) << error;
    EXPECT_NE(error.find("attract.subtitle"), std::string::npos) << error;
    EXPECT_NE(error.find("menu.title"), std::string::npos) << error;
    EXPECT_EQ(error.find("attract.call"), std::string::npos) << error;
}

TEST(Strings, ANonStringOrBadSyntaxNamesFileAndLine) {
    const fs::path number = write_temp("number.toml", "[attract]\ncall = \"Press\"\nsubtitle = 3\n");
    EXPECT_NE(error_of(number, {}).find(number.string() + ":3: key 'attract.subtitle' is not a string"), std::string::npos)
        << error_of(number, {});
    const fs::path syntax = write_temp("syntax.toml", "[attract]\ncall = \"Press\n");
    EXPECT_NE(error_of(syntax, {}).find(syntax.string() + ":2"), std::string::npos) << error_of(syntax, {});
    EXPECT_NE(error_of("/nonexistent/strings.toml", {}).find("/nonexistent/strings.toml"), std::string::npos);
}

TEST(Strings, FormatFillsNamedPlaces) {
    const ui::Strings strings(std::map<std::string, std::string>{{"a.b", "about {s} s left, {s}!"}, {"a.c", "{n} of {m} {x}"}});
    EXPECT_EQ(strings.format("a.b", {{"s", "12"}}), "about 12 s left, 12!");
    EXPECT_EQ(strings.format("a.c", {{"n", "1"}, {"m", "{n}"}}), "1 of {n} {x}");  // values are not expanded again
    EXPECT_EQ(strings.get("a.unknown"), "a.unknown");
}
