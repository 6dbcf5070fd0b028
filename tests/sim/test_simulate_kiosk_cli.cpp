// `glint simulate --kiosk` on the command line (appliance/app/simulate_command.cpp): documented in
// --help, and a flag of the scan's that the kiosk session would ignore is refused with exit code 2.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <string>
#include <sys/wait.h>

namespace {

struct CommandRun {
    int exit_code = -1;
    std::string output;  // stdout and stderr
};

CommandRun run(const std::string& args) {
    CommandRun r;
    FILE* p = ::popen((std::string(GLINT_VISION_BINARY) + " " + args + " 2>&1").c_str(), "r");
    if (!p) return r;
    std::array<char, 4096> buf{};
    while (std::fgets(buf.data(), int(buf.size()), p)) r.output += buf.data();
    const int status = ::pclose(p);
    r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    return r;
}

TEST(SimulateKioskCli, HelpDocumentsTheKioskSession) {
    const CommandRun r = run("simulate --kiosk --help");
    EXPECT_EQ(r.exit_code, 0) << r.output;
    for (const char* s : {"--kiosk", "Kiosk sessions", "events.csv", "kiosk.json", "truth/board.csv", "--frame-format",
                          "--jpeg-quality"})
        EXPECT_NE(r.output.find(s), std::string::npos) << "no '" << s << "' in:\n" << r.output;
}

TEST(SimulateKioskCli, FlagsOfTheScanAreRefused) {
    CommandRun r = run("simulate --kiosk --env /nonexistent.exr --out /tmp/glint-kiosk-cli-unused --trajectory guided");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find("--trajectory does not apply with --kiosk"), std::string::npos) << r.output;
    r = run("simulate --env /nonexistent.exr --out /tmp/glint-kiosk-cli-unused --jpeg-quality 80");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find("--jpeg-quality needs --kiosk"), std::string::npos) << r.output;
    r = run("simulate --kiosk --env /nonexistent.exr --out /tmp/glint-kiosk-cli-unused");
    EXPECT_EQ(r.exit_code, 2) << r.output;
    EXPECT_NE(r.output.find("/nonexistent.exr"), std::string::npos) << r.output;
}

}  // namespace
