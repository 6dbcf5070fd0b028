// `glint sensors --source SPEC [--record FILE] [--print-csv] [--seconds S] [--latency-ms L]`:
// reads (or replays) an orientation source and prints one line per sample on stdout and the
// health figures on stderr once a second (firmware_bridge/host/README.md).
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <deque>
#include <memory>
#include <mutex>
#include <thread>

#include "appliance/app/cli_util.hpp"
#include "appliance/app/commands.hpp"
#include "appliance/app/interrupt.hpp"
#include "appliance/core/errors.hpp"
#include "firmware_bridge/host/replay_source.hpp"
#include "firmware_bridge/host/source_spec.hpp"
#include "firmware_bridge/host/sample_recording.hpp"

namespace glint::app {
namespace {

constexpr double kDeg = 180.0 / 3.14159265358979323846;

// Yaw about world +Y (from -Z towards -X), pitch of the sensor's -Z axis above the horizon, roll
// about that axis (the sensor's +X dipping below the horizon is positive): degrees.
void yaw_pitch_roll(const glm::dquat& q, double& yaw, double& pitch, double& roll) {
    const glm::dvec3 f = q * glm::dvec3(0, 0, -1);
    const glm::dvec3 r = q * glm::dvec3(1, 0, 0);
    const glm::dvec3 u = q * glm::dvec3(0, 1, 0);
    yaw = std::atan2(-f.x, -f.z) * kDeg;
    pitch = std::asin(std::clamp(f.y, -1.0, 1.0)) * kDeg;
    roll = std::atan2(-r.y, u.y) * kDeg;
}

std::string health_line(const host::LinkHealth& h) {
    char buf[512];
    std::snprintf(buf, sizeof buf,
                  "health: %s, %.1f Hz, age %s, crc errors %llu, frame errors %llu, lost %llu, untimed %llu, "
                  "reconnects %llu, stalls %llu, timeouts %llu, drift %.1f ppm",
                  host::link_state_name(h.state), h.rate_hz,
                  h.last_sample_age_ns < 0 ? "-" : (std::to_string(h.last_sample_age_ns / 1'000'000) + " ms").c_str(),
                  static_cast<unsigned long long>(h.crc_errors), static_cast<unsigned long long>(h.frame_errors),
                  static_cast<unsigned long long>(h.lost_frames), static_cast<unsigned long long>(h.untimed_samples),
                  static_cast<unsigned long long>(h.reconnects), static_cast<unsigned long long>(h.stalls),
                  static_cast<unsigned long long>(h.timeouts), h.clock_drift_ppm);
    std::string s = buf;
    if (!h.last_error.empty()) s += ", last error: " + h.last_error;
    return s;
}

}  // namespace

Command add_sensors_command(CLI::App& app) {
    struct Args {
        std::string source, record;
        bool csv = false, realtime = false;
        double seconds = 0, latency_ms = 0;
    };
    auto a = std::make_shared<Args>();
    CLI::App* cmd = app.add_subcommand("sensors", std::string(command_summary("sensors").summary));
    cmd->add_option("--source", a->source,
                    "serial:PATH[:BAUD] | i2c:/dev/i2c-N[:ADDR] | modbus-tcp:HOST:PORT | modbus-rtu:PATH[:BAUD] | "
                    "replay:FILE")
        ->required();
    cmd->add_option("--record", a->record,
                    "Record the sensor to FILE: a serial board's raw stream and decoded messages, or the samples an "
                    "I2C or Modbus source publishes (they have no byte stream); glint sensors --source replay:FILE "
                    "plays either");
    cmd->add_flag("--print-csv", a->csv,
                  "Print samples as CSV: a header row, then t_ns,w,x,y,z (sensor-to-world quaternion, conventions' frame); "
                  "without it, "
                  "t in seconds and yaw/pitch/roll in degrees (yaw about +Y from -Z towards -X, pitch up, roll "
                  "right side down)");
    cmd->add_option("--seconds", a->seconds, "Stop after S seconds (replay: of recorded time); 0 = until Ctrl-C")
        ->check(non_negative_number());
    cmd->add_option("--latency-ms", a->latency_ms, "Latency offset of the sensor path, ms (sample times move back)")
        ->check(CLI::Range(0.0, 1000.0));
    cmd->add_flag("--realtime", a->realtime, "Replay at recorded speed (default: as fast as possible)");
    return {cmd, [a] {
                host::SourceSpec spec;
                try {
                    spec = host::parse_source_spec(a->source);
                } catch (const host::SourceError& e) {
                    throw InputError(std::string("--source: ") + e.what());
                }
                host::SourceOptions options;
                options.latency_offset_ns = std::int64_t(a->latency_ms * 1e6);
                recording::SteadyClock clock;
                std::unique_ptr<host::OrientationSource> source;
                try {
                    source = host::make_source(spec, clock, options, a->realtime);
                } catch (const host::SourceError& e) {
                    throw InputError(e.what());
                }
                std::unique_ptr<host::SensorRecording> recording;
                if (!a->record.empty()) {
                    try {
                        recording = std::make_unique<host::SensorRecording>(a->record, spec, clock);
                    } catch (const std::exception& e) {
                        throw InputError(std::string("--record: ") + e.what());
                    }
                    recording->attach(*source);
                }
                const bool replay = spec.kind == host::SourceKind::Replay;
                std::mutex mutex;
                std::deque<host::OrientationSample> pending;
                std::atomic<bool> done{false};
                std::int64_t first_t = -1;
                source->set_sample_callback([&](const host::OrientationSample& s) {
                    const std::lock_guard lock(mutex);
                    if (first_t < 0) first_t = s.t_ns;
                    if (a->seconds > 0 && double(s.t_ns - first_t) > a->seconds * 1e9) {
                        done = true;
                        return;
                    }
                    if (recording) recording->sample(s);
                    pending.push_back(s);
                });
                const StopRequest stop;  // Ctrl-C ends the loop below; the recording is closed properly
                if (a->csv) std::printf("t_ns,w,x,y,z\n");
                source->start();
                const auto started = std::chrono::steady_clock::now();
                auto next_health = started + std::chrono::seconds(1);
                const auto flush = [&] {
                    std::deque<host::OrientationSample> batch;
                    {
                        const std::lock_guard lock(mutex);
                        batch.swap(pending);
                    }
                    for (const host::OrientationSample& s : batch) {
                        if (a->csv) {
                            const glm::dquat& q = s.world_from_sensor;
                            std::printf("%lld,%.9f,%.9f,%.9f,%.9f\n", static_cast<long long>(s.t_ns), q.w, q.x, q.y,
                                        q.z);
                        } else {
                            double y = 0, p = 0, r = 0;
                            yaw_pitch_roll(s.world_from_sensor, y, p, r);
                            std::printf("t=%.6f s  yaw %8.3f  pitch %7.3f  roll %8.3f deg\n", double(s.t_ns) * 1e-9, y,
                                        p, r);
                        }
                    }
                    std::fflush(stdout);
                };
                while (!stop.requested() && !done) {
                    std::this_thread::sleep_for(std::chrono::milliseconds(20));
                    flush();
                    const auto now = std::chrono::steady_clock::now();
                    if (replay && source->health().state == host::LinkState::Finished) break;
                    if (!replay && a->seconds > 0 && now - started >= std::chrono::duration<double>(a->seconds)) break;
                    if (now >= next_health) {
                        std::fprintf(stderr, "%s\n", health_line(source->health()).c_str());
                        next_health += std::chrono::seconds(1);
                    }
                }
                flush();
                std::fprintf(stderr, "%s\n", health_line(source->health()).c_str());  // before stop(): the last state
                source->stop();
                flush();
                if (recording && !recording->close()) throw RuntimeError(recording->error());
                return 0;
            }};
}

}  // namespace glint::app
