// libFuzzer target for Wavefront OBJ models (appliance/render/mesh.hpp load_obj): one input is
// split at a line "#---#" into model.obj and the MTL file it may name (lib.mtl), written into a
// scratch directory in /dev/shm. Checks, besides memory safety under ASan and UBSan: a refused
// file is an InputError and nothing else; an accepted mesh keeps the invariants the renderer
// relies on (fuzz_mesh_checks.hpp) and its usemtl parts index its materials.
#include <cstddef>
#include <cstdint>

#include "appliance/core/errors.hpp"
#include "appliance/render/mesh.hpp"
#include "tests/fuzz/fuzz_mesh_checks.hpp"
#include "tests/fuzz/fuzz_support.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace glint;
    const auto& dir = fuzz::scratch_dir("obj");
    fuzz::clear_dir(dir);
    const auto pieces = fuzz::split(fuzz::as_text(data, size), "\n#---#\n");
    fuzz::write_file(dir / "model.obj", pieces[0]);
    if (pieces.size() > 1) fuzz::write_file(dir / "lib.mtl", pieces[1]);
    render::Mesh mesh;
    try {
        mesh = render::load_obj(dir / "model.obj");
    } catch (const InputError&) {
        return 0;
    }
    fuzz::check_mesh(mesh);
    render::normalise_to_unit_sphere(mesh);  // as load_model does: still finite
    fuzz::check_mesh(mesh);
    for (const auto& part : mesh.parts)
        fuzz::check(mesh.obj_materials.empty() || std::size_t(part.material) < mesh.obj_materials.size());
    return 0;
}
