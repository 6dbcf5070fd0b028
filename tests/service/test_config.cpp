// The TOML configuration (appliance/ui/config.hpp): the shipped example is exactly the defaults
// and shows every field of Config; every kind of bad input is an error naming file, line and key.
// The list of fields is read from config.hpp's text, not from the code under test, so a field
// added to Config without a key (or without a line in the example) fails here.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <cctype>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "appliance/ui/config.hpp"
#include "appliance/ui/config_keys.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/render/mesh.hpp"
#include "firmware_bridge/host/source_spec.hpp"

namespace fs = std::filesystem;
using namespace glint::ui;

namespace {

std::string read_text(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    EXPECT_TRUE(in) << p;
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

const fs::path kSource = GLINT_SOURCE_DIR;
const fs::path kExample = kSource / "config/glint.example.toml";

std::string trim(std::string s) {
    const auto a = s.find_first_not_of(" \t\n");
    if (a == std::string::npos) return {};
    const auto b = s.find_last_not_of(" \t\n");
    return s.substr(a, b - a + 1);
}

// Splits at commas outside braces, angle brackets and quotes.
std::vector<std::string> split_declarators(const std::string& s) {
    std::vector<std::string> out;
    int depth = 0;
    bool quoted = false;
    std::string cur;
    for (const char c : s) {
        if (c == '"') quoted = !quoted;
        if (!quoted) {
            if (c == '{' || c == '<' || c == '(') ++depth;
            if (c == '}' || c == '>' || c == ')') --depth;
            if (c == ',' && depth == 0) {
                out.push_back(cur);
                cur.clear();
                continue;
            }
        }
        cur += c;
    }
    out.push_back(cur);
    return out;
}

bool word_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; }

// The last identifier of `s` ("" when it ends in something else).
std::string last_identifier(const std::string& s) {
    std::size_t end = s.size();
    while (end > 0 && std::isspace(static_cast<unsigned char>(s[end - 1]))) --end;
    std::size_t begin = end;
    while (begin > 0 && word_char(s[begin - 1])) --begin;
    return s.substr(begin, end - begin);
}

// "section.key" for every field of every *Section struct of config.hpp, read from its text:
// each struct is marked "struct NameSection {  // [section]" and every data member is a key.
// (Plain string searches: GCC 12's std::regex trips -Wmaybe-uninitialized in sanitizer builds.)
std::set<std::string> header_fields() {
    const std::string text = read_text(kSource / "appliance/ui/config.hpp");
    std::set<std::string> fields;
    std::istringstream lines(text);
    std::string line, section, statement;
    while (std::getline(lines, line)) {
        if (section.empty()) {
            const auto brace = line.find("Section {");
            const auto mark = line.find("// [");
            if (line.rfind("struct ", 0) == 0 && brace != std::string::npos && mark != std::string::npos)
                section = line.substr(mark + 4, line.find(']', mark) - mark - 4);
            continue;
        }
        if (line.rfind("};", 0) == 0) {
            section.clear();
            continue;
        }
        const auto comment = line.find("//");
        if (comment != std::string::npos) line.resize(comment);
        statement += " " + line;
        std::size_t semi;
        while ((semi = statement.find(';')) != std::string::npos) {
            const std::string decl = trim(statement.substr(0, semi));
            statement.erase(0, semi + 1);
            if (decl.empty()) continue;
            for (const std::string& part : split_declarators(decl)) {
                // The name is the last identifier of the left-hand side.
                const std::string name = last_identifier(part.substr(0, part.find('=')));
                if (!name.empty()) fields.insert(section + "." + name);
            }
        }
    }
    return fields;
}

struct ExampleKey {
    std::string name;
    int line = 0;
    bool commented = false;  // the line above is a comment
};

// The keys of the example as written: "[section]" headers and "key = value" lines.
std::vector<ExampleKey> example_keys() {
    std::istringstream in(read_text(kExample));
    std::vector<ExampleKey> keys;
    std::string line, section, previous;
    int n = 0;
    while (std::getline(in, line)) {
        ++n;
        const std::string t = trim(line);
        if (t.size() > 2 && t.front() == '[') section = t.substr(1, t.size() - 2);
        else if (!t.empty() && t.front() != '#') {
            const auto eq = t.find('=');
            if (eq != std::string::npos) keys.push_back({section + "." + trim(t.substr(0, eq)), n, trim(previous).rfind("#", 0) == 0});
        }
        previous = line;
    }
    return keys;
}

// The message of the ConfigError `text` raises (as file "test.toml"), or "" when it parses.
std::string error_of(const std::string& text) {
    try {
        parse_config(text, "test.toml");
    } catch (const ConfigError& e) {
        return e.what();
    }
    return "";
}

class TempDir {
public:
    TempDir() {
        char tmpl[] = "/tmp/glint-config-XXXXXX";
        path_ = ::mkdtemp(tmpl);
    }
    ~TempDir() { fs::remove_all(path_); }
    const fs::path& path() const { return path_; }

private:
    fs::path path_;
};

}  // namespace

TEST(Config, ExampleIsExactlyTheDefaults) {
    const Config example = load_config(kExample);
    const Config defaults = default_config();
    EXPECT_EQ(changed_keys(example, defaults), std::vector<std::string>{});
    EXPECT_EQ(example.file, kExample);
    EXPECT_EQ(defaults.file, fs::path());
}

TEST(Config, EveryFieldOfConfigIsAKeyAndInTheExample) {
    const std::set<std::string> fields = header_fields();
    // Guard against the header parser finding nothing (then everything below would pass).
    ASSERT_GE(fields.size(), 38u);
    EXPECT_TRUE(fields.count("ar.materials"));
    EXPECT_TRUE(fields.count("display.connector"));

    std::set<std::string> keys;
    for (const auto& k : config_keys()) keys.insert(k.name());
    EXPECT_EQ(keys, fields) << "config.cpp's table of keys and config.hpp's fields differ";

    std::set<std::string> in_example;
    for (const auto& k : example_keys()) {
        EXPECT_TRUE(in_example.insert(k.name).second) << k.name << " twice in the example";
        EXPECT_TRUE(k.commented) << "example line " << k.line << ": " << k.name << " has no comment line above it";
    }
    EXPECT_EQ(in_example, fields) << "the example and config.hpp's fields differ";
}

TEST(Config, ExampleKeysAreInTheOrderOfTheTable) {
    std::vector<std::string> example, table;
    for (const auto& k : example_keys()) example.push_back(k.name);
    for (const auto& k : config_keys()) table.push_back(k.name());
    EXPECT_EQ(example, table);
}

TEST(Config, EmptyFileGivesTheDefaults) {
    EXPECT_TRUE(same_values(parse_config("", "empty.toml"), default_config()));
    EXPECT_TRUE(same_values(parse_config("[display]\n[timeouts]\n", "empty.toml"), default_config()));
}

TEST(Config, ValuesAreRead) {
    const Config c = parse_config(R"([display]
kind = "kms"
mode = "1920x1080@60"
width = 800
[frame]
budget_ms = 40          # an integer is fine for a number
[ar]
materials = ["mirror", "glossy:80"]
[maintenance]
chord = "ctrl+shift+f12"
)",
                                  "t.toml");
    EXPECT_EQ(c.display.kind, "kms");
    EXPECT_EQ(c.display.mode, "1920x1080@60");
    EXPECT_EQ(c.display.width, 800);
    EXPECT_EQ(c.display.height, 720);  // untouched: default
    EXPECT_DOUBLE_EQ(c.frame.budget_ms, 40.0);
    EXPECT_EQ(c.ar.materials, (std::vector<std::string>{"mirror", "glossy:80"}));
    EXPECT_EQ(c.maintenance.chord, "ctrl+shift+f12");
}

TEST(Config, UnknownSectionNamesFileLineAndKey) {
    EXPECT_EQ(error_of("[display]\nkind = \"kms\"\n\n[displya]\nkind = \"kms\"\n"),
              "test.toml:4: key 'displya': unknown section (sections: display, camera, sensor, gpio, frame, capture, "
              "convolution, ar, timeouts, maintenance, state)");
    EXPECT_EQ(error_of("debug = true\n").rfind("test.toml:1: key 'debug': unknown key at the top level", 0), 0u)
        << error_of("debug = true\n");
}

TEST(Config, UnknownKeyNamesFileLineAndKey) {
    EXPECT_EQ(error_of("[gpio]\nchip = \"gpiochip1\"\nbuton_line = 5\n"),
              "test.toml:3: key 'gpio.buton_line': unknown key (gpio has chip, button_line, key_switch_line, lamp_line, "
              "debounce_ms)");
    // Dotted keys and inline tables are TOML too; the key's own line is named.
    EXPECT_EQ(error_of("\n\ntimeouts.ar_idel_s = 3\n").rfind("test.toml:3: key 'timeouts.ar_idel_s': unknown key", 0), 0u);
}

TEST(Config, WrongTypeNamesFileLineAndKey) {
    EXPECT_EQ(error_of("[display]\nwidth = \"1280\"\n"),
              "test.toml:2: key 'display.width': wrong type: an integer is needed, not a string");
    EXPECT_EQ(error_of("[display]\n\nwidth = 1280.5\n"),
              "test.toml:3: key 'display.width': wrong type: an integer is needed, not a floating-point number");
    EXPECT_EQ(error_of("[display]\nfullscreen = 1\n"),
              "test.toml:2: key 'display.fullscreen': wrong type: a boolean (true or false) is needed, not an integer");
    EXPECT_EQ(error_of("[frame]\nbudget_ms = \"33\"\n"),
              "test.toml:2: key 'frame.budget_ms': wrong type: a number is needed, not a string");
    EXPECT_EQ(error_of("[ar]\nmaterials = [\"matte\", 3]\n"),
              "test.toml:2: key 'ar.materials': element 2 is an integer, not a string");
    EXPECT_EQ(error_of("[ar]\nmaterials = \"matte\"\n"),
              "test.toml:2: key 'ar.materials': wrong type: an array of strings is needed, not a string");
    EXPECT_EQ(error_of("display = 3\n").rfind("test.toml:1: key 'display': must be a table ([display]), not an integer", 0), 0u);
}

TEST(Config, OutOfRangeNamesFileLineAndKey) {
    EXPECT_EQ(error_of("[display]\nkind = \"drm\"\n"),
              "test.toml:2: key 'display.kind': 'drm' is not one of auto, kms, window, headless");
    EXPECT_EQ(error_of("[display]\nwidth = 0\n"), "test.toml:2: key 'display.width': 0 is out of range [16, 16384]");
    EXPECT_EQ(error_of("[frame]\nbudget_ms = 0\n"), "test.toml:2: key 'frame.budget_ms': 0.0 is out of range (0.0, 1000.0]");
    EXPECT_EQ(error_of("[frame]\nbudget_ms = -5.5\n"),
              "test.toml:2: key 'frame.budget_ms': -5.5 is out of range (0.0, 1000.0]");
    EXPECT_EQ(error_of("[frame]\nbudget_ms = inf\n"), "test.toml:2: key 'frame.budget_ms': must be a finite number");
    EXPECT_EQ(error_of("[frame]\nbudget_ms = nan\n"), "test.toml:2: key 'frame.budget_ms': must be a finite number");
    EXPECT_EQ(error_of("[capture]\ntarget_coverage = 1.5\n"),
              "test.toml:2: key 'capture.target_coverage': 1.5 is out of range (0.0, 1.0]");
    EXPECT_EQ(error_of("[gpio]\nbutton_line = 99999999999\n"),
              "test.toml:2: key 'gpio.button_line': 99999999999 does not fit an int");
    EXPECT_EQ(error_of("[gpio]\nbutton_line = -1\n"), "test.toml:2: key 'gpio.button_line': -1 is out of range [0, 1023]");
    EXPECT_EQ(error_of("[maintenance]\nmax_attempts = 0\n"),
              "test.toml:2: key 'maintenance.max_attempts': 0 is out of range [1, 100]");
    EXPECT_EQ(error_of("[maintenance]\nlockout_s = 0\n"),
              "test.toml:2: key 'maintenance.lockout_s': 0.0 is out of range (0.0, 86400.0]");
    EXPECT_EQ(error_of("[timeouts]\nar_idle_s = 0\n"),
              "test.toml:2: key 'timeouts.ar_idle_s': 0.0 is out of range (0.0, 86400.0]");
    EXPECT_EQ(error_of("[timeouts]\nattract_s = 0\n"), "");  // 0 = for ever
    EXPECT_EQ(error_of("[state]\ndir = \"var/lib/glint\"\n"),
              "test.toml:2: key 'state.dir': 'var/lib/glint' is not an absolute path");
    EXPECT_EQ(error_of("[ar]\nmaterials = []\n"), "test.toml:2: key 'ar.materials': needs at least one material");
    EXPECT_EQ(error_of("[ar]\nmaterials = [\"matte\", \"matte\"]\n"),
              "test.toml:2: key 'ar.materials': 'matte' is listed twice");
}

TEST(Config, MaterialsAreWhatTheRendererParses) {
    EXPECT_EQ(error_of("[ar]\nmaterials = [\"matte\", \"glossy:40\", \"mirror\", \"kd=0.8,0.1,0.1;ks=0.2;n=60\"]\n"), "");
    EXPECT_EQ(error_of("[ar]\nmaterials = [\"matte\", \"shiny\"]\n"),
              "test.toml:2: key 'ar.materials': material 'shiny': not a material (want matte, glossy:N, mirror or "
              "kd=R,G,B;ks=R,G,B;n=N)");
    const std::string e = error_of("[ar]\nmaterials = [\"glossy:-3\"]\n");
    EXPECT_EQ(e.rfind("test.toml:2: key 'ar.materials': material 'glossy:-3'", 0), 0u) << e;
}

// The model check stands in for render::load_model without building meshes; both must agree.
TEST(Config, ModelsAreWhatTheRendererLoads) {
    TempDir dir;
    const fs::path obj = dir.path() / "Tri.OBJ";
    std::ofstream(obj) << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    for (const std::string& spec : std::vector<std::string>{"sphere", "teapot", "teapot:1", "teapot:3", obj.string()}) {
        EXPECT_EQ(error_of("[ar]\nmodel = \"" + spec + "\"\n"), "") << spec;
        EXPECT_NO_THROW(glint::render::load_model(spec, "ar.model")) << spec;
    }
    for (const std::string spec : {"teapot:0", "teapot:401", "teapot:x", "teapot:", "bunny.ply", "cube"}) {
        EXPECT_NE(error_of("[ar]\nmodel = \"" + spec + "\"\n"), "") << spec;
        EXPECT_THROW(glint::render::load_model(spec, "ar.model"), glint::InputError) << spec;
    }
    EXPECT_EQ(error_of("[ar]\nmodel = \"bunny.ply\"\n"),
              "test.toml:2: key 'ar.model': 'bunny.ply' is neither sphere, teapot, teapot:LEVEL nor an .obj, .gltf or .glb file");
    EXPECT_EQ(error_of("[ar]\nmodel = \"teapot:401\"\n"),
              "test.toml:2: key 'ar.model': 'teapot:401': the teapot's level must be an integer in [1, 400]");
    const std::string missing = (dir.path() / "gone.glb").string();
    EXPECT_EQ(error_of("[ar]\nmodel = \"" + missing + "\"\n"), "test.toml:2: key 'ar.model': '" + missing + "': no such file");
}

TEST(Config, DisplayModeAndChordSyntax) {
    for (const char* good : {"", "1280x720", "1920x1080@59.94", "640x480@60"})
        EXPECT_EQ(error_of(std::string("[display]\nmode = \"") + good + "\"\n"), "") << good;
    for (const char* bad : {"1280", "1280x", "x720", "1280x720@", "1280x720@0", "1280*720", "1280x720@60Hz"})
        EXPECT_EQ(error_of(std::string("[display]\nmode = \"") + bad + "\"\n"),
                  std::string("test.toml:2: key 'display.mode': '") + bad + "' is not WIDTHxHEIGHT or WIDTHxHEIGHT@HZ")
            << bad;
    for (const char* good : {"", "ctrl+alt+m", "super+f1", "ctrl+alt+shift+9"})
        EXPECT_EQ(error_of(std::string("[maintenance]\nchord = \"") + good + "\"\n"), "") << good;
    EXPECT_EQ(error_of("[maintenance]\nchord = \"m\"\n"),
              "test.toml:2: key 'maintenance.chord': 'm': needs at least one modifier (ctrl, alt, shift, super) and a key");
    EXPECT_EQ(error_of("[maintenance]\nchord = \"ctrl+meta+m\"\n"),
              "test.toml:2: key 'maintenance.chord': 'ctrl+meta+m': 'meta' is not a modifier (ctrl, alt, shift, super)");
    EXPECT_EQ(error_of("[maintenance]\nchord = \"ctrl+ctrl+m\"\n"),
              "test.toml:2: key 'maintenance.chord': 'ctrl+ctrl+m': 'ctrl' given twice");
    EXPECT_EQ(error_of("[maintenance]\nchord = \"ctrl+alt+f13\"\n"),
              "test.toml:2: key 'maintenance.chord': 'ctrl+alt+f13': the key 'f13' is not a-z, 0-9 or f1-f12");
}

// The KMS display's lock-down (docs/lockdown.md): which VT, and what is done with the keyboards.
TEST(Config, DisplayVtAndKeyboard) {
    for (const char* good : {"auto", "none", "/dev/tty1", "/dev/tty7", "/dev/tty63"})
        EXPECT_EQ(error_of(std::string("[display]\nvt = \"") + good + "\"\n"), "") << good;
    for (const char* bad : {"", "tty1", "/dev/tty0", "/dev/tty64", "/dev/tty01", "/dev/ttyS0", "/dev/tty", "/dev/pts/1"})
        EXPECT_EQ(error_of(std::string("[display]\nvt = \"") + bad + "\"\n"),
                  std::string("test.toml:2: key 'display.vt': '") + bad + "' is not auto, none or a VT /dev/tty1 .. /dev/tty63")
            << bad;
    for (const char* good : {"grab", "shared", "none"})
        EXPECT_EQ(error_of(std::string("[display]\nkeyboard = \"") + good + "\"\n"), "") << good;
    EXPECT_EQ(error_of("[display]\nkeyboard = \"exclusive\"\n"),
              "test.toml:2: key 'display.keyboard': 'exclusive' is not one of grab, shared, none");
    EXPECT_EQ(error_of("[display]\nvt_lock_switch = \"yes\"\n"),
              "test.toml:2: key 'display.vt_lock_switch': wrong type: a boolean (true or false) is needed, not a string");
    const Config c = parse_config("[display]\nvt = \"/dev/tty2\"\nvt_lock_switch = true\nkeyboard = \"shared\"\n", "test.toml");
    EXPECT_EQ(c.display.vt, "/dev/tty2");
    EXPECT_TRUE(c.display.vt_lock_switch);
    EXPECT_EQ(c.display.keyboard, "shared");
    EXPECT_EQ(c.display.vt_switch, "refuse");
    EXPECT_EQ(c.display.kms_api, "auto");
    EXPECT_EQ(error_of("[display]\nvt_switch = \"allow\"\n"),
              "test.toml:2: key 'display.vt_switch': 'allow' is not one of refuse, release");
    EXPECT_EQ(error_of("[display]\nkms_api = \"modern\"\n"),
              "test.toml:2: key 'display.kms_api': 'modern' is not one of auto, atomic, legacy");
    const Config r = parse_config("[display]\nvt_switch = \"release\"\nkms_api = \"legacy\"\n", "test.toml");
    EXPECT_EQ(r.display.vt_switch, "release");
    EXPECT_EQ(r.display.kms_api, "legacy");
}

TEST(Config, PinHashMustBeAModernCompleteCryptHash) {
    // Made outside this code: Python's crypt.crypt("1234", "$y$j9T$F5Jx5fExrKuPp53xLKQ..1").
    const std::string yescrypt = "$y$j9T$F5Jx5fExrKuPp53xLKQ..1$Ep4SUX.oXxnq/KKEBY/E3tIknDNDS9Tu.RwGhF8ZCzA";
    EXPECT_EQ(error_of("[maintenance]\npin_hash = \"" + yescrypt + "\"\n"), "");
    EXPECT_EQ(error_of("[maintenance]\npin_hash = \"1234\"\n"),
              "test.toml:2: key 'maintenance.pin_hash': not a crypt(3) hash (a yescrypt hash starts with \"$y$\")");
    EXPECT_EQ(error_of("[maintenance]\npin_hash = \"$1$saltsalt$f7LBW3HdNCxweXy3QoJ.A0\"\n"),
              "test.toml:2: key 'maintenance.pin_hash': a legacy crypt(3) method (DES, MD5, ...): make a yescrypt or "
              "SHA-512 one (mkpasswd -m yescrypt, openssl passwd -6)");
    // The setting alone, and a hash cut short by an editor.
    EXPECT_EQ(error_of("[maintenance]\npin_hash = \"$y$j9T$F5Jx5fExrKuPp53xLKQ..1\"\n"),
              "test.toml:2: key 'maintenance.pin_hash': an incomplete or malformed crypt(3) hash");
    EXPECT_EQ(error_of("[maintenance]\npin_hash = \"" + yescrypt.substr(0, yescrypt.size() - 3) + "\"\n"),
              "test.toml:2: key 'maintenance.pin_hash': an incomplete or malformed crypt(3) hash");
}

TEST(Config, RulesAcrossKeysNameTheKeyAndItsLine) {
    EXPECT_EQ(error_of("[frame]\nbudget_ms = 50\nhard_cap_ms = 40\n"),
              "test.toml:3: key 'frame.hard_cap_ms': 40.0 is below frame.budget_ms (50.0): every frame would be a stall");
    // Only budget_ms is in the file: the default hard cap (100) is below it; no line for the key.
    EXPECT_EQ(error_of("[frame]\nbudget_ms = 200\n"),
              "test.toml: key 'frame.hard_cap_ms': 100.0 is below frame.budget_ms (200.0): every frame would be a stall");
    EXPECT_EQ(error_of("[frame]\n\nwatchdog_s = 0.05\n"),
              "test.toml:3: key 'frame.watchdog_s': 0.05 s is not longer than frame.hard_cap_ms (100.0 ms)");
    EXPECT_EQ(error_of("[capture]\nmap_width = 1000\n"),
              "test.toml:2: key 'capture.map_width': 1000 is not twice capture.map_height (512): an equirect map is 2:1");
    EXPECT_EQ(error_of("[gpio]\nbutton_line = 4\n\nlamp_line = 4\n"),
              "test.toml:4: key 'gpio.lamp_line': line 4 is also gpio.button_line");
    // Without a chip the lines are not used, so they may coincide.
    EXPECT_EQ(error_of("[gpio]\nchip = \"\"\nbutton_line = 4\nlamp_line = 4\n"), "");
    EXPECT_EQ(error_of("[state]\ndir = \"/srv/glint\"\nexport_dir = \"/srv/glint\"\n"),
              "test.toml:3: key 'state.export_dir': '/srv/glint' is the state directory itself");
}

TEST(Config, TheFirstProblemInTheFileIsReported) {
    // toml++ keeps tables sorted by name ([ar] before [timeouts]); the report follows the file.
    EXPECT_EQ(error_of("[timeouts]\nar_idle_s = -1\n[ar]\nmodel = \"cube\"\n[zzz]\n"),
              "test.toml:2: key 'timeouts.ar_idle_s': -1.0 is out of range (0.0, 86400.0]");
    EXPECT_EQ(error_of("[state]\nnope = 1\n[display]\nkind = \"x\"\n"),
              "test.toml:2: key 'state.nope': unknown key (state has dir, export_dir)");
    // A key error comes before a rule across keys, wherever it is.
    EXPECT_EQ(error_of("[frame]\nhard_cap_ms = 1\n[timeouts]\nmessage_s = 0\n"),
              "test.toml:4: key 'timeouts.message_s': 0.0 is out of range (0.0, 86400.0]");
}

TEST(Config, SyntaxErrorNamesFileAndLine) {
    const std::string e = error_of("[display]\nkind = \"kms\"\nwidth = \n");
    EXPECT_EQ(e.rfind("test.toml:3: TOML syntax: ", 0), 0u) << e;
    const std::string dup = error_of("[display]\nkind = \"kms\"\n\nkind = \"window\"\n");
    EXPECT_EQ(dup.rfind("test.toml:4: TOML syntax: ", 0), 0u) << dup;
}

TEST(Config, ErrorsAreBadInputForTheExitCode) {
    // The commands map glint::InputError to exit code 2, which the unit does not restart.
    try {
        parse_config("[display]\nkind = 1\n", "test.toml");
        FAIL() << "parsed";
    } catch (const glint::InputError& e) {
        EXPECT_NE(dynamic_cast<const ConfigError*>(&e), nullptr);
    }
}

TEST(Config, FileErrorsNameTheFile) {
    TempDir dir;
    const fs::path missing = dir.path() / "nope.toml";
    try {
        load_config(missing);
        FAIL() << "a missing file loaded";
    } catch (const ConfigError& e) {
        EXPECT_EQ(std::string(e.what()), missing.string() + ": cannot open: No such file or directory");
    }
    try {
        load_config(dir.path());
        FAIL() << "a directory loaded";
    } catch (const ConfigError& e) {
        EXPECT_EQ(std::string(e.what()), dir.path().string() + ": is a directory, not a config file");
    }
    const fs::path bad = dir.path() / "glint.toml";
    std::ofstream(bad) << "[display]\nkind = 3\n";
    try {
        load_config(bad);
        FAIL() << "a bad file loaded";
    } catch (const ConfigError& e) {
        EXPECT_EQ(std::string(e.what()), bad.string() + ":2: key 'display.kind': wrong type: a string is needed, not an integer");
    }
}

TEST(Config, ToTomlReadsBackToTheSameValues) {
    Config c = default_config();
    c.display.kind = "window";
    c.display.connector = "HDMI-A-1 \"left\"\\";  // quotes and backslashes escaped
    c.frame.budget_ms = 16.666666666666668;        // shortest round-trip text
    c.frame.hard_cap_ms = 50;
    c.ar.materials = {"kd=1,0,0;ks=0.5;n=40", "mirror"};
    c.timeouts.attract_s = 600;
    const Config back = parse_config(to_toml(c), "written.toml");
    EXPECT_EQ(changed_keys(back, c), std::vector<std::string>{}) << to_toml(c);
    EXPECT_EQ(back.display.connector, c.display.connector);
    EXPECT_EQ(format_value(c, "frame.hard_cap_ms"), "50.0");
    EXPECT_EQ(format_value(c, "ar.materials"), "[\"kd=1,0,0;ks=0.5;n=40\", \"mirror\"]");
    EXPECT_THROW(format_value(c, "frame.nope"), std::invalid_argument);
}

TEST(Config, ChangedKeysAndCopyKey) {
    Config a = default_config(), b = default_config();
    b.gpio.lamp_line = 5;
    b.ar.materials.push_back("glossy:10");
    EXPECT_EQ(changed_keys(a, b), (std::vector<std::string>{"gpio.lamp_line", "ar.materials"}));
    copy_key(a, b, "ar.materials");
    EXPECT_EQ(changed_keys(a, b), (std::vector<std::string>{"gpio.lamp_line"}));
    EXPECT_THROW(copy_key(a, b, "gpio.nope"), std::invalid_argument);
}

// The config checks source kinds itself (ui may not include firmware_bridge/host, tests/arch);
// these two tests hold its lists to the factories that make the sources.
TEST(Config, SensorKindsAreThoseTheHostParses) {
    const std::map<std::string, std::string> examples = {{"serial", "serial:/dev/ttyACM0"},
                                                         {"i2c", "i2c:/dev/i2c-1"},
                                                         {"modbus-tcp", "modbus-tcp:10.0.0.2:502"},
                                                         {"modbus-rtu", "modbus-rtu:/dev/ttyUSB0"},
                                                         {"replay", "replay:/tmp/s.glrec"}};
    for (const auto& [kind, spec] : examples) {
        EXPECT_EQ(error_of("[sensor]\nsource = \"" + spec + "\"\n"), "") << spec;
        EXPECT_EQ(glint::host::source_kind_name(glint::host::parse_source_spec(spec).kind), kind) << spec;
    }
    // Every kind the host knows is accepted by the config.
    using K = glint::host::SourceKind;
    for (const K k : {K::Serial, K::I2c, K::ModbusTcp, K::ModbusRtu, K::Replay})
        EXPECT_TRUE(examples.count(glint::host::source_kind_name(k))) << glint::host::source_kind_name(k);
    EXPECT_EQ(error_of("[sensor]\nsource = \"usb:/dev/ttyACM0\"\n"),
              "test.toml:2: key 'sensor.source': 'usb:/dev/ttyACM0': unknown kind 'usb' (want serial, i2c, modbus-tcp, "
              "modbus-rtu, replay)");
    EXPECT_EQ(error_of("[sensor]\nsource = \"serial:\"\n"),
              "test.toml:2: key 'sensor.source': 'serial:': 'serial:' needs what follows the colon");
}

TEST(Config, CameraKindsAreThoseTheFactoriesRegister) {
    // The kinds registered as backends["KIND"] in capture's factory and the simulator.
    std::set<std::string> registered;
    for (const char* file : {"appliance/capture/camera_factory.cpp", "appliance/sim/session_simulator.cpp"}) {
        const std::string text = read_text(kSource / file);
        for (std::size_t at = text.find("[\""); at != std::string::npos; at = text.find("[\"", at + 1)) {
            const std::string before = last_identifier(text.substr(at > 40 ? at - 40 : 0, at > 40 ? 40 : at));
            const auto close = text.find("\"]", at + 2);
            if ((before != "b" && before != "backends") || close == std::string::npos) continue;
            std::size_t after = close + 2;
            while (after < text.size() && text[after] == ' ') ++after;
            if (text.compare(after, 1, "=") == 0 && text.compare(after, 2, "==") != 0)
                registered.insert(text.substr(at + 2, close - at - 2));
        }
    }
    EXPECT_EQ(registered, (std::set<std::string>{"libcamera", "replay", "simulator"}));
    for (const auto& kind : registered) EXPECT_EQ(error_of("[camera]\nsource = \"" + kind + ":x\"\n"), "") << kind;
    EXPECT_EQ(error_of("[camera]\nsource = \"v4l2:/dev/video0\"\n"),
              "test.toml:2: key 'camera.source': 'v4l2:/dev/video0': unknown kind 'v4l2' (want libcamera, replay, simulator)");
    EXPECT_EQ(error_of("[camera]\nsource = \"\"\n"),
              "test.toml:2: key 'camera.source': '': unknown kind '' (want libcamera, replay, simulator)");
}

TEST(Config, KeysKnowTheirSections) {
    EXPECT_EQ(config_sections(), (std::vector<std::string>{"display", "camera", "sensor", "gpio", "frame", "capture",
                                                            "convolution", "ar", "timeouts", "maintenance", "state"}));
}

// Damaged files (a card written half, a slip in an editor): every one either parses or is a
// ConfigError; nothing else escapes, nothing crashes (run under the sanitizers in issue 18).
TEST(Config, DamagedFilesAreConfigErrorsOrParse) {
    const std::string example = read_text(kExample);
    std::mt19937 rng(17);
    const std::string alphabet = "[]=\"'#.,{}\n 0123456789-+eEinfatrux_\\";
    int parsed = 0, rejected = 0;
    for (int round = 0; round < 3000; ++round) {
        std::string text = example;
        const int edits = 1 + static_cast<int>(rng() % 4);
        for (int e = 0; e < edits && !text.empty(); ++e) {
            const std::size_t at = rng() % text.size();
            switch (rng() % 4) {
                case 0: text[at] = alphabet[rng() % alphabet.size()]; break;        // replace
                case 1: text.erase(at, 1 + rng() % 8); break;                       // delete
                case 2: text.insert(at, 1, alphabet[rng() % alphabet.size()]); break;  // insert
                case 3: text.resize(at); break;                                     // cut short
            }
        }
        try {
            parse_config(text, "damaged.toml");
            ++parsed;
        } catch (const ConfigError& e) {
            const std::string what = e.what();
            EXPECT_EQ(what.rfind("damaged.toml", 0), 0u) << what;
            ++rejected;
        }
    }
    // Both outcomes occur, so the edits neither always break the file nor never do.
    EXPECT_GT(parsed, 50);
    EXPECT_GT(rejected, 500);
}
