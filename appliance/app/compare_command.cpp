// `glint compare A.exr REFERENCE.exr`: the error metrics of docs/conventions.md,
// so test engineers can compare any two maps the way the tests and benchmarks do.
#include <cstdio>
#include <memory>

#include "appliance/app/commands.hpp"
#include "appliance/core/error_metrics.hpp"
#include "appliance/core/exr_io.hpp"

namespace glint::app {

Command add_compare_command(CLI::App& app) {
    struct Args {
        std::string approx, reference;
    };
    auto args = std::make_shared<Args>();
    CLI::App* cmd = app.add_subcommand(
        "compare", "Error of a map against a reference map (weighted relative RMS, worst texel, "
                   "mean/max absolute percentage); a map of another size is resampled bilinearly");
    cmd->add_option("map", args->approx, "Map to judge (OpenEXR)")->required();
    cmd->add_option("reference", args->reference, "Reference map (OpenEXR)")->required();
    return {cmd, [args] {
                const HdrImage a = load_exr(args->approx).image;
                const HdrImage b = load_exr(args->reference).image;
                const MapError e = compare_maps(a, b);
                std::printf("weighted_rel_rms %.6e\nworst_texel %.6e\nmean_abs_percent %.6f\nmax_abs_percent %.6f\n",
                            e.weighted_relative_rms, e.worst_texel, e.mean_abs_percent, e.max_abs_percent);
                return 0;
            }};
}

}  // namespace glint::app
