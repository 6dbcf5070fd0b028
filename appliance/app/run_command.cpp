// `glint run [--config FILE]`: the appliance itself (docs/kiosk.md): the kiosk loop
// (appliance/ui/kiosk_loop.hpp) on the live camera, orientation sensor, GPIO button and display
// named in the configuration, under systemd (docs/service.md): READY=1 once the first frame is on
// screen, STATUS= with the state, WATCHDOG=1 from the frame loop, SIGHUP reloads the live keys,
// SIGTERM ends it cleanly (camera stopped, sensor closed, display released).
#include <chrono>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "appliance/app/cli_util.hpp"
#include "appliance/app/commands.hpp"
#include "appliance/app/fifo_gpio_chip.hpp"
#include "appliance/app/interrupt.hpp"
#include "appliance/app/calibration_wizard.hpp"
#include "appliance/app/kiosk_overlay.hpp"
#include "appliance/app/log_tail.hpp"
#include "appliance/app/menu_settings.hpp"
#include "appliance/app/session_recorder.hpp"
#include "appliance/capture/calibration_io.hpp"
#include "appliance/capture/camera_pump.hpp"
#include "appliance/capture/camera_factory.hpp"
#include "appliance/capture/exposure_controller.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/sim/session_simulator.hpp"
#include "appliance/ui/config.hpp"
#include "appliance/ui/config_reload.hpp"
#include "appliance/ui/fault_injection.hpp"
#include "appliance/ui/imgui_layer.hpp"
#include "appliance/ui/kiosk_loop.hpp"
#include "appliance/ui/screens.hpp"
#include "appliance/ui/service_notify.hpp"
#include "appliance/ui/strings.hpp"
#include "firmware_bridge/host/gpio_lines.hpp"
#include "firmware_bridge/host/orientation_history.hpp"
#include "firmware_bridge/host/serial_source.hpp"
#include "firmware_bridge/host/source_spec.hpp"
#include "firmware_bridge/recording/clock.hpp"

namespace glint::app {
namespace {

namespace fs = std::filesystem;

struct RunArgs {
    std::string config;
    std::string display;  // overrides display.kind
    std::string record;   // a session directory to record into
    double max_seconds = 0;  // tests: stop after this long (0: run until a signal)
    std::string faults;      // --inject-fault
};

// The live devices as the kiosk's input. The sensor's samples and the button's events arrive on
// their drivers' threads and wait here, under a lock, for the frame loop's poll.
class LiveSource final : public ui::KioskSource {
public:
    LiveSource(const ui::Config& cfg, const std::string& record_dir) {
        // The calibration on file: the one named, or the state directory's.
        calibration_file_ =
            cfg.camera.calibration.empty() ? fs::path(cfg.state.dir) / "calibration.json" : fs::path(cfg.camera.calibration);
        const fs::path& calibration_file = calibration_file_;
        if (!fs::is_regular_file(calibration_file))
            throw InputError("camera.calibration: " + calibration_file.string() +
                             " does not exist (glint calibrate writes it; a simulated session's calibration.json will do)");
        calibration_ = capture::load_calibration(calibration_file);
        response_ = render::load_camera_response(calibration_file, "camera.calibration");

        capture::CameraBackends backends = capture::capture_camera_backends();
        sim::add_simulator_camera(backends);
        // Read on its own thread: the frame loop takes what is ready (camera_pump.hpp).
        camera_ = std::make_unique<capture::CameraPump>(capture::make_camera_source(cfg.camera.source, backends, clock_));
        host::SourceSpec sensor_spec;
        try {
            sensor_spec = host::parse_source_spec(cfg.sensor.source);
            sensor_ = host::make_source(sensor_spec, clock_);
        } catch (const std::exception& e) {
            throw InputError(std::string("sensor.source: ") + e.what());
        }
        // The sensor board's own buttons (a serial board reports debounced edges) are the
        // visitor's button too: an exhibit may wire the big button to the board, not to GPIO.
        if (sensor_spec.kind == host::SourceKind::Serial)
            static_cast<host::SerialSource&>(*sensor_).set_button_sink([this](std::int64_t host_ns, unsigned, bool pressed) {
                const std::lock_guard lock(mutex_);
                events_.push_back({host_ns, "button", pressed ? "press" : "release"});
            });
        if (!record_dir.empty()) {
            if (sensor_spec.kind == host::SourceKind::Replay)
                throw InputError("--record: the sensor is a replay, a recording already (sensor.source is " +
                                 cfg.sensor.source + ")");
            recorder_ = std::make_unique<SessionRecorder>(record_dir, calibration_, sensor_spec, clock_);
            recorder_->attach(*sensor_);
        }
        sensor_->set_sample_callback([this](const host::OrientationSample& s) {
            if (recorder_) recorder_->sample(s);  // I2C and Modbus sources: their samples are the record
            const std::lock_guard lock(mutex_);
            history_.push(s);
            samples_.push_back({s.t_ns, s.world_from_sensor});
        });
        if (!cfg.gpio.chip.empty()) {
            // The real chip, or a test's pipe (fifo_gpio_chip.hpp).
            if (cfg.gpio.chip.rfind("fifo:", 0) == 0) chip_ = std::make_unique<FifoGpioChip>(cfg.gpio.chip.substr(5), clock_);
            else chip_ = std::make_unique<host::LibgpiodChip>(cfg.gpio.chip);
            // The visitor's button and the technician's key switch, both to ground (active low).
            std::vector<unsigned> inputs{unsigned(cfg.gpio.button_line)};
            if (cfg.gpio.key_switch_line >= 0) inputs.push_back(unsigned(cfg.gpio.key_switch_line));
            buttons_ = std::make_unique<host::ButtonService>(*chip_, inputs, /*active_low=*/true, clock_,
                                                             std::int64_t(cfg.gpio.debounce_ms * 1e6));
            buttons_->set_callback([this, key_switch = cfg.gpio.key_switch_line](const host::ButtonEvent& e) {
                const std::lock_guard lock(mutex_);
                if (int(e.line) == key_switch) events_.push_back({e.t_ns, "key_switch", e.pressed ? "on" : "off"});
                else events_.push_back({e.t_ns, "button", e.pressed ? "press" : "release"});
            });
            if (cfg.gpio.lamp_line >= 0) {
                lamp_line_ = unsigned(cfg.gpio.lamp_line);
                lamp_ = std::make_unique<host::LampDriver>(*chip_, std::vector<unsigned>{lamp_line_}, clock_);
            }
        }
        camera_->start();
        sensor_->start();
        if (buttons_) buttons_->start();
        if (lamp_) lamp_->start();
        start_ns_ = std::int64_t(clock_.now_us()) * 1000;
    }

    ~LiveSource() override {
        // SIGTERM's path: everything released in order, each quickly.
        if (lamp_) {
            lamp_->set_pattern(lamp_line_, host::LampPattern::off());  // dark while the kiosk is down
            lamp_->update();
            lamp_->stop();
        }
        if (buttons_) buttons_->stop();
        sensor_->stop();
        camera_->stop();
        if (recorder_) {
            const std::string error = recorder_->close();
            if (!error.empty()) std::fprintf(stderr, "glint: --record: %s\n", error.c_str());
            else std::fprintf(stderr, "glint: recorded %llu frames\n", static_cast<unsigned long long>(recorder_->frames()));
        }
    }

    std::string describe() const override { return "live: " + camera_->describe() + ", sensor " + sensor_->name(); }
    const capture::CameraCalibration& calibration() const override { return calibration_; }
    const render::CameraResponse& response() const override { return response_; }
    void configure_capture(capture::CaptureOptions& o) override {
        o.live_calibration = calibration_;
        o.live_orientation = [this](std::int64_t t_ns) -> std::optional<glm::dquat> {
            // The frame may be ahead of the sensor's stream by its latency: wait up to 100 ms for it.
            for (int k = 0; k < 100; ++k) {
                {
                    const std::lock_guard lock(mutex_);
                    const std::optional<host::OrientationSample> newest = history_.newest();
                    if (newest && newest->t_ns >= t_ns) return history_.at(t_ns).world_from_sensor;
                }
                std::this_thread::sleep_for(std::chrono::milliseconds(1));
            }
            const std::lock_guard lock(mutex_);
            return history_.at(t_ns).world_from_sensor;
        };
    }
    std::int64_t start_ns() const override { return start_ns_; }
    bool ended(std::int64_t) const override { return false; }

    ui::KioskPoll poll(std::int64_t) override {
        ui::KioskPoll p;
        // The frames the camera pump has ready, without waiting: the loop keeps its own pace. At
        // most two a frame (a burst waits for the next frame; the pump drops the oldest when the
        // loop falls further behind).
        constexpr int kMaxFramesPerPoll = 2;
        for (int n = 0; n < kMaxFramesPerPoll; ++n) {
            std::optional<capture::CameraFrame> f = camera_->next_frame(std::chrono::milliseconds(0));
            if (!f) break;
            if (recorder_) recorder_->frame(*f);
            if (exposure_)
                if (const std::optional<capture::ExposureRequest> request = exposure_->on_frame(*f)) camera_->set_exposure(*request);
            p.frames.push_back(std::move(*f));
        }
        {
            const std::lock_guard lock(mutex_);
            p.orientations.assign(samples_.begin(), samples_.end());
            samples_.clear();
            p.events.assign(events_.begin(), events_.end());
            events_.clear();
        }
        if (recorder_)
            for (const capture::SessionEvent& e : p.events) recorder_->event(e);
        return p;
    }

    void set_scanning(bool scanning) override {
        if (scanning) {
            exposure_ = std::make_unique<capture::ExposureController>(exposure_settings());
        } else if (exposure_) {
            exposure_.reset();
            camera_->set_exposure(capture::ExposureRequest{});  // the camera's own automatic exposure again
        }
    }
    std::string exposure_state() const override {
        return exposure_ && exposure_->bracketing() ? "bracketing" : std::string();
    }

    std::string restart_camera() override {
        // The same device again (a camera that hung recovers on a new start; one unplugged fails
        // here and the kiosk tries again later).
        try {
            camera_->stop();
            camera_->start();
            if (exposure_) exposure_ = std::make_unique<capture::ExposureController>(exposure_settings());
            return {};
        } catch (const std::exception& e) {
            return e.what();
        }
    }

    // A calibration wizard's exposure (nullopt: the camera's own again). The visitor's scan
    // drives the exposure while it runs; the menu starts no wizard then.
    void set_wizard_exposure(const std::optional<capture::ExposureRequest>& request) {
        if (!exposure_) camera_->set_exposure(request.value_or(capture::ExposureRequest{}));
    }
    const fs::path& calibration_file() const { return calibration_file_; }

    bool has_lamp() const { return lamp_ != nullptr; }
    void set_lamp(ui::LampMode mode) override {
        lamp_mode_ = mode;
        apply_lamp();
    }
    void set_lamp_test(std::optional<ui::LampMode> mode) {
        lamp_test_ = mode;
        apply_lamp();
    }

    ui::SourceHealth health() const override {
        ui::SourceHealth h;
        const host::LinkHealth link = sensor_->health();
        h.sensor = host::link_state_name(link.state);
        if (!link.last_error.empty() && link.state != host::LinkState::Streaming) h.sensor += ": " + link.last_error;
        h.sensor_rate_hz = link.rate_hz;
        h.camera_error = camera_->health().last_error;
        return h;
    }

    std::optional<glm::dquat> world_from_sensor(std::int64_t t_ns) const override {
        const std::lock_guard lock(mutex_);
        return history_.at(t_ns).world_from_sensor;
    }

private:
    void apply_lamp() {
        if (!lamp_) return;
        switch (lamp_test_.value_or(lamp_mode_)) {
            case ui::LampMode::Off: lamp_->set_pattern(lamp_line_, host::LampPattern::off()); break;
            case ui::LampMode::On: lamp_->set_pattern(lamp_line_, host::LampPattern::on()); break;
            case ui::LampMode::Blink: lamp_->set_pattern(lamp_line_, host::LampPattern::blink(1'000'000'000)); break;
        }
    }

    capture::ExposureControlSettings exposure_settings() const {
        capture::ExposureControlSettings settings;
        settings.min_exposure_s = calibration_.min_exposure_s;
        settings.code_exposure = calibration_.response.inverse;  // the top-up frames read codes as exposure
        return settings;
    }

    recording::SteadyClock clock_;
    fs::path calibration_file_;  // the calibration read at start, where the menu's wizards save theirs
    capture::CameraCalibration calibration_;
    render::CameraResponse response_;
    std::unique_ptr<capture::CameraSource> camera_;
    std::unique_ptr<host::OrientationSource> sensor_;
    std::unique_ptr<host::GpioChip> chip_;
    std::unique_ptr<host::ButtonService> buttons_;
    std::unique_ptr<host::LampDriver> lamp_;
    unsigned lamp_line_ = 0;
    ui::LampMode lamp_mode_ = ui::LampMode::Off;
    std::optional<ui::LampMode> lamp_test_;  // the menu's lamp test, over the kiosk's mode
    std::unique_ptr<SessionRecorder> recorder_;
    std::unique_ptr<capture::ExposureController> exposure_;  // while the visitor scans
    mutable std::mutex mutex_;
    // 2 s at 200 Hz, gaps over 100 ms not bridged, the newest held 20 ms.
    host::OrientationHistory history_{400, 100'000'000, 20'000'000};
    std::deque<capture::SensorOrientation> samples_;
    std::deque<capture::SessionEvent> events_;
    std::int64_t start_ns_ = 0;
};

int run_appliance(const RunArgs& a) {
    const ui::FaultPlan faults = ui::parse_fault_plan(a.faults);
    ui::Config cfg = a.config.empty() ? ui::default_config() : ui::load_config(a.config);
    if (!a.display.empty()) cfg.display.kind = a.display;
    const auto journal = std::make_shared<LogTail>();
    const auto log = [journal](const std::string& line) { journal->write(line); };
    // The technician's settings from the menu, over the file's (menu_settings.hpp).
    std::optional<ui::MenuSettings> menu_settings = load_menu_settings(cfg.state.dir, log);
    if (menu_settings) {
        apply_menu_settings(cfg, *menu_settings);
        log("settings from the maintenance menu (" + (fs::path(cfg.state.dir) / kMenuSettingsItem).string() +
            ") override glint.toml's [capture] and [convolution]");
    }
    StopRequest stop;
    ReloadRequest reload_request;
    ui::ServiceNotifier notifier;
    ui::WatchdogFeeder watchdog(notifier, ui::watchdog_interval());
    ui::ConfigReloader reloader(cfg);
    const ui::Strings strings = ui::Strings::load(find_data_file(ui::kStringsRelativePath));

    std::unique_ptr<LiveSource> source;
    try {
        source = std::make_unique<LiveSource>(cfg, a.record);
    } catch (const std::exception& e) {
        notifier.status(std::string("failed: ") + e.what());
        throw;
    }
    log(source->describe());

    ui::KioskOptions o;
    o.config = cfg;
    o.maps_dir = fs::path(cfg.state.dir) / "scene";
    o.snapshot_every_s = 0;
    bool restart = false;
    std::optional<ui::Config> applied;  // settings applied in the menu, for the loop's next frame
    WizardSettings wizard_settings;
    wizard_settings.sessions_dir = fs::path(cfg.state.dir) / "calibration-sessions";
    auto wizard = std::make_shared<CalibrationWizard>(wizard_settings, source->calibration(), log);
    o.observe_input = [wizard](const ui::KioskPoll& input) { wizard->feed(input); };
    o.make_overlay = make_kiosk_overlay({.config = cfg,
                                         .strings = strings,
                                         .log = log,
                                         .log_tail = journal,
                                         .request_restart = [&restart] { restart = true; },
                                         .set_lamp_test = source->has_lamp()
                                                              ? std::function<void(std::optional<ui::LampMode>)>(
                                                                    [s = source.get()](std::optional<ui::LampMode> m) { s->set_lamp_test(m); })
                                                              : nullptr,
                                         .apply_settings =
                                             [&](const ui::MenuSettings& s) {
                                                 menu_settings = s;
                                                 ui::Config next = reloader.current();
                                                 apply_menu_settings(next, s);
                                                 applied = next;
                                                 try {
                                                     save_menu_settings(cfg.state.dir, s);
                                                     return std::string("settings applied and kept in ") +
                                                            (fs::path(cfg.state.dir) / kMenuSettingsItem).string();
                                                 } catch (const std::exception& e) {
                                                     return std::string("settings applied until the next restart; ") +
                                                            "keeping them failed: " + e.what();
                                                 }
                                             },
                                         .maps_dir = o.maps_dir,
                                         .frames_dir = {},
                                         .sessions_dir = a.record.empty() ? fs::path() : fs::path(a.record),
                                         .wizard = wizard,
                                         .calibration_file = source->calibration_file(),
                                         .set_exposure =
                                             [s = source.get()](std::optional<capture::ExposureRequest> r) {
                                                 s->set_wizard_exposure(r);
                                             }});
    const auto started = std::chrono::steady_clock::now();
    o.stop_requested = [&] {
        if (stop.requested() || restart) return true;
        return a.max_seconds > 0 &&
               std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count() > a.max_seconds;
    };
    o.reload = [&]() -> std::optional<ui::Config> {
        if (applied) {
            std::optional<ui::Config> next = std::move(applied);
            applied.reset();
            return next;
        }
        if (!reload_request.take() || a.config.empty()) return std::nullopt;
        notifier.reloading();
        const ui::ReloadReport report = reloader.reload();
        log(report.summary());
        notifier.ready(report.summary());  // the reload is over (systemd waits for READY=1 after RELOADING=1)
        if (!report.ok) return std::nullopt;
        ui::Config next = reloader.current();
        if (menu_settings) apply_menu_settings(next, *menu_settings);  // the menu's still win
        return next;
    };
    ui::KioskState shown = ui::KioskState::Attract;
    o.after_present = [&](ui::KioskState state, long long frame) {
        if (frame == 0) notifier.ready(ui::kiosk_state_name(state));
        else if (state != shown) notifier.status(ui::kiosk_state_name(state));
        shown = state;
        watchdog.tick(std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch()).count());
    };
    o.fault_gl_lost_at_s = faults.gl_lost_at_s;
    ui::FaultInjectingSource faulty(*source, faults, log);
    const ui::KioskResult result = faults.empty() ? ui::run_kiosk(*source, o, log) : ui::run_kiosk(faulty, o, log);
    notifier.stopping();
    const auto t_stop = std::chrono::steady_clock::now();
    source.reset();  // camera, sensor and buttons released before the display (its destructor ran in run_kiosk)
    std::fprintf(stderr, "glint: stopped after %lld frames; devices released in %.3f s\n",
                 (long long)result.summary["frame_ms"]["frames"].get<long long>(),
                 std::chrono::duration<double>(std::chrono::steady_clock::now() - t_stop).count());
    return 0;
}

}  // namespace

Command add_run_command(CLI::App& app) {
    auto a = std::make_shared<RunArgs>();
    CLI::App* cmd = app.add_subcommand("run", std::string(command_summary("run").summary));
    cmd->add_option("--config", a->config, "The appliance's TOML configuration (default: every key's default; "
                                           "config/glint.example.toml lists them)");
    cmd->add_option("--display", a->display, "Override display.kind: kms, window, headless or auto")
        ->check(CLI::IsMember({"kms", "window", "headless", "auto"}));
    cmd->add_option("--record", a->record,
                    "Record the camera frames, the sensor stream (serial sources) and the button events into DIR, a "
                    "session glint replay reads");
    cmd->add_option("--max-seconds", a->max_seconds, "Stop cleanly after this many seconds (tests; 0: until SIGTERM)")
        ->check(CLI::Range(0.0, 1e9));
    cmd->add_option("--inject-fault", a->faults, std::string(ui::kInjectFaultHelp));
    return {cmd, [a] { return run_appliance(*a); }};
}

}  // namespace glint::app
