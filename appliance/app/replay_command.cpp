// `glint replay SESSION --out DIR [--realtime] [--display headless|window|kms|auto] [--snapshot-every S]
// [--threads N] [--loop-for S | --repeat N]`: the kiosk program on a recorded session (appliance/ui/kiosk_replay.hpp;
// docs/kiosk.md "Replay").
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "appliance/app/cli_util.hpp"
#include "appliance/app/commands.hpp"
#include "appliance/app/calibration_wizard.hpp"
#include "appliance/app/kiosk_overlay.hpp"
#include "appliance/capture/session.hpp"
#include "appliance/app/log_tail.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/progress.hpp"
#include "appliance/ui/config.hpp"
#include "appliance/ui/imgui_layer.hpp"
#include "appliance/ui/kiosk_replay.hpp"
#include "appliance/ui/screens.hpp"
#include "appliance/ui/strings.hpp"

namespace glint::app {
namespace {

namespace fs = std::filesystem;

struct ReplayArgs {
    std::string session, out, display = "headless", config, faults;
    bool no_overlay = false;
    bool realtime = false;
    double snapshot_every_s = 5;
    int threads = 0;
    double loop_for_s = 0;  // soak (kiosk_replay.hpp)
    int repeat = 0;
};

int run_replay_command(const ReplayArgs& a) {
    if (!fs::is_directory(a.session)) throw InputError("SESSION " + a.session + ": not a directory");
    if (a.out.empty()) throw InputError("--out DIR is required");
    ui::ReplayOptions o;
    o.session = a.session;
    o.out = a.out;
    o.realtime = a.realtime;
    o.faults = ui::parse_fault_plan(a.faults);
    if (!a.config.empty()) o.kiosk.config = ui::load_config(a.config);
    // A replay shows headless unless asked: the config's display is the appliance's.
    o.kiosk.config.display.kind = a.display;
    const auto journal = std::make_shared<LogTail>();
    const auto log = [journal](const std::string& line) { journal->write(line); };
    if (!a.no_overlay) {
        const ui::Strings strings = ui::Strings::load(find_data_file(ui::kStringsRelativePath));
        ui::Config overlay_config = o.kiosk.config;
        overlay_config.state.dir = a.out;  // the PIN's lock state stays with the replay
        // The menu's calibration wizards on the recorded frames: their runs and an applied
        // calibration stay with the replay's output too.
        WizardSettings wizard_settings;
        wizard_settings.sessions_dir = fs::path(a.out) / "calibration-sessions";
        wizard_settings.never_drop = !a.realtime;  // the same result on any machine
        auto wizard = std::make_shared<CalibrationWizard>(wizard_settings, capture::open_session(a.session).calibration, log);
        o.kiosk.observe_input = [wizard](const ui::KioskPoll& input) { wizard->feed(input); };
        o.kiosk.make_overlay = make_kiosk_overlay({.config = overlay_config,
                                                   .strings = strings,
                                                   .log = log,
                                                   .log_tail = journal,
                                                   .request_restart = {},
                                                   .set_lamp_test = {},
                                                   .apply_settings = {},
                                                   .maps_dir = a.out,
                                                   .frames_dir = fs::path(a.out) / "frames",
                                                   .sessions_dir = {},
                                                   .wizard = wizard,
                                                   .calibration_file = fs::path(a.out) / "calibration.json",
                                                   .set_exposure = {}});
    }
    o.kiosk.snapshot_every_s = a.snapshot_every_s;
    o.kiosk.threads = a.threads;
    o.loop_for_s = a.loop_for_s;
    o.repeat = a.repeat;
    const bool soak = a.loop_for_s > 0 || a.repeat > 0;
    std::unique_ptr<ProgressBar> bar;
    long long shown = 0;  // tenths of a session second drawn
    // A soak logs a line a pass instead (its passes would restart the bar).
    if (!soak) o.kiosk.progress = [&](double t_s, double end_s) {
        if (!bar) bar = std::make_unique<ProgressBar>("replay (session seconds x 10)", (long long)(end_s * 10) + 1);
        const long long now = (long long)(t_s * 10);
        if (now > shown) {
            bar->advance(now - shown);
            shown = now;
        }
    };
    const nlohmann::json s = ui::run_replay(o, log);
    if (bar) bar->finish();
    std::printf("states:");
    for (const auto& st : s["states"]) std::printf(" %s@%.1fs", st["name"].get<std::string>().c_str(), st["t_s"].get<double>());
    std::printf("\nframe time: median %.2f ms, p99 %.2f ms, max %.2f ms (budget %.1f ms, %d over the hard cap)\n",
                s["frame_ms"]["median"].get<double>(), s["frame_ms"]["p99"].get<double>(), s["frame_ms"]["max"].get<double>(),
                s["frame_ms"]["budget"].get<double>(), s["frame_ms"]["over_hard_cap"].get<int>());
    const auto number = [&](const char* key) { return s[key].is_null() ? std::string("n/a") : std::to_string(s[key].get<double>()); };
    std::printf("scan end -> lit object: %s s; coverage %s; environment error %s; irradiance error %s; tracking %s\n",
                number("scan_end_to_lit_s").c_str(), number("coverage").c_str(), number("env_error").c_str(),
                number("irradiance_error").c_str(), number("tracking_detection_rate").c_str());
    std::printf("frames: %s/frames/, summary: %s/summary.json\n", a.out.c_str(), a.out.c_str());
    if (soak) std::printf("soak: one row a pass and every 5 s in %s/soak.csv (the figures above: the last pass)\n", a.out.c_str());
    return 0;
}

}  // namespace

Command add_replay_command(CLI::App& app) {
    auto a = std::make_shared<ReplayArgs>();
    CLI::App* cmd = app.add_subcommand("replay", std::string(command_summary("replay").summary));
    cmd->add_option("SESSION", a->session, "A recorded session directory (glint simulate --kiosk, glint run --record)")->required();
    cmd->add_option("--out", a->out, "Directory for the PNG frames (DIR/frames/), the maps and summary.json")->required();
    cmd->add_option("--config", a->config, "The appliance's TOML configuration (budgets, timeouts, capture, AR); its display "
                                           "section is not used: see --display");
    cmd->add_flag("--no-overlay", a->no_overlay, "Frames without the visitor screens' text and graphics");
    cmd->add_flag("--realtime", a->realtime, "Deliver the session at its recorded pace (default: as fast as possible)");
    cmd->add_option("--display", a->display, "headless (default), window, kms or auto")
        ->check(CLI::IsMember({"headless", "window", "kms", "auto"}));
    cmd->add_option("--snapshot-every", a->snapshot_every_s,
                    "A PNG frame every S seconds of session time, besides one at each state change (0: none)")
        ->check(CLI::Range(0.0, 3600.0));
    cmd->add_option("--threads", a->threads, "Capture and convolution worker threads (0: the cores but one)")
        ->check(CLI::Range(0, 256));
    cmd->add_option("--inject-fault", a->faults, std::string(ui::kInjectFaultHelp));
    // Soak (docs/kiosk.md "Soak"): leaks show as growth from pass to pass in one process.
    CLI::Option* loop_for =
        cmd->add_option("--loop-for", a->loop_for_s,
                        "Soak: replay the session pass after pass in this process (one display and GL context) "
                        "while the run is younger than S seconds; DIR/soak.csv gets memory, descriptors, GL objects "
                        "and frame times every 5 s and after each pass; the other outputs are the last pass's")
            ->check(CLI::Range(1.0, 7.0 * 24 * 3600));
    cmd->add_option("--repeat", a->repeat, "Soak: exactly N passes (see --loop-for)")->check(CLI::Range(1, 1000000))->excludes(loop_for);
    return {cmd, [a] { return run_replay_command(*a); }};
}

}  // namespace glint::app
