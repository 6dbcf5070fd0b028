// libFuzzer target for glTF 2.0 models (appliance/render/mesh.hpp load_gltf, through Debian's
// TinyGLTF): an input that starts with the binary magic "glTF" is written as model.glb, any other
// as model.gltf (JSON; its buffers as data: URIs), into a scratch directory in /dev/shm. Checks,
// besides memory safety under ASan and UBSan (TinyGLTF itself is Debian's build, not
// instrumented; our reader of its accessors is): a refused file is an InputError and nothing
// else; an accepted mesh keeps the invariants the renderer relies on and its parts index its
// materials.
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "appliance/core/errors.hpp"
#include "appliance/render/mesh.hpp"
#include "tests/fuzz/fuzz_mesh_checks.hpp"
#include "tests/fuzz/fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace glint;
    const auto& dir = fuzz::scratch_dir("gltf");
    fuzz::clear_dir(dir);
    const bool binary = size >= 4 && std::memcmp(data, "glTF", 4) == 0;
    const auto file = dir / (binary ? "model.glb" : "model.gltf");
    fuzz::write_file(file, fuzz::as_text(data, size));
    render::Mesh mesh;
    try {
        mesh = render::load_gltf(file);
    } catch (const InputError&) {
        return 0;
    }
    fuzz::check_mesh(mesh);
    render::normalise_to_unit_sphere(mesh);  // as load_model does: still finite
    fuzz::check_mesh(mesh);
    for (const auto& part : mesh.parts) fuzz::check(std::size_t(part.material) < mesh.materials.size());
    return 0;
}
