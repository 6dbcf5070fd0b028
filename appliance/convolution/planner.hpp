// The planner: for each wanted map, the method, input level, output size and
// cut-off whose predicted error is within the tolerance at the least predicted
// cost ("model only what the scene needs", DESIGN.md).
#pragma once

#include <vector>

#include "appliance/convolution/convolution.hpp"
#include "appliance/convolution/methods.hpp"

namespace glint::convolution {

// Tunables of the error model, named so that tests and docs can refer to them.
struct PlannerModel {
    // Reading a level whose texels are h rad apart instead of the input is a
    // midpoint rule over each coarse texel: for a lobe exp(-n a^2 / 2) its
    // relative error scales as h^2 n (second derivative over value; 1/24 for a
    // smooth map). Edges inside a coarse texel and the kink of the clamped
    // cosine at the horizon make it larger: measured worst texels on the test
    // maps reach ~1.7 h^2 n and the weighted RMS ~0.1 h^2 n (docs/convolution.md).
    // The coefficient bounds the worst texel, so the level share of tau holds
    // for the RMS with a wide margin and the worst texel stays within a few tau.
    double level_error_coefficient = 0.5;
    // Bilinear lookup of an output map with texel spacing h: (h^2 / 8) * n.
    double output_error_coefficient = 1.0 / 8.0;
    // Shares of the tolerance.
    double level_share = 0.5;
    double output_share = 0.25;
    double texel_cut_share = 0.5;   // per-texel bound on the cut-off error
    double first_cut_energy = 0.3;  // first cone drops this fraction of tau of the lobe
    double bright_contrast = 16.0;  // texels brighter than this x mean are summed exactly
    int max_bright_texels = 1024;
};

struct EnvironmentShape {
    Size input;
    std::vector<Size> cone_levels;  // pyramid of the remainder after the bright split
    std::vector<Size> mip_levels;   // pyramid of the full map (mipmap baseline)
};

// Lobe width in radians of cos^n (about 1/sqrt(n)); the hemisphere for n <= 1.
double lobe_width(double shininess);

// Output size that follows the lobe when the user did not fix one.
Size lobe_output_size(double shininess, double tolerance, Size input, const PlannerModel& model);

// The plan for one map under the given options.
MapPlan plan_map(const MapRequest& request, const Options& options, const EnvironmentShape& env,
                 const PlannerModel& model);

// ConeSettings that realise a cone plan.
ConeSettings cone_settings(double tolerance, const PlannerModel& model);

// SH order for shininess n whose kernel tail is negligible against tolerance.
int sh_order_for(double shininess, double tolerance);

}  // namespace glint::convolution
