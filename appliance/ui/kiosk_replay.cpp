#include "appliance/ui/kiosk_replay.hpp"


#include <algorithm>
#include <chrono>
#include <cstddef>
#include <cstdio>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <thread>

#include "appliance/capture/capture_pipeline.hpp"
#include "appliance/capture/kiosk_session.hpp"
#include "appliance/capture/session.hpp"
#include "appliance/core/atomic_file.hpp"
#include "appliance/core/error_metrics.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/exr_io.hpp"
#include "appliance/core/memory.hpp"
#include "appliance/core/scene_state.hpp"
#include "appliance/gl/display.hpp"
#include "appliance/gl/gl_objects.hpp"
#include "appliance/render/maps.hpp"
#include "appliance/render/material.hpp"

namespace glint::ui {
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

// A recorded session as the kiosk's input.
class ReplaySource final : public KioskSource {
public:
    ReplaySource(const fs::path& dir, bool realtime)
        : session_(capture::open_session(dir)), realtime_(realtime) {
        if (session_.frames.empty()) throw InputError(dir.string() + ": the session has no frames");
        kiosk_ = capture::load_kiosk_info(session_);
        events_ = capture::load_session_events(session_);
        // A session without a sensor stream (board views for the menu's camera calibration) has
        // no orientations: a scan in it waits for the sensor and ends as a live one would.
        if (!session_.sensors.empty()) sensors_ = capture::load_sensor_orientations(session_);
        for (const capture::TruthBoardPose& p : capture::load_truth_board_poses(session_)) truth_board_[p.index] = p;
        if (session_.has_truth)
            for (const capture::TruthPose& p : capture::load_truth_poses(session_))
                truth_camera_[p.index] = p.world_from_camera;
        response_ = render::load_camera_response(session_.dir / "calibration.json", "calibration");
        // A session without a kiosk recording (a plain scan): the visitor pressed the button at its start.
        if (!kiosk_ && events_.empty()) events_.push_back({session_.frames.front().t_ns, "button", "press"});
        std::stable_sort(events_.begin(), events_.end(), [](const auto& a, const auto& b) { return a.t_ns < b.t_ns; });
    }

    std::string describe() const override { return "replay: " + session_.dir.string(); }
    const capture::CameraCalibration& calibration() const override { return session_.calibration; }
    const render::CameraResponse& response() const override { return response_; }
    std::string board_json() const override { return kiosk_ ? kiosk_->board_json : std::string(); }
    void configure_capture(capture::CaptureOptions& o) override { o.session = session_.dir; }
    std::int64_t start_ns() const override { return session_.frames.front().t_ns; }
    bool replayed() const override { return !realtime_; }
    bool ended(std::int64_t now_ns) const override { return now_ns > session_.frames.back().t_ns; }

    KioskPoll poll(std::int64_t now_ns) override {
        KioskPoll p;
        for (; next_sensor_ < sensors_.size() && sensors_[next_sensor_].t_ns <= now_ns; ++next_sensor_)
            p.orientations.push_back(sensors_[next_sensor_]);
        for (; next_event_ < events_.size() && events_[next_event_].t_ns <= now_ns; ++next_event_) p.events.push_back(events_[next_event_]);
        for (; next_frame_ < session_.frames.size() && session_.frames[next_frame_].t_ns <= now_ns; ++next_frame_) {
            capture::CameraFrame f = capture::load_frame(session_, session_.frames[next_frame_]);
            f.sequence = session_.frames[next_frame_].index;
            p.frames.push_back(std::move(f));
        }
        return p;
    }

    std::optional<glm::dquat> world_from_sensor(std::int64_t t_ns) const override {
        if (sensors_.empty() || t_ns < sensors_.front().t_ns || t_ns > sensors_.back().t_ns) return std::nullopt;
        const auto it = std::lower_bound(sensors_.begin(), sensors_.end(), t_ns,
                                         [](const capture::SensorOrientation& a, std::int64_t t) { return a.t_ns < t; });
        if (it == sensors_.begin()) return it->world_from_sensor;
        const auto prev = it - 1;
        if (it->t_ns - prev->t_ns > 100'000'000) return std::nullopt;  // a lost stretch: no answer
        const double f = double(t_ns - prev->t_ns) / double(std::max<std::int64_t>(1, it->t_ns - prev->t_ns));
        return glm::slerp(prev->world_from_sensor, it->world_from_sensor, f);
    }

    std::optional<std::int64_t> scan_end_ns() const override {
        const capture::KioskPhase* scan = kiosk_ ? kiosk_->phase("scan") : nullptr;
        if (!scan) return std::nullopt;
        return scan->end_ns;
    }
    bool in_ar_phase(std::int64_t t_ns) const override {
        const capture::KioskPhase* ar = kiosk_ ? kiosk_->phase("ar") : nullptr;
        return !ar || (t_ns >= ar->start_ns && t_ns <= ar->end_ns);
    }
    std::optional<capture::TruthBoardPose> truth_board(std::uint64_t index) const override {
        const auto it = truth_board_.find(index);
        if (it == truth_board_.end()) return std::nullopt;
        return it->second;
    }

    std::optional<glm::dquat> truth_camera(std::uint64_t index) const override {
        const auto it = truth_camera_.find(index);
        if (it == truth_camera_.end()) return std::nullopt;
        return it->second;
    }

    const capture::Session& session() const { return session_; }
    double length_s() const { return double(session_.frames.back().t_ns - session_.frames.front().t_ns) * 1e-9; }

private:
    capture::Session session_;
    bool realtime_;
    std::optional<capture::KioskSessionInfo> kiosk_;
    std::vector<capture::SessionEvent> events_;
    std::vector<capture::SensorOrientation> sensors_;
    std::map<std::uint64_t, capture::TruthBoardPose> truth_board_;
    std::map<std::uint64_t, glm::dquat> truth_camera_;
    render::CameraResponse response_;
    std::size_t next_frame_ = 0, next_event_ = 0, next_sensor_ = 0;
};

// What the soak watches for growth, read from /proc and the allocator (cheap: every few seconds).
struct ProcessSample {
    long rss_kib = -1;      // VmRSS
    long threads = -1;      // Threads
    long fds = -1;          // entries of /proc/self/fd, the listing's own descriptor not counted
    long heap_kib = -1;       // malloc's bytes in use (core/memory.hpp, heap_usage)
    long heap_held_kib = -1;  // what malloc holds from the system: in use or kept free
    long gl[9] = {};        // live GL names per kind (kGlKinds), "other": every other GlName kind
};

constexpr const char* kGlKinds[9] = {"textures", "framebuffers", "buffers", "vertex_arrays", "queries",
                                     "programs", "shaders", "fences", "other"};

ProcessSample sample_process() {
    ProcessSample s;
    std::ifstream status("/proc/self/status");
    for (std::string line; std::getline(status, line);) {
        if (line.rfind("VmRSS:", 0) == 0) s.rss_kib = std::stol(line.substr(6));
        else if (line.rfind("Threads:", 0) == 0) s.threads = std::stol(line.substr(8));
    }
    std::error_code ec;
    long fds = 0;
    for (fs::directory_iterator it("/proc/self/fd", ec), end; !ec && it != end; it.increment(ec)) ++fds;
    if (!ec) s.fds = fds - 1;
    const HeapUsage heap = heap_usage();
    s.heap_kib = long(heap.in_use_bytes / 1024);
    s.heap_held_kib = long(heap.held_bytes / 1024);
    const long known[8] = {gl::GlTexture::live(), gl::GlFramebuffer::live(), gl::GlBuffer::live(), gl::GlVertexArray::live(),
                           gl::GlQuery::live(),   gl::GlProgramName::live(), gl::GlShader::live(), gl::GlFence::live()};
    long sum = 0;
    for (int k = 0; k < 8; ++k) sum += s.gl[k] = known[k];
    s.gl[8] = gl::gl_live_total() - sum;
    return s;
}

// DIR/soak.csv, a row at a time and flushed: a soak cut short keeps what it measured.
class SoakLog {
public:
    explicit SoakLog(const fs::path& path) : path_(path), file_(path) {
        if (!file_) throw InputError(path.string() + ": cannot write the soak log");
        file_ << "pass,kind,wall_s,rss_kib,heap_kib,heap_held_kib,fds,threads,gl_total";
        for (const char* k : kGlKinds) file_ << ",gl_" << k;
        file_ << ",frames,frame_median_ms,frame_p99_ms\n";
        file_.flush();
    }
    // kind: "start" (the display open, before the first pass), "during" or "pass" (after the pass,
    // with its frame times).
    ProcessSample write(int pass, const char* kind, double wall_s, const json* summary = nullptr) {
        const ProcessSample p = sample_process();
        long total = 0;
        for (long n : p.gl) total += n;
        char line[256];
        std::snprintf(line, sizeof line, "%d,%s,%.1f,%ld,%ld,%ld,%ld,%ld,%ld", pass, kind, wall_s, p.rss_kib, p.heap_kib,
                      p.heap_held_kib, p.fds, p.threads, total);
        file_ << line;
        for (long n : p.gl) file_ << ',' << n;
        if (summary) {
            const json& f = (*summary)["frame_ms"];
            std::snprintf(line, sizeof line, ",%lld,%.3f,%.3f", f["frames"].get<long long>(), f["median"].get<double>(),
                          f["p99"].get<double>());
            file_ << line << "\n";
        } else {
            file_ << ",,,\n";
        }
        file_.flush();
        if (!file_) throw RuntimeError(path_.string() + ": writing the soak log failed");
        return p;
    }

private:
    fs::path path_;
    std::ofstream file_;
};

// One replay of the session: the kiosk loop from its start, summary.json written.
json replay_pass(const ReplayOptions& o, KioskOptions k, const std::function<void(const std::string&)>& log) {
    ReplaySource source(o.session, o.realtime);
    // A replay into the directory of an earlier one: its frames go, so that OUT/frames holds this
    // run's only (the files are the replay's own: NNNNN_STATE_....png).
    std::error_code ec;
    // And its summary, frame log and captured map: a replay that fails must not leave an earlier
    // one's summary.json beside its own frames, for a script to read as this run's success.
    for (const char* name : {"summary.json", "frames.csv", kSceneEnv, kSceneCoverage}) fs::remove(o.out / name, ec);
    if (fs::is_directory(o.out / "frames", ec))
        for (const fs::directory_entry& e : fs::directory_iterator(o.out / "frames", ec))
            if (e.path().extension() == ".png" && e.path().filename().string().find('_') == 5) fs::remove(e.path(), ec);
    k.maps_dir = o.out;
    k.frames_dir = o.out / "frames";
    k.frame_log = o.out / "frames.csv";
    if (k.progress) {
        const double length = source.length_s();
        k.progress = [length, inner = k.progress](double t_s, double) { inner(std::min(t_s, length), length); };
    }
    if (o.faults.gl_lost_at_s) k.fault_gl_lost_at_s = o.faults.gl_lost_at_s;
    FaultInjectingSource faulty(source, o.faults, log);
    KioskResult r = o.faults.empty() ? run_kiosk(source, k, log) : run_kiosk(faulty, k, log);
    json& summary = r.summary;
    summary["session"] = fs::absolute(o.session).string();
    summary["allocator"] = allocator_name();  // jemalloc in a kiosk, glibc where it is not installed
    summary["env_error"] = json();
    summary["irradiance_error"] = json();
    if (r.capture && r.capture->truth_error) summary["env_error"] = r.capture->truth_error->weighted_relative_rms;
    if (r.env && source.session().has_truth) {
        // The irradiance the object was lit with against the one the true room gives, both made
        // the same way (the convolution engine at 1 %), compared at the truth's size.
        const HdrImage truth = load_exr(capture::truth_env_path(source.session())).image;
        convolution::Options co;
        co.tolerance = 0.01;
        co.threads = o.kiosk.threads;
        const render::Material matte = render::parse_material("matte");
        const render::ShadingMaps ours = render::convolve_maps(*r.env, matte, co);
        const render::ShadingMaps theirs = render::convolve_maps(truth, matte, co);
        summary["irradiance_error"] = compare_maps(*ours.irradiance, *theirs.irradiance).weighted_relative_rms;
    }
    write_text_atomically(o.out / "summary.json", summary.dump(2) + "\n");
    return summary;
}

}  // namespace

json run_replay(const ReplayOptions& o, const std::function<void(const std::string&)>& log) {
    if (o.loop_for_s <= 0 && o.repeat <= 0) return replay_pass(o, o.kiosk, log);

    // Soak: one display and context for every pass, so what a pass leaves behind in GL (and in
    // the driver) adds up in this process.
    using Clock = std::chrono::steady_clock;
    const Clock::time_point start = Clock::now();
    const auto wall_s = [&] { return std::chrono::duration<double>(Clock::now() - start).count(); };
    std::error_code ec;
    fs::create_directories(o.out, ec);
    if (ec) throw InputError(o.out.string() + ": cannot create it: " + ec.message());
    std::vector<gl::DisplayAttempt> attempts;
    const std::unique_ptr<gl::Display> display = gl::open_display(display_config_of(o.kiosk.config), &attempts);
    for (const gl::DisplayAttempt& a : attempts)
        log(std::string("display ") + gl::display_kind_name(a.kind) + ": " + (a.ok ? "opened " : "not opened: ") + a.detail);
    SoakLog soak(o.out / "soak.csv");
    soak.write(0, "start", wall_s());
    json summary;
    for (int pass = 1; o.repeat > 0 ? pass <= o.repeat : wall_s() < o.loop_for_s; ++pass) {
        KioskOptions k = o.kiosk;
        k.display = display.get();
        double next_sample_s = wall_s() + o.sample_every_s;
        k.progress = [&, pass, inner = o.kiosk.progress](double t_s, double end_s) {
            if (inner) inner(t_s, end_s);
            if (o.sample_every_s > 0 && wall_s() >= next_sample_s) {
                soak.write(pass, "during", wall_s());
                next_sample_s = wall_s() + o.sample_every_s;
            }
        };
        summary = replay_pass(o, std::move(k), log);
        // What the live kiosk does when a visit ends (run_kiosk, on entering ATTRACT): a pass
        // starts in ATTRACT, so without this the next purge came only with the next pass's AR and
        // the row below counted the pass's freed pages still held.
        return_freed_memory();
        const ProcessSample p = soak.write(pass, "pass", wall_s(), &summary);
        std::ostringstream line;
        line << "soak pass " << pass << " done at " << long(wall_s()) << " s: rss " << p.rss_kib << " KiB, heap "
             << p.heap_kib << " KiB in use (" << p.heap_held_kib << " KiB held), fds " << p.fds << ", threads " << p.threads << ", GL objects "
             << gl::gl_live_total() << ", frame median " << summary["frame_ms"]["median"].get<double>() << " ms, p99 "
             << summary["frame_ms"]["p99"].get<double>() << " ms";
        log(line.str());
    }
    return summary;
}

}  // namespace glint::ui
