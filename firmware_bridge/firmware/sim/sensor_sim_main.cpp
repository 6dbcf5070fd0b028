// glint-sensor-sim: runs the sensor-board firmware against a simulated IMU and serves its
// serial link on a pseudo-terminal, for the appliance's serial driver to open.
#include <CLI/CLI.hpp>

#include <atomic>
#include <csignal>
#include <cstdio>
#include <exception>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "firmware_bridge/firmware/sim/sensor_sim.hpp"

namespace {

std::atomic<bool> g_stop{false};
extern "C" void on_signal(int) { g_stop.store(true); }  // lock-free store only

constexpr double kRadPerDeg = 0.017453292519943295;

std::vector<std::string> split(const std::string& text, char sep) {
    std::vector<std::string> parts;
    std::stringstream in(text);
    std::string part;
    while (std::getline(in, part, sep)) parts.push_back(part);
    return parts;
}

double number(const std::string& text, const std::string& option) {
    std::size_t used = 0;
    double v = 0;
    try {
        v = std::stod(text, &used);
    } catch (const std::exception&) {
        used = 0;
    }
    if (used == 0 || used != text.size()) throw std::runtime_error(option + ": '" + text + "' is not a number");
    return v;
}

std::uint64_t seconds_to_us(double s, const std::string& option) {
    if (!(s >= 0) || s > 1e9) throw std::runtime_error(option + ": time " + std::to_string(s) + " s out of range");
    return static_cast<std::uint64_t>(s * 1e6);
}

glint::firmware::Vec3d vec3(const std::string& text, const std::string& option) {
    const auto p = split(text, ',');
    if (p.size() != 3) throw std::runtime_error(option + ": expected X,Y,Z, got '" + text + "'");
    return {number(p[0], option), number(p[1], option), number(p[2], option)};
}

}  // namespace

int main(int argc, char** argv) {
    using namespace glint::firmware;
    CLI::App app{"Sensor-board simulator: the Glint firmware against a simulated IMU, on a pseudo-terminal.\n"
                 "Prints the serial port (the pty slave, or the device) on the first line of stdout; open it like a real serial device."};
    app.set_version_flag("--version", "glint-sensor-sim " GLINT_VERSION, "Print the version");
    std::string imu = "bno055";
    std::string trajectory = "kiosk";
    bool no_loop = false;
    std::uint32_t rate = 200, orientation_rate = 100, raw_rate = 0;
    std::uint64_t seed = 1;
    std::string noise = "default";
    std::optional<double> gyro_noise, gyro_bias_walk, accel_noise, mag_noise;
    std::optional<std::string> gyro_bias;
    std::vector<std::string> disturbances, presses, nacks;
    std::string pty_link;
    std::string port = "pty";
    int baud = 115200;
    double duration = 0;
    bool realtime = false, fast = false;
    std::uint32_t board_id = 0x51A0B0A2;

    app.add_option("--imu", imu, "IMU to simulate: bno055 (on-chip fusion) or raw (MPU-6050 + QMC5883L, fused on the board)")
        ->check(CLI::IsMember({"bno055", "raw"}))->capture_default_str();
    app.add_option("--trajectory", trajectory,
                   "True motion: a trajectory file (README.md 'Trajectory files') or a built-in: static, yaw-sweep, tumble, kiosk")
        ->capture_default_str();
    app.add_flag("--no-loop", no_loop, "Hold the last orientation of a trajectory file instead of repeating it");
    app.add_option("--rate", rate, "IMU sample rate of the firmware, Hz (100..1000)")
        ->check(CLI::Range(100u, 1000u))->capture_default_str();
    app.add_option("--orientation-rate", orientation_rate, "Orientation frames per second (0 = off, <= --rate)")->capture_default_str();
    app.add_option("--raw-rate", raw_rate, "RawImu frames per second (0 = off, <= --rate)")->capture_default_str();
    app.add_option("--seed", seed, "Seed of the sensor noise")->capture_default_str();
    app.add_option("--noise", noise, "Sensor error preset: none, default, high (the options below override it)")
        ->check(CLI::IsMember({"none", "default", "high"}))->capture_default_str();
    app.add_option("--gyro-noise", gyro_noise, "Gyro white noise, deg/s (standard deviation per reading)");
    app.add_option("--gyro-bias", gyro_bias, "Gyro bias at start, deg/s, sensor frame: X,Y,Z");
    app.add_option("--gyro-bias-walk", gyro_bias_walk, "Gyro bias random walk, deg/s per sqrt(s)");
    app.add_option("--accel-noise", accel_noise, "Accelerometer white noise, m/s^2");
    app.add_option("--mag-noise", mag_noise, "Magnetometer white noise, uT");
    app.add_option("--mag-disturbance", disturbances,
                   "Extra magnetic field START_S:END_S:X,Y,Z (uT, world frame: +Y up, -Z north); repeatable");
    app.add_option("--press", presses, "Button press BUTTON:START_S:END_S (with 3 ms of contact bounce); repeatable");
    app.add_option("--nack", nacks, "I2C fault: the IMU NACKs every transfer START_S:END_S; repeatable");
    app.add_option("--port", port,
                   "Where the board's UART goes: pty (a new pseudo-terminal; its path is printed on the first "
                   "line of stdout) or a serial device PATH")
        ->capture_default_str();
    app.add_option("--baud", baud, "Line rate for a serial device (with a pty it is only recorded)")
        ->check(CLI::IsMember({9600, 19200, 38400, 57600, 115200, 230400, 460800, 921600, 1000000, 2000000}))
        ->capture_default_str();
    app.add_option("--pty-link", pty_link, "Create this symlink to the pty slave (replaced if it is a symlink; removed at exit)");
    app.add_option("--duration", duration, "Seconds of board time to run (0 = until SIGINT/SIGTERM)")
        ->check(CLI::NonNegativeNumber)->capture_default_str();
    auto* rt = app.add_flag("--realtime", realtime, "Board clock = real time (default)");
    app.add_flag("--fast", fast, "Virtual board clock, as fast as the reader takes the frames")->excludes(rt);
    app.add_option("--board-id", board_id, "Board id sent in Hello")->capture_default_str();

    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        if (e.get_exit_code() == 0) return app.exit(e);  // --help
        // Bad arguments: one line and exit code 2, as every Glint command.
        std::fprintf(stderr, "glint-sensor-sim: error: %s (see glint-sensor-sim --help)\n", e.what());
        return 2;
    }

    try {
        sim::SensorSimOptions options;
        options.trajectory = trajectory;
        options.loop_trajectory = !no_loop;
        options.pty_link = pty_link;
        options.port = port;
        options.baud = baud;
        options.duration_s = duration;
        options.pacing = fast ? sim::Pacing::Fast : sim::Pacing::Realtime;
        sim::SimBoardOptions& b = options.board;
        b.imu = imu == "raw" ? sim::ImuKind::Raw : sim::ImuKind::Bno055;
        b.seed = seed;
        b.info.board_id = board_id;
        b.settings.sample_rate_hz = rate;
        if (orientation_rate > rate || raw_rate > rate) {
            throw std::runtime_error("--orientation-rate and --raw-rate must not exceed --rate (" + std::to_string(rate) + ")");
        }
        b.settings.orientation_rate_hz = orientation_rate;
        b.settings.raw_rate_hz = raw_rate;
        if (noise == "none") {
            b.errors = sim::SensorErrors::none();
        } else if (noise == "high") {
            b.errors.gyro_noise_rad_s *= 5;
            b.errors.gyro_bias_rad_s = 5.0 * b.errors.gyro_bias_rad_s;
            b.errors.gyro_bias_walk_rad_s_per_sqrt_s *= 5;
            b.errors.accel_noise_m_s2 *= 5;
            b.errors.mag_noise_ut *= 5;
        }
        if (gyro_noise) b.errors.gyro_noise_rad_s = *gyro_noise * kRadPerDeg;
        if (gyro_bias) b.errors.gyro_bias_rad_s = kRadPerDeg * vec3(*gyro_bias, "--gyro-bias");
        if (gyro_bias_walk) b.errors.gyro_bias_walk_rad_s_per_sqrt_s = *gyro_bias_walk * kRadPerDeg;
        if (accel_noise) b.errors.accel_noise_m_s2 = *accel_noise;
        if (mag_noise) b.errors.mag_noise_ut = *mag_noise;
        for (const std::string& d : disturbances) {
            const auto p = split(d, ':');
            if (p.size() != 3) throw std::runtime_error("--mag-disturbance: expected START_S:END_S:X,Y,Z, got '" + d + "'");
            b.errors.mag_disturbances.push_back({seconds_to_us(number(p[0], "--mag-disturbance"), "--mag-disturbance"),
                                                 seconds_to_us(number(p[1], "--mag-disturbance"), "--mag-disturbance"),
                                                 vec3(p[2], "--mag-disturbance")});
        }
        for (const std::string& s : presses) {
            const auto p = split(s, ':');
            if (p.size() != 3) throw std::runtime_error("--press: expected BUTTON:START_S:END_S, got '" + s + "'");
            const double button = number(p[0], "--press");
            if (button < 0 || button >= b.info.button_count) {
                throw std::runtime_error("--press: button " + p[0] + " does not exist (the board has " +
                                         std::to_string(b.info.button_count) + ")");
            }
            b.presses.push_back({static_cast<std::uint8_t>(button), seconds_to_us(number(p[1], "--press"), "--press"),
                                 seconds_to_us(number(p[2], "--press"), "--press")});
        }
        for (const std::string& s : nacks) {
            const auto p = split(s, ':');
            if (p.size() != 2) throw std::runtime_error("--nack: expected START_S:END_S, got '" + s + "'");
            b.imu_nacks.push_back({seconds_to_us(number(p[0], "--nack"), "--nack"),
                                   seconds_to_us(number(p[1], "--nack"), "--nack")});
        }

        sim::SensorSim simulator(options);
        std::signal(SIGINT, on_signal);
        std::signal(SIGTERM, on_signal);
        // The port on the first line of stdout, for scripts (`--port pty`): read it, open it.
        std::printf("%s\n", simulator.port().c_str());
        std::fflush(stdout);
        std::fprintf(stderr, "glint-sensor-sim: serial port %s%s%s (%s IMU, trajectory %s, %s)\n",
                     simulator.port().c_str(), simulator.link().empty() ? "" : ", link ",
                     simulator.link().c_str(), imu.c_str(), trajectory.c_str(), fast ? "fast" : "real time");
        simulator.run(g_stop);
        const FirmwareStats& s = simulator.stats();
        std::fprintf(stderr,
                     "glint-sensor-sim: stopped at %.3f s board time: %u frames sent, %u dropped, %u received "
                     "(%u bad), %u IMU samples, %u sensor faults\n",
                     static_cast<double>(simulator.now_us()) * 1e-6, s.frames_sent, s.frames_dropped,
                     s.rx_frames_ok, s.rx_frames_bad, s.samples, s.sensor_faults);
        return 0;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "ERROR: *** %s ***\n", e.what());
        return 1;
    }
}
