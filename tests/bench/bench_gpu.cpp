// GPU engine benchmark (docs/gpu.md): convolution in tiles within a frame budget.
//  (a) The whole set of the CPU benchmark (irradiance + 11 shininess values at
//      the reference sizes, courtyard) by `auto` on the GPU engine against the
//      CPU engine: wall time, and error against the cached exact references
//      of tests/bench/run_convolution_bench.sh when they exist.
//  (b) A render loop of a 1280x720 frame at a 30 Hz budget that draws a
//      textured full-screen quad and a lit sphere, without and then with the
//      whole set's GPU convolution running in the frames' leftover time:
//      frame time median, p95, p99 and max, and when the convolution finished.
// Writes tests/bench/results/gpu.md, gpu_frames.csv and images/gpu_frame_times.png.
#include <GLES3/gl3.h>
#include <sys/utsname.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <zlib.h>

#include "appliance/convolution/convolution.hpp"
#include "appliance/convolution/gpu/frame_gate.hpp"
#include "appliance/convolution/gpu/gpu_engine.hpp"
#include "appliance/core/error_metrics.hpp"
#include "appliance/core/exr_io.hpp"
#include "appliance/core/memory.hpp"
#include "bench_util.hpp"
#include "appliance/core/parallel.hpp"
#include "appliance/gl/gl_context.hpp"
#include "appliance/gl/gl_objects.hpp"
#include "appliance/gl/gl_program.hpp"

using namespace glint;
using namespace glint::convolution;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

using glint::bench::fmt;
using glint::bench::machine_description;

namespace {

double ms_since(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

std::vector<MapRequest> whole_set() {
    std::vector<MapRequest> maps{MapRequest::make_irradiance()};
    maps[0].size = bench::reference_size(1);
    for (double n : bench::whole_set_shininess()) {
        std::ostringstream s;
        s << n;
        MapRequest m = MapRequest::make_phong(n, s.str());
        m.size = bench::reference_size(n);
        maps.push_back(m);
    }
    return maps;
}

double percentile(std::vector<double> v, double p) {
    if (v.empty()) return NAN;
    std::sort(v.begin(), v.end());
    const double k = p * double(v.size() - 1);
    const std::size_t lo = std::size_t(std::floor(k)), hi = std::min(v.size() - 1, lo + 1);
    return v[lo] + (k - double(lo)) * (v[hi] - v[lo]);
}

// A UV sphere: positions and normals interleaved, indexed triangles.
struct Mesh {
    gl::GlVertexArray vao;
    gl::GlBuffer vertices, indices;
    GLsizei count = 0;
};

Mesh make_sphere(int slices, int stacks) {
    std::vector<float> v;
    std::vector<GLuint> idx;
    for (int j = 0; j <= stacks; ++j)
        for (int i = 0; i <= slices; ++i) {
            const double t = M_PI * j / stacks, p = 2 * M_PI * i / slices;
            const float x = float(std::sin(t) * std::sin(p)), y = float(std::cos(t)), z = float(-std::sin(t) * std::cos(p));
            v.insert(v.end(), {x, y, z, x, y, z});
        }
    for (int j = 0; j < stacks; ++j)
        for (int i = 0; i < slices; ++i) {
            const GLuint a = GLuint(j * (slices + 1) + i), b = a + GLuint(slices + 1);
            idx.insert(idx.end(), {a, b, a + 1, a + 1, b, b + 1});
        }
    Mesh m{gl::GlVertexArray::create(), gl::GlBuffer::create(), gl::GlBuffer::create(), GLsizei(idx.size())};
    glBindVertexArray(m.vao.id());
    glBindBuffer(GL_ARRAY_BUFFER, m.vertices.id());
    glBufferData(GL_ARRAY_BUFFER, GLsizeiptr(v.size() * sizeof(float)), v.data(), GL_STATIC_DRAW);
    glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, m.indices.id());
    glBufferData(GL_ELEMENT_ARRAY_BUFFER, GLsizeiptr(idx.size() * sizeof(GLuint)), idx.data(), GL_STATIC_DRAW);
    glEnableVertexAttribArray(0);
    glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float), nullptr);
    glEnableVertexAttribArray(1);
    glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float), reinterpret_cast<void*>(3 * sizeof(float)));
    glBindVertexArray(0);
    return m;
}

// Column-major 4x4 matrices for the camera.
using Mat4 = std::array<float, 16>;

// The frame: the camera image and a lit sphere that turns; returns the GPU time (ms, CPU time around a fence).
class Scene {
public:
    Scene(const HdrImage& irradiance, const HdrImage& reflection, const HdrImage& background)
        : quad_("textured_quad.vert", "textured_quad.frag"), lit_("lit_mesh.vert", "lit_mesh.frag"),
          sphere_(make_sphere(96, 48)), empty_(gl::GlVertexArray::create()),
          irradiance_(gpu::upload_image(irradiance)), reflection_(gpu::upload_image(reflection)),
          color_(gl::GlTexture::create()), framebuffer_(gl::GlFramebuffer::create()) {
        for (GLuint t : {irradiance_.id(), reflection_.id()}) {
            glBindTexture(GL_TEXTURE_2D, t);
            glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
            glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
            glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_REPEAT);
        }
        // The "camera image": the background map at 1280x720, 8 bit.
        std::vector<unsigned char> rgba(1280 * 720 * 4);
        for (int y = 0; y < 720; ++y)
            for (int x = 0; x < 1280; ++x) {
                const Rgb c = background.at(x * background.width() / 1280, y * background.height() / 720);
                const float v[3] = {c.r, c.g, c.b};
                for (int k = 0; k < 3; ++k)
                    rgba[std::size_t((y * 1280 + x) * 4 + k)] = (unsigned char)(255.0f * std::min(1.0f, v[k] / (1.0f + v[k])));
                rgba[std::size_t((y * 1280 + x) * 4 + 3)] = 255;
            }
        camera_ = gl::GlTexture::create();
        glBindTexture(GL_TEXTURE_2D, camera_.id());
        glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, 1280, 720, 0, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data());
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
        glBindTexture(GL_TEXTURE_2D, color_.id());
        glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, 1280, 720, 0, GL_RGBA, GL_UNSIGNED_BYTE, nullptr);
        depth_ = GLuint(0);
        glGenRenderbuffers(1, &depth_);
        glBindRenderbuffer(GL_RENDERBUFFER, depth_);
        glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT24, 1280, 720);
        glBindFramebuffer(GL_FRAMEBUFFER, framebuffer_.id());
        glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, color_.id(), 0);
        glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth_);
        gl::check_gl("creating the 1280x720 frame");
    }
    ~Scene() { glDeleteRenderbuffers(1, &depth_); }

    double draw(int frame) {
        const auto start = Clock::now();
        glBindFramebuffer(GL_FRAMEBUFFER, framebuffer_.id());
        glViewport(0, 0, 1280, 720);
        glDisable(GL_SCISSOR_TEST);
        glDisable(GL_BLEND);
        glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
        glDisable(GL_DEPTH_TEST);
        quad_.use();
        glActiveTexture(GL_TEXTURE0);
        glBindTexture(GL_TEXTURE_2D, camera_.id());
        glUniform1i(quad_.uniform("u_image"), 0);
        glBindVertexArray(empty_.id());
        glDrawArrays(GL_TRIANGLES, 0, 3);
        glEnable(GL_DEPTH_TEST);
        lit_.use();
        const float a = float(frame) * 0.02f;
        const Mat4 model{std::cos(a), 0, std::sin(a), 0, 0, 1, 0, 0, -std::sin(a), 0, std::cos(a), 0, 0, 0, -3, 1};
        const float f = 1.0f / std::tan(0.5f * 1.0f), aspect = 1280.0f / 720.0f, zn = 0.1f, zf = 10.0f;
        const Mat4 projection{f / aspect, 0, 0, 0, 0, f, 0, 0, 0, 0, (zf + zn) / (zn - zf), -1, 0, 0, 2 * zf * zn / (zn - zf), 0};
        glUniformMatrix4fv(lit_.uniform("u_model"), 1, GL_FALSE, model.data());
        glUniformMatrix4fv(lit_.uniform("u_view_projection"), 1, GL_FALSE, projection.data());
        glUniform3f(lit_.uniform("u_eye"), 0, 0, 0);
        glUniform3f(lit_.uniform("u_kd"), 0.6f, 0.6f, 0.6f);
        glUniform3f(lit_.uniform("u_ks"), 0.3f, 0.3f, 0.3f);
        glActiveTexture(GL_TEXTURE0);
        glBindTexture(GL_TEXTURE_2D, irradiance_.id());
        glActiveTexture(GL_TEXTURE1);
        glBindTexture(GL_TEXTURE_2D, reflection_.id());
        glUniform1i(lit_.uniform("u_irradiance"), 0);
        glUniform1i(lit_.uniform("u_reflection"), 1);
        glBindVertexArray(sphere_.vao.id());
        glDrawElements(GL_TRIANGLES, sphere_.count, GL_UNSIGNED_INT, nullptr);
        glBindVertexArray(0);
        gl::GlFence::insert().wait();
        return ms_since(start);
    }

    // The last frame as an 8-bit RGB PNG (what a visitor would see).
    void save_png(const fs::path& path) {
        std::vector<unsigned char> rgba(1280 * 720 * 4);
        glBindFramebuffer(GL_READ_FRAMEBUFFER, framebuffer_.id());
        glReadPixels(0, 0, 1280, 720, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data());
        std::vector<unsigned char> raw;
        for (int y = 719; y >= 0; --y) {  // GL rows are bottom first
            raw.push_back(0);                // PNG filter: none
            for (int x = 0; x < 1280; ++x)
                raw.insert(raw.end(), &rgba[std::size_t((y * 1280 + x) * 4)], &rgba[std::size_t((y * 1280 + x) * 4 + 3)]);
        }
        uLongf size = compressBound(uLong(raw.size()));
        std::vector<unsigned char> z(size);
        compress2(z.data(), &size, raw.data(), uLong(raw.size()), 9);
        z.resize(size);
        std::ofstream out(path, std::ios::binary);
        const auto u32 = [&](std::uint32_t v) {
            const unsigned char b[4] = {(unsigned char)(v >> 24), (unsigned char)(v >> 16), (unsigned char)(v >> 8),
                                        (unsigned char)v};
            out.write(reinterpret_cast<const char*>(b), 4);
        };
        const auto chunk = [&](const char* type, const std::vector<unsigned char>& data) {
            u32(std::uint32_t(data.size()));
            std::vector<unsigned char> body(type, type + 4);
            body.insert(body.end(), data.begin(), data.end());
            out.write(reinterpret_cast<const char*>(body.data()), std::streamsize(body.size()));
            u32(std::uint32_t(crc32(0, body.data(), uInt(body.size()))));
        };
        out.write("\x89PNG\r\n\x1a\n", 8);
        chunk("IHDR", {0, 0, 0x05, 0x00, 0, 0, 0x02, 0xD0, 8, 2, 0, 0, 0});  // 1280 x 720, 8-bit RGB
        chunk("IDAT", z);
        chunk("IEND", {});
    }

private:
    gl::GlProgram quad_, lit_;
    Mesh sphere_;
    gl::GlVertexArray empty_;
    gl::GlTexture irradiance_, reflection_, camera_, color_;
    gl::GlFramebuffer framebuffer_;
    GLuint depth_ = 0;
};

struct LoopResult {
    std::vector<double> frame_ms, render_ms;
    double job_seconds = NAN;  // wall time from the job's start to its end
    int frames_to_finish = 0;
    gpu::TileStats tiles;
};

// Runs frames at 30 Hz; with `env`, the whole set's convolution runs on a worker
// thread (its own context, shared with this one) in each frame's leftover time.
LoopResult render_loop(gl::EglDisplay& display, gl::GlContext& main, Scene& scene, const HdrImage* env,
                       int frames_without_job, double budget_ms, double cap_ms) {
    LoopResult r;
    gpu::FrameBudgetGate gate;
    std::atomic<bool> done{env == nullptr};
    std::atomic<bool> ready{env == nullptr};
    std::thread worker;
    Clock::time_point job_start{};
    if (env) {
        job_start = Clock::now();
        worker = std::thread([&] {
            // The job's CPU parts (SH maps, the cone's bound, read-backs) must not
            // take the cores from the frame: they run at a lower priority.
            lower_this_thread_priority();
            try {
                gl::GlContext context(display, nullptr, &main);
                gpu::GpuEngine engine(context, gate, cap_ms);
                engine.prepare_programs();  // at start-up, as the appliance does
                ready = true;
                Options o;
                o.threads = 1;  // the render thread keeps the other core
                o.executor = &engine;
                convolve(*env, whole_set(), o);
                r.tiles = engine.stats();
            } catch (const gpu::JobCancelled&) {
            }
            ready = true;
            r.job_seconds = std::chrono::duration<double>(Clock::now() - job_start).count();
            done = true;
            gate.finish();
        });
    }
    while (!ready) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    auto next = Clock::now();
    for (int frame = 0; env ? !done.load() : frame < frames_without_job; ++frame) {
        const auto start = Clock::now();
        const double render = scene.draw(frame);
        const double left = budget_ms - render - 2.0;  // 2 ms for presenting and the loop itself
        if (env && left > 0) gate.run_slice(left);
        r.render_ms.push_back(render);
        r.frame_ms.push_back(ms_since(start));
        if (env && !done) r.frames_to_finish = frame + 1;
        next += std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double, std::milli>(budget_ms));
        if (next > Clock::now()) std::this_thread::sleep_until(next);
        else next = Clock::now();  // a late frame: the next one starts now
    }
    if (worker.joinable()) worker.join();
    return r;
}


}  // namespace

int main(int argc, char** argv) {
    keep_freed_memory();
    fs::path worlds = "/usr/share/blender/datafiles/studiolights/world", cache = "build/bench-cache",
             out = "tests/bench/results", images = "images";
    int frames = 150;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        auto value = [&] {
            if (i + 1 >= argc) {
                std::fprintf(stderr, "bench_gpu: %s needs a value\n", a.c_str());
                std::exit(2);
            }
            return std::string(argv[++i]);
        };
        if (a == "--help") {
            std::printf("bench_gpu [--worlds DIR] [--cache DIR] [--out DIR] [--images DIR] [--frames N]\n"
                        "GPU engine against CPU on the whole set, and a 30 Hz render loop with and without\n"
                        "the convolution. Writes DIR/gpu.md, DIR/gpu_frames.csv, IMAGES/gpu_frame_times.png.\n");
            return 0;
        } else if (a == "--worlds") worlds = value();
        else if (a == "--cache") cache = value();
        else if (a == "--out") out = value();
        else if (a == "--images") images = value();
        else if (a == "--frames") frames = std::stoi(value());
        else {
            std::fprintf(stderr, "bench_gpu: unknown argument %s (see --help)\n", a.c_str());
            return 2;
        }
    }
    const HdrImage env = load_exr(worlds / "courtyard.exr").image;
    gl::EglDisplay display = gl::EglDisplay::surfaceless();
    gl::GlContext context(display);
    std::fprintf(stderr, "bench_gpu: %s\n", context.describe().c_str());

    // (a) whole set, CPU and GPU (the GPU engine with no frame to share).
    const std::vector<MapRequest> maps = whole_set();
    Options cpu_options;
    cpu_options.threads = 2;
    auto t0 = Clock::now();
    const std::vector<MapResult> cpu = convolve(env, maps, cpu_options);
    const double cpu_s = ms_since(t0) / 1e3;
    gpu::UnlimitedGate open(50.0);
    gpu::GpuEngine engine(context, open, 50.0);
    Options gpu_options = cpu_options;
    gpu_options.executor = &engine;
    std::fprintf(stderr, "bench_gpu: whole set on the GPU engine...\n");
    t0 = Clock::now();
    const std::vector<MapResult> gpu_maps = convolve(env, maps, gpu_options);
    const double gpu_s = ms_since(t0) / 1e3;
    struct Row {
        std::string label, method;
        double cpu_s, gpu_s, gpu_vs_cpu, cpu_vs_exact, gpu_vs_exact;
    };
    std::vector<Row> rows;
    for (std::size_t k = 0; k < maps.size(); ++k) {
        const fs::path ref = cache / ("courtyard_" + (maps[k].irradiance ? std::string("irradiance") : maps[k].label) +
                                      "_" + std::to_string(maps[k].size->width) + "x" +
                                      std::to_string(maps[k].size->height) + ".exr");
        double ce = NAN, ge = NAN;
        if (fs::exists(ref)) {
            const HdrImage exact = load_exr(ref).image;
            ce = compare_maps(cpu[k].image, exact).weighted_relative_rms;
            ge = compare_maps(gpu_maps[k].image, exact).weighted_relative_rms;
        }
        rows.push_back({maps[k].label, to_string(cpu[k].plan.method), cpu[k].seconds, gpu_maps[k].seconds,
                        compare_maps(gpu_maps[k].image, cpu[k].image).weighted_relative_rms, ce, ge});
    }

    // (b) the render loop.
    Scene scene(cpu[0].image, cpu[6].image, env);  // irradiance and n = 160 shade the sphere
    std::fprintf(stderr, "bench_gpu: render loop without the convolution (%d frames)...\n", frames);
    scene.draw(0);  // warm up
    const LoopResult idle = render_loop(display, context, scene, nullptr, frames, 1000.0 / 30.0, 50.0);
    std::fprintf(stderr, "bench_gpu: render loop with the whole set's convolution...\n");
    const LoopResult busy = render_loop(display, context, scene, &env, 0, 1000.0 / 30.0, 50.0);
    fs::create_directories(out);
    fs::create_directories(images);
    scene.save_png(images / "gpu_frame.png");

    // ---- outputs ----
    {
        std::ofstream csv(out / "gpu_frames.csv");
        csv << "run,frame,frame_ms,render_ms\n";
        for (std::size_t i = 0; i < idle.frame_ms.size(); ++i)
            csv << "without," << i << ',' << idle.frame_ms[i] << ',' << idle.render_ms[i] << '\n';
        for (std::size_t i = 0; i < busy.frame_ms.size(); ++i)
            csv << "with," << i << ',' << busy.frame_ms[i] << ',' << busy.render_ms[i] << '\n';
    }
    char date[64];
    const std::time_t now = std::time(nullptr);
    std::strftime(date, sizeof date, "%Y-%m-%d %H:%M UTC", std::gmtime(&now));
    const double budget = 1000.0 / 30.0;
    std::ofstream md(out / "gpu.md");
    md << "# GPU engine: speed, parity and frame times\n\n"
       << "Generated by `tests/bench/run_gpu_bench.sh` on " << date << ", " << machine_description() << "; GL: "
       << context.describe() << ".\n\n"
       << "## (a) Whole set on courtyard (irradiance + 11 shininess values, reference sizes), `auto`\n\n"
       << "| | wall time |\n|---|---|\n"
       << "| CPU engine, 2 threads | " << fmt("%.3f s", cpu_s) << " |\n"
       << "| GPU engine (llvmpipe), tiles of at most 50 ms | " << fmt("%.2f s", gpu_s) << " |\n\n"
       << "The GPU engine runs the sums (cone first passes, annuli and bright texels; SH reconstruction); "
          "planning, the SH projection and the bounds stay on the CPU. Errors are weighted relative RMS; `exact` "
          "references from build/bench-cache (written by run_convolution_bench.sh; `nan` if missing).\n\n"
       << "| map | method | CPU s | GPU s | GPU vs CPU | CPU vs exact | GPU vs exact |\n|---|---|---|---|---|---|---|\n";
    for (const Row& r : rows)
        md << "| " << r.label << " | " << r.method << " | " << fmt("%.4f", r.cpu_s) << " | " << fmt("%.3f", r.gpu_s)
           << " | " << fmt("%.1e", r.gpu_vs_cpu) << " | " << fmt("%.1e", r.cpu_vs_exact) << " | "
           << fmt("%.1e", r.gpu_vs_exact) << " |\n";
    const auto frame_row = [&](const char* name, const LoopResult& l) {
        md << "| " << name << " | " << l.frame_ms.size() << " | " << fmt("%.1f", percentile(l.frame_ms, 0.5)) << " | "
           << fmt("%.1f", percentile(l.frame_ms, 0.95)) << " | " << fmt("%.1f", percentile(l.frame_ms, 0.99)) << " | "
           << fmt("%.1f", *std::max_element(l.frame_ms.begin(), l.frame_ms.end())) << " | "
           << fmt("%.1f", percentile(l.render_ms, 0.5)) << " |\n";
    };
    md << "\n## (b) 1280x720 frames at 30 Hz (budget " << fmt("%.1f", budget) << " ms): a textured full-screen quad "
       << "and a lit sphere (9216 triangles)\n\n"
       << "Frame time: from the frame's start to the end of its GPU work, including the convolution tiles it "
          "granted.\n\n"
       << "| run | frames | median ms | p95 ms | p99 ms | max ms | render median ms |\n|---|---|---|---|---|---|---|\n";
    frame_row("without convolution", idle);
    frame_row("with the whole set's convolution", busy);
    const double p99 = percentile(busy.frame_ms, 0.99);
    md << "\nWith the convolution running, p99 is " << fmt("%.2f", p99 / budget) << "x the budget (target <= 1.2x: "
       << (p99 <= 1.2 * budget ? "met" : "NOT met") << "). The convolution finished after "
       << busy.frames_to_finish << " frames (" << fmt("%.1f", busy.job_seconds) << " s), in " << busy.tiles.tiles
       << " tiles, the longest draw " << fmt("%.1f", busy.tiles.largest_ms) << " ms (cap 50 ms).\n\n"
       << "![frame times](../../../images/gpu_frame_times.png)\n\n"
       << "The last frame (`images/gpu_frame.png`):\n\n![frame](../../../images/gpu_frame.png)\n";
    md.close();
    const std::string plot = "gnuplot -e \"set terminal png size 900,420; set output '" +
                             (images / "gpu_frame_times.png").string() +
                             "'; set datafile separator ','; set xlabel 'frame'; set ylabel 'ms'; "
                             "set title 'Frame time at 30 Hz, 1280x720, llvmpipe'; set key top right; "
                             "plot '< grep ^without " + (out / "gpu_frames.csv").string() +
                             "' using 2:3 with lines title 'without convolution', "
                             "'< grep ^with, " + (out / "gpu_frames.csv").string() +
                             "' using 2:3 with lines title 'with the whole set convolving', " +
                             fmt("%.3f", budget) + " with lines dt 2 title 'budget', " + fmt("%.3f", 1.2 * budget) +
                             " with lines dt 3 title '1.2 x budget'\"";
    if (std::system(plot.c_str()) != 0) std::fprintf(stderr, "bench_gpu: gnuplot failed; no plot\n");
    std::printf("bench_gpu: wrote %s\n", (out / "gpu.md").c_str());
    return 0;
}
