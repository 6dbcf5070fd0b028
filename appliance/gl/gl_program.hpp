// Shader programs from the embedded sources of shaders/. A source may say
// `#include "name.glsl"` on a line of its own (another file of shaders/);
// `defines` are inserted after the #version line. Compile and link errors
// throw RuntimeError naming the files and quoting the driver's log.
#pragma once

#include <GLES3/gl3.h>

#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "appliance/gl/gl_objects.hpp"

namespace glint::gl {

// The text of shaders/<name> with its #includes expanded and the defines
// inserted; throws RuntimeError for an unknown name or an include cycle.
std::string shader_text(std::string_view name, const std::vector<std::string>& defines = {});

class GlProgram {
public:
    GlProgram() = default;
    GlProgram(std::string_view vertex, std::string_view fragment, const std::vector<std::string>& defines = {});
    GLuint id() const { return program_.id(); }
    void use() const { glUseProgram(program_.id()); }
    // Location of a uniform, -1 if the program does not use it (the driver may
    // have removed it), as GL itself answers.
    GLint uniform(const char* name) const { return glGetUniformLocation(program_.id(), name); }
    const std::string& label() const { return label_; }

private:
    GlProgramName program_;
    std::string label_;
};

}  // namespace glint::gl
