#include <gtest/gtest.h>

#include <atomic>
#include <filesystem>
#include <thread>
#include <fstream>
#include <unistd.h>

#include "appliance/capture/camera_factory.hpp"
#include "appliance/capture/camera_pump.hpp"
#include "appliance/capture/libcamera_source.hpp"
#include "appliance/capture/replay_camera.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/exr_io.hpp"
#include "appliance/sim/camera_simulator.hpp"
#include "appliance/sim/session_simulator.hpp"

namespace glint::capture {
namespace {

using sim::simulate_session;
using sim::SimulateOptions;

namespace fs = std::filesystem;

// A source that takes 30 ms to make each frame and remembers from which thread it was called.
class SlowSource final : public CameraSource {
public:
    std::string describe() const override { return "slow"; }
    void start() override { started = true; }
    void stop() override { started = false; }
    std::optional<CameraFrame> next_frame(std::chrono::milliseconds) override {
        callers_ok = callers_ok && std::this_thread::get_id() != test_thread;
        if (made >= limit) return std::nullopt;
        std::this_thread::sleep_for(std::chrono::milliseconds(30));
        CameraFrame f;
        f.rgb = cv::Mat(2, 2, CV_8UC3, cv::Scalar(0, 0, 0));
        f.sequence = std::uint64_t(made++);
        f.exposure_s = exposure_s;
        return f;
    }
    void set_exposure(const ExposureRequest& r) override {
        callers_ok = callers_ok && std::this_thread::get_id() != test_thread;
        exposure_s = r.exposure_s;
    }
    bool finished() const override { return made >= limit; }
    CameraHealth health() const override { return {}; }

    std::thread::id test_thread = std::this_thread::get_id();
    std::atomic<bool> callers_ok{true}, started{false};
    std::atomic<int> made{0};
    int limit = 1000;
    std::atomic<double> exposure_s{0.01};
};

TEST(CameraPump, TheFrameLoopNeverWaitsInsideTheCamera) {
    auto slow = std::make_unique<SlowSource>();
    SlowSource& source = *slow;
    CameraPump pump(std::move(slow), 4);
    pump.start();
    EXPECT_TRUE(source.started);
    // Asked for a frame without waiting while the source is making one: none, at once.
    const auto t0 = std::chrono::steady_clock::now();
    EXPECT_FALSE(pump.next_frame(std::chrono::milliseconds(0)));
    EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::milliseconds(25));
    // Frames come in order; an exposure asked for reaches the source from the pump's thread.
    ExposureRequest r;
    r.automatic = false;
    r.exposure_s = 0.002;
    pump.set_exposure(r);
    std::uint64_t last = 0;
    bool first = true, exposure_seen = false;
    for (int k = 0; k < 8; ++k) {
        const std::optional<CameraFrame> f = pump.next_frame(std::chrono::milliseconds(2000));
        ASSERT_TRUE(f);
        if (!first) {
            EXPECT_GT(f->sequence, last);
        }
        last = f->sequence;
        first = false;
        exposure_seen = exposure_seen || f->exposure_s == 0.002;
    }
    EXPECT_TRUE(exposure_seen);
    EXPECT_TRUE(source.callers_ok);
    pump.stop();
    EXPECT_FALSE(source.started);
    pump.stop();  // idempotent
}

TEST(CameraPump, AFrameLoopThatFallsBehindLosesTheOldestFramesCounted) {
    auto slow = std::make_unique<SlowSource>();
    SlowSource& source = *slow;
    source.limit = 10;
    CameraPump pump(std::move(slow), 3);
    pump.start();
    // Nobody takes frames until the source has made all 10 and ended.
    for (int k = 0; k < 400 && !pump.finished() && source.made < 10; ++k) std::this_thread::sleep_for(std::chrono::milliseconds(10));
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    std::vector<std::uint64_t> got;
    while (const std::optional<CameraFrame> f = pump.next_frame(std::chrono::milliseconds(0))) got.push_back(f->sequence);
    EXPECT_EQ(got, (std::vector<std::uint64_t>{7, 8, 9}));  // the newest three
    EXPECT_EQ(pump.health().dropped, 7u);
    EXPECT_TRUE(pump.finished());
}

TEST(LibcameraSource, AMissingCameraIsAClearErrorListingWhatWasFound) {
    LibcameraOptions o;
    o.camera_id = "/base/no/such/camera@0";
    LibcameraSource source(o);
    try {
        source.start();
        FAIL() << "started a camera that does not exist";
    } catch (const CameraError& e) {
        const std::string what = e.what();
        EXPECT_NE(what.find("libcamera"), std::string::npos) << what;
        EXPECT_TRUE(what.find("no camera") != std::string::npos || what.find("did not start") != std::string::npos)
            << what;
        // Whatever libcamera lists on this machine is named in the message.
        for (const std::string& name : list_libcamera_cameras()) EXPECT_NE(what.find(name), std::string::npos) << what;
    }
    EXPECT_FALSE(source.next_frame(std::chrono::milliseconds(1)));  // not started: no frame, no crash
    source.stop();                                                    // idempotent
}

class ReplayCameraTest : public ::testing::Test {
protected:
    void SetUp() override {
        dir_ = fs::temp_directory_path() / ("glint-replay-camera-" + std::to_string(::getpid()));
        fs::remove_all(dir_);
        fs::create_directories(dir_);
        HdrImage env(64, 32);
        for (int j = 0; j < 32; ++j)
            for (int i = 0; i < 64; ++i) env.set(i, j, {0.5f + 0.01f * float(i), 0.6f, 0.7f});
        save_exr(dir_ / "env.exr", env);
        SimulateOptions o;
        o.env = dir_ / "env.exr";
        o.out = dir_ / "session";
        o.trajectory = (dir_ / "t.csv").string();
        std::ofstream(dir_ / "t.csv") << "0,1,0,0,0\n2,0.70710678,0,0.70710678,0\n";
        o.fps = 2;
        o.width = 32;
        o.height = 18;
        simulate_session(o);
    }
    void TearDown() override { fs::remove_all(dir_); }
    fs::path dir_;
};

TEST_F(ReplayCameraTest, DeliversEveryFrameAtItsRecordedTimeOnTheVirtualClock) {
    const Session s = open_session(dir_ / "session");
    ASSERT_EQ(s.frames.size(), 5u);  // 0, 0.5, ..., 2 s
    host::VirtualClock clock(1'000'000);
    ReplayCamera cam(s, clock);
    cam.start();
    for (std::size_t k = 0; k < s.frames.size(); ++k) {
        const auto f = cam.next_frame(std::chrono::milliseconds(1000));
        ASSERT_TRUE(f) << k;
        EXPECT_EQ(f->t_ns, s.frames[k].t_ns);
        EXPECT_EQ(f->sequence, k);
        EXPECT_EQ(f->rgb.cols, 32);
        // Paced: the clock stands at the frame's offset from the first frame.
        EXPECT_EQ(clock.now_us(), 1'000'000 + std::uint64_t((s.frames[k].t_ns - s.frames[0].t_ns) / 1000));
    }
    EXPECT_TRUE(cam.finished());
    EXPECT_FALSE(cam.next_frame(std::chrono::milliseconds(10)));
    EXPECT_EQ(cam.health().frames, 5u);
}

TEST_F(ReplayCameraTest, WaitsNoLongerThanTheTimeoutAndSkipsADamagedFrame) {
    const Session s = open_session(dir_ / "session");
    std::ofstream(dir_ / "session" / s.frames[1].file) << "not a png";
    host::VirtualClock clock(0);
    ReplayCamera cam(s, clock);
    cam.start();
    ASSERT_TRUE(cam.next_frame(std::chrono::milliseconds(10)));
    // Frame 1 is due 500 ms later: a 100 ms wait times out, and the clock moved 100 ms.
    EXPECT_FALSE(cam.next_frame(std::chrono::milliseconds(100)));
    EXPECT_EQ(clock.now_us(), 100'000u);
    EXPECT_EQ(cam.health().timeouts, 1u);
    EXPECT_FALSE(cam.next_frame(std::chrono::milliseconds(1000)));  // frame 1: damaged, skipped
    EXPECT_NE(cam.health().last_error.find(s.frames[1].file), std::string::npos) << cam.health().last_error;
    const auto f2 = cam.next_frame(std::chrono::milliseconds(1000));
    ASSERT_TRUE(f2);
    EXPECT_EQ(f2->sequence, 2u);
}

// Every kind the app registers: capture's own two and the simulator's.
CameraBackends all_backends() {
    CameraBackends b = capture_camera_backends();
    sim::add_simulator_camera(b);
    return b;
}

TEST_F(ReplayCameraTest, TheFactoryPicksEachBackendByName) {
    const CameraBackends backends = all_backends();
    host::VirtualClock clock;
    const auto libcamera = make_camera_source("libcamera:/base/no/such/camera@0", backends, clock);
    EXPECT_NE(dynamic_cast<LibcameraSource*>(libcamera.get()), nullptr) << libcamera->describe();
    const auto replay = make_camera_source("replay:" + (dir_ / "session").string(), backends, clock);
    EXPECT_NE(dynamic_cast<ReplayCamera*>(replay.get()), nullptr) << replay->describe();
    const auto simulator = make_camera_source("simulator:" + (dir_ / "env.exr").string(), backends, clock);
    EXPECT_NE(dynamic_cast<sim::CameraSimulator*>(simulator.get()), nullptr) << simulator->describe();
    // What the kind's argument names must exist.
    EXPECT_THROW(make_camera_source("replay:" + (dir_ / "none").string(), backends, clock), InputError);
}

TEST(CameraFactory, ABadSpecIsAnErrorNamingItAndWhatIsAccepted) {
    const CameraBackends backends = all_backends();
    host::VirtualClock clock;
    for (const std::string spec : {"webcam:0", "", "replay", "simulator:"}) {
        try {
            make_camera_source(spec, backends, clock);
            FAIL() << "made a camera of '" << spec << "'";
        } catch (const InputError& e) {
            const std::string what = e.what();
            EXPECT_NE(what.find("camera '" + spec + "'"), std::string::npos) << what;
            if (spec == "webcam:0") {
                for (const char* accepted : {"libcamera[:ID]", "replay:DIR", "simulator:ENV.exr"})
                    EXPECT_NE(what.find(accepted), std::string::npos) << what;
            }
        }
    }
}

TEST_F(ReplayCameraTest, TheSimulatorDeliversItsFramesAtTheirTimesThroughTheInterface) {
    CameraCalibration cal;
    cal.intrinsics = Intrinsics::from_fov(32, 18, 70 * kPi / 180);
    sim::CameraRun run;
    run.world_from_camera = [](double t_s) { return sim::camera_look(10 * t_s, 5); };
    run.fps = 4;
    run.frames = 5;
    host::VirtualClock clock(1'000'000);
    sim::CameraSimulator simulator(load_exr(dir_ / "env.exr").image, cal, run, clock);
    CameraSource& cam = simulator;
    EXPECT_NE(cam.describe().find("simulator"), std::string::npos) << cam.describe();
    cam.start();
    std::vector<cv::Mat> first_run;
    for (int k = 0; k < 5; ++k) {
        const auto f = cam.next_frame(std::chrono::milliseconds(1000));
        ASSERT_TRUE(f) << k;
        // Due k / fps after start(), stamped with the clock's time then.
        const std::uint64_t due_us = 1'000'000 + std::uint64_t(k) * 250'000;
        EXPECT_EQ(f->t_ns, std::int64_t(due_us) * 1000) << k;
        EXPECT_EQ(clock.now_us(), due_us) << k;
        EXPECT_EQ(f->sequence, std::uint64_t(k));
        EXPECT_EQ(f->rgb.cols, 32);
        EXPECT_EQ(f->rgb.rows, 18);
        EXPECT_GT(f->exposure_s, 0);
        first_run.push_back(f->rgb.clone());
    }
    EXPECT_TRUE(cam.finished());
    EXPECT_FALSE(cam.next_frame(std::chrono::milliseconds(10)));
    EXPECT_EQ(cam.health().frames, 5u);
    // Started again, it runs again from the same state: the same frames, paced the same way.
    cam.start();
    for (int k = 0; k < 5; ++k) {
        if (k > 0) {
            EXPECT_FALSE(cam.next_frame(std::chrono::milliseconds(100))) << "frame " << k << " is 250 ms away";
        }
        const auto f = cam.next_frame(std::chrono::milliseconds(1000));
        ASSERT_TRUE(f) << k;
        EXPECT_EQ(cv::norm(f->rgb, first_run[std::size_t(k)], cv::NORM_INF), 0.0) << k;
    }
    EXPECT_EQ(cam.health().timeouts, 4u);
}

}  // namespace
}  // namespace glint::capture
