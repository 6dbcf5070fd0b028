#include "appliance/gl/gl_program.hpp"

#include <sstream>

#include "appliance/core/errors.hpp"
#include "appliance/gl/gl_context.hpp"
#include "appliance/gl/shader_sources.hpp"

namespace glint::gl {
namespace {

std::string_view find_source(std::string_view name) {
    for (const ShaderSource& s : shader_sources())
        if (s.name == name) return s.text;
    throw RuntimeError("shader \"" + std::string(name) + "\" is not in shaders/ (not embedded)");
}

void expand(std::string_view name, std::vector<std::string_view>& stack, std::string& out) {
    for (std::string_view open : stack)
        if (open == name) throw RuntimeError("shaders/" + std::string(name) + " includes itself");
    stack.push_back(name);
    std::istringstream lines{std::string(find_source(name))};
    std::string line;
    while (std::getline(lines, line)) {
        const std::string_view l(line);
        const std::size_t at = l.find("#include \"");
        if (at != std::string_view::npos && l.substr(0, at).find_first_not_of(" \t") == std::string_view::npos) {
            const std::size_t end = l.find('"', at + 10);
            if (end == std::string_view::npos)
                throw RuntimeError("shaders/" + std::string(name) + ": malformed #include: " + line);
            const std::string_view included = l.substr(at + 10, end - at - 10);
            std::string body;
            expand(included, stack, body);
            // An included file has no #version line of its own.
            out += body;
            continue;
        }
        out += line;
        out += '\n';
    }
    stack.pop_back();
}

GlShader compile(GLenum type, std::string_view name, const std::string& text) {
    GlShader shader(glCreateShader(type));
    const char* src = text.c_str();
    glShaderSource(shader.id(), 1, &src, nullptr);
    glCompileShader(shader.id());
    GLint ok = GL_FALSE;
    glGetShaderiv(shader.id(), GL_COMPILE_STATUS, &ok);
    if (!ok) {
        GLint length = 0;
        glGetShaderiv(shader.id(), GL_INFO_LOG_LENGTH, &length);
        std::string log(std::size_t(std::max(length, 1)), '\0');
        glGetShaderInfoLog(shader.id(), length, nullptr, log.data());
        throw RuntimeError("shaders/" + std::string(name) + " does not compile: " + log.c_str());
    }
    return shader;
}

}  // namespace

std::string shader_text(std::string_view name, const std::vector<std::string>& defines) {
    std::vector<std::string_view> stack;
    std::string body;
    expand(name, stack, body);
    if (body.rfind("#version", 0) != 0)
        throw RuntimeError("shaders/" + std::string(name) + " must start with its #version line");
    const std::size_t eol = body.find('\n');
    std::string text = body.substr(0, eol + 1);
    for (const std::string& d : defines) text += "#define " + d + "\n";
    text += body.substr(eol + 1);
    return text;
}

GlProgram::GlProgram(std::string_view vertex, std::string_view fragment, const std::vector<std::string>& defines)
    : program_(GlProgramName::create()), label_(std::string(vertex) + " + " + std::string(fragment)) {
    const GlShader vs = compile(GL_VERTEX_SHADER, vertex, shader_text(vertex, defines));
    const GlShader fs = compile(GL_FRAGMENT_SHADER, fragment, shader_text(fragment, defines));
    glAttachShader(program_.id(), vs.id());
    glAttachShader(program_.id(), fs.id());
    glLinkProgram(program_.id());
    GLint ok = GL_FALSE;
    glGetProgramiv(program_.id(), GL_LINK_STATUS, &ok);
    if (!ok) {
        GLint length = 0;
        glGetProgramiv(program_.id(), GL_INFO_LOG_LENGTH, &length);
        std::string log(std::size_t(std::max(length, 1)), '\0');
        glGetProgramInfoLog(program_.id(), length, nullptr, log.data());
        throw RuntimeError("shaders " + label_ + " do not link: " + log.c_str());
    }
    glDetachShader(program_.id(), vs.id());
    glDetachShader(program_.id(), fs.id());
    check_gl(("building the program " + label_).c_str());
}

}  // namespace glint::gl
