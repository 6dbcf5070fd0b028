// RAII for GL object names: move-only, deleted with the right call when they
// go out of scope, so a cancelled job or an exception leaks nothing. Create
// and destroy them with the owning context current.
//
// Each kind keeps a process-wide count of its live names (`GlName<Traits>::live()`, and
// `gl_live_total()` over every kind, those declared elsewhere included): the soak benchmark
// (`glint replay --loop-for`, docs/kiosk.md "Soak") reads them to see GL objects that are never
// deleted. Names made with raw glGen* calls outside these wrappers are not counted.
#pragma once

#include <GLES3/gl3.h>

#include <atomic>
#include <utility>

namespace glint::gl {

namespace detail {
// Relaxed atomics: objects are made on the frame thread and on workers' contexts (LiveMaps).
inline std::atomic<long> live_total{0};
}  // namespace detail

// Live GL names held by every wrapper of this file (all kinds, fences included).
inline long gl_live_total() { return detail::live_total.load(std::memory_order_relaxed); }

template <typename Traits>
class GlName {
public:
    GlName() = default;
    // Generates a new name (glGen* / glCreate*).
    static GlName create() { return GlName(Traits::create()); }
    explicit GlName(GLuint id) : id_(id) { count(id_, +1); }
    GlName(GlName&& other) noexcept : id_(std::exchange(other.id_, 0)) {}
    GlName& operator=(GlName&& other) noexcept {
        if (this != &other) {
            reset();
            id_ = std::exchange(other.id_, 0);
        }
        return *this;
    }
    GlName(const GlName&) = delete;
    GlName& operator=(const GlName&) = delete;
    ~GlName() { reset(); }

    GLuint id() const { return id_; }
    explicit operator bool() const { return id_ != 0; }
    void reset() {
        if (id_ != 0) {
            Traits::destroy(id_);
            count(id_, -1);
        }
        id_ = 0;
    }
    // Names of this kind alive in the process now.
    static long live() { return live_.load(std::memory_order_relaxed); }

private:
    static void count(GLuint id, long delta) {
        if (id == 0) return;
        live_.fetch_add(delta, std::memory_order_relaxed);
        detail::live_total.fetch_add(delta, std::memory_order_relaxed);
    }
    static inline std::atomic<long> live_{0};
    GLuint id_ = 0;
};

struct TextureTraits {
    static GLuint create() { GLuint id = 0; glGenTextures(1, &id); return id; }
    static void destroy(GLuint id) { glDeleteTextures(1, &id); }
};
struct FramebufferTraits {
    static GLuint create() { GLuint id = 0; glGenFramebuffers(1, &id); return id; }
    static void destroy(GLuint id) { glDeleteFramebuffers(1, &id); }
};
struct BufferTraits {
    static GLuint create() { GLuint id = 0; glGenBuffers(1, &id); return id; }
    static void destroy(GLuint id) { glDeleteBuffers(1, &id); }
};
struct VertexArrayTraits {
    static GLuint create() { GLuint id = 0; glGenVertexArrays(1, &id); return id; }
    static void destroy(GLuint id) { glDeleteVertexArrays(1, &id); }
};
struct QueryTraits {
    static GLuint create() { GLuint id = 0; glGenQueries(1, &id); return id; }
    static void destroy(GLuint id) { glDeleteQueries(1, &id); }
};
struct ProgramTraits {
    static GLuint create() { return glCreateProgram(); }
    static void destroy(GLuint id) { glDeleteProgram(id); }
};
struct ShaderTraits {
    static GLuint create() { return 0; }  // made with glCreateShader(type): see gl_program.cpp
    static void destroy(GLuint id) { glDeleteShader(id); }
};

using GlTexture = GlName<TextureTraits>;
using GlFramebuffer = GlName<FramebufferTraits>;
using GlBuffer = GlName<BufferTraits>;
using GlVertexArray = GlName<VertexArrayTraits>;
using GlQuery = GlName<QueryTraits>;
using GlProgramName = GlName<ProgramTraits>;
using GlShader = GlName<ShaderTraits>;

// A GL fence (sync object), deleted with glDeleteSync.
class GlFence {
public:
    GlFence() = default;
    static GlFence insert() { return GlFence(glFenceSync(GL_SYNC_GPU_COMMANDS_COMPLETE, 0)); }
    static long live() { return live_.load(std::memory_order_relaxed); }
    GlFence(GlFence&& o) noexcept : sync_(std::exchange(o.sync_, nullptr)) {}
    GlFence& operator=(GlFence&& o) noexcept {
        if (this != &o) {
            reset();
            sync_ = std::exchange(o.sync_, nullptr);
        }
        return *this;
    }
    GlFence(const GlFence&) = delete;
    GlFence& operator=(const GlFence&) = delete;
    ~GlFence() { reset(); }
    // Blocks until the GPU has passed the fence (flushes first).
    void wait() const {
        if (sync_) glClientWaitSync(sync_, GL_SYNC_FLUSH_COMMANDS_BIT, GLuint64(-1));
    }
    bool signalled() const {
        GLint value = GL_UNSIGNALED;
        if (sync_) glGetSynciv(sync_, GL_SYNC_STATUS, 1, nullptr, &value);
        return value == GL_SIGNALED;
    }
    void reset() {
        if (sync_) {
            glDeleteSync(sync_);
            count(-1);
        }
        sync_ = nullptr;
    }

private:
    explicit GlFence(GLsync s) : sync_(s) {
        if (sync_) count(+1);
    }
    static void count(long delta) {
        live_.fetch_add(delta, std::memory_order_relaxed);
        detail::live_total.fetch_add(delta, std::memory_order_relaxed);
    }
    static inline std::atomic<long> live_{0};
    GLsync sync_ = nullptr;
};

}  // namespace glint::gl
