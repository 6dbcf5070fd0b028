// `glint bake-ao MODEL`: per-vertex ambient occlusion of a model file, baked with Embree and
// stored beside it as MODEL.ao, where `glint render --model MODEL` finds it (docs/render.md,
// "Ambient occlusion").
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>

#include "appliance/app/cli_util.hpp"
#include "appliance/app/commands.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/progress.hpp"
#include "appliance/render/ao_bake.hpp"
#include "appliance/render/ao_file.hpp"
#include "appliance/render/mesh.hpp"

namespace glint::app {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

struct BakeArgs {
    std::string model;
    std::string out;
    int rays = 256;
    double max_distance = 2.0;  // no limit (ao_bake.hpp)
    int threads = 0;
};

int run_bake_ao(const BakeArgs& args) {
    if (!render::model_is_file(args.model))
        throw InputError("bake-ao " + args.model + ": the built-in models need no file (glint render bakes the "
                         "teapot at start; the sphere has ao = 1); give an .obj, .gltf or .glb file");
    if (!(args.max_distance > 0 && args.max_distance <= 100))
        throw InputError("--max-distance: must be in (0, 100] (times the model's bounding radius)");
    const fs::path out = args.out.empty() ? render::ao_path_for(args.model) : fs::path(args.out);
    if (!fs::is_directory(fs::absolute(out).parent_path()))
        throw InputError("--out " + out.string() + ": the directory " + fs::absolute(out).parent_path().string() +
                         " does not exist");
    // The checksum first: the bake must describe the bytes it was made from.
    std::uint64_t bytes = 0;
    const std::uint64_t checksum = render::file_checksum(args.model, &bytes);
    const render::Mesh mesh = render::load_model(args.model, "bake-ao");

    const auto start = Clock::now();
    render::AoBakeOptions options;
    options.rays = args.rays;
    options.max_distance_relative = args.max_distance;
    options.threads = args.threads;
    options.progress = progress_callback("baking ambient occlusion (vertices)");
    render::AoFile file;
    file.ao = render::bake_ambient_occlusion(mesh, options);
    const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
    file.model_name = fs::path(args.model).filename().string();
    file.model_bytes = bytes;
    file.model_checksum = checksum;
    file.rays = args.rays;
    file.max_distance_relative = args.max_distance;
    render::save_ao_file(out, file);

    double sum = 0, lo = 1;
    for (float a : file.ao) {
        sum += a;
        lo = std::min(lo, double(a));
    }
    std::printf("%zu vertices, %zu triangles, %d rays each, max distance %g radius: %.2f s (%.3g Mrays/s)\n",
                mesh.positions.size(), mesh.triangle_count(), args.rays, args.max_distance, seconds,
                double(mesh.positions.size()) * args.rays / seconds * 1e-6);
    std::printf("ao: mean %.4f, min %.4f\nwrote %s\n", sum / double(file.ao.size()), lo, out.string().c_str());
    if (!args.out.empty() && fs::absolute(out) != fs::absolute(render::ao_path_for(args.model)))
        std::printf("note: glint render looks for %s\n", render::ao_path_for(args.model).string().c_str());
    return 0;
}

}  // namespace

Command add_bake_ao_command(CLI::App& app) {
    auto args = std::make_shared<BakeArgs>();
    CLI::App* cmd = app.add_subcommand("bake-ao", std::string(command_summary("bake-ao").summary));
    cmd->add_option("model", args->model, "The model: an .obj, .gltf or .glb file")->required();
    cmd->add_option("--out", args->out, "Where to write (default MODEL.ao, where glint render looks for it)");
    cmd->add_option("--rays", args->rays, "Cosine-weighted rays per vertex")
        ->check(CLI::Range(1, 1 << 20))
        ->capture_default_str();
    cmd->add_option("--max-distance", args->max_distance,
                    "Hits farther than this times the model's bounding radius do not occlude (2, the diameter: no limit)")
        ->capture_default_str();
    cmd->add_option("--threads", args->threads, "Worker threads; 0 = all cores")
        ->check(non_negative_number())
        ->capture_default_str();
    return {cmd, [args] { return run_bake_ao(*args); }};
}

}  // namespace glint::app
