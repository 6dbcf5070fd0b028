// One policy for the GPU in every command (`--engine cpu|gpu|auto`):
//   cpu   never opens GL;
//   gpu   must get a context and the engine's capabilities, or the command fails (exit 1) with one
//         line saying why: an explicit choice is never silently replaced;
//   auto  (the default) uses a hardware GPU when there is one; otherwise, or when the context or the
//         engine cannot be had, it runs on the CPU and says why in one line on stderr. A software
//         rasteriser (Mesa llvmpipe) counts as no GPU: it emulates one on the same CPU cores the CPU
//         engine uses, and is slower at the same work.
// The command owns the display and the context and hands the context to the library; libraries
// never create a display.
#pragma once

#include <CLI/CLI.hpp>
#include <memory>
#include <string>

#include "appliance/gl/gl_context.hpp"

namespace glint::app {

enum class EngineChoice { Auto, Cpu, Gpu };

// Adds `--engine cpu|gpu|auto` (validated by CLI11) to `command`; `gpu_does` says what the GPU runs.
void add_engine_option(CLI::App& command, EngineChoice& choice, const std::string& gpu_does);

// The GL context a command runs its GPU engine on, or none (then the CPU engine runs).
class GpuChoice {
public:
    // Opens a surfaceless EGL context as `choice` asks (see the file comment). `what` names the
    // work for the messages, e.g. "convolution".
    GpuChoice(EngineChoice choice, std::string what);
    GpuChoice(GpuChoice&&) = default;
    ~GpuChoice();

    // The context, or nullptr when the CPU runs.
    const gl::GlContext* context() const { return context_.get(); }
    // The engine could not be made on this context (e.g. no float render targets): with
    // --engine gpu throws RuntimeError naming `why`; with auto says why on stderr and drops the
    // context, so the CPU runs.
    void give_up(const std::string& why);

private:
    EngineChoice choice_;
    std::string what_;
    std::unique_ptr<gl::EglDisplay> display_;
    std::unique_ptr<gl::GlContext> context_;
};

}  // namespace glint::app
