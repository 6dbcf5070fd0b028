// The GPU policy of every command (gpu_policy.hpp).
#include "appliance/app/gpu_policy.hpp"

#include <cstdio>
#include <filesystem>

#include "appliance/core/errors.hpp"

namespace glint::app {
namespace {

// A DRM render node is how Linux exposes a GPU to unprivileged rendering; without one, EGL can
// only offer a software rasteriser, and probing it would cost the start-up time of loading Mesa.
bool has_render_node() {
    std::error_code ec;
    for (const auto& entry : std::filesystem::directory_iterator("/dev/dri", ec))
        if (entry.path().filename().string().rfind("renderD", 0) == 0) return true;
    return false;
}

bool is_software_renderer(const std::string& renderer) {
    for (const char* name : {"llvmpipe", "softpipe", "swrast", "lavapipe"})
        if (renderer.find(name) != std::string::npos) return true;
    return false;
}

}  // namespace

void add_engine_option(CLI::App& command, EngineChoice& choice, const std::string& gpu_does) {
    command
        .add_option_function<std::string>(
            "--engine",
            [&choice](const std::string& name) {
                choice = name == "cpu" ? EngineChoice::Cpu : name == "gpu" ? EngineChoice::Gpu : EngineChoice::Auto;
            },
            "cpu, gpu or auto. gpu: " + gpu_does +
                " on an EGL context, and fail when none can be had; auto: the GPU when there is a hardware one, else "
                "the CPU, saying why")
        ->check(CLI::IsMember({"auto", "cpu", "gpu"}))
        ->default_str("auto");
}

GpuChoice::GpuChoice(EngineChoice choice, std::string what) : choice_(choice), what_(std::move(what)) {
    if (choice_ == EngineChoice::Cpu) return;
    if (choice_ == EngineChoice::Auto && !has_render_node()) {
        std::fprintf(stderr, "glint: engine auto: no GPU (no /dev/dri/renderD* device); %s runs on the CPU\n",
                     what_.c_str());
        return;
    }
    try {
        display_ = std::make_unique<gl::EglDisplay>(gl::EglDisplay::surfaceless());
        context_ = std::make_unique<gl::GlContext>(*display_);
    } catch (const RuntimeError& e) {
        context_.reset();
        display_.reset();
        give_up(e.what());
        return;
    }
    if (choice_ == EngineChoice::Auto && is_software_renderer(context_->caps().renderer)) {
        give_up("the GL renderer is " + context_->caps().renderer + ", a software rasteriser");
        return;
    }
    std::fprintf(stderr, "glint: GL: %s\n", context_->describe().c_str());
}

GpuChoice::~GpuChoice() = default;

void GpuChoice::give_up(const std::string& why) {
    if (choice_ == EngineChoice::Gpu) throw RuntimeError("--engine gpu: " + what_ + " cannot run on the GPU: " + why);
    std::fprintf(stderr, "glint: engine auto: %s; %s runs on the CPU\n", why.c_str(), what_.c_str());
    context_.reset();
    display_.reset();
}

}  // namespace glint::app
