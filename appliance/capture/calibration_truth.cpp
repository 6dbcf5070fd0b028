// Calibrations to update and their error against a simulated truth (calibration_truth.hpp).
#include "appliance/capture/calibration_truth.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "appliance/capture/calibration_io.hpp"
#include "appliance/core/equirect.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/rotation.hpp"

namespace glint::capture {

CameraCalibration calibration_to_update(const std::filesystem::path& file, const Session& session) {
    return std::filesystem::exists(file) ? load_calibration(file) : session.calibration;
}

CameraCalibration truth_calibration(const Session& session) {
    if (!session.has_truth) throw InputError(session.dir.string() + ": the session has no truth/ (not simulated)");
    return load_calibration(session.dir / "truth" / "calibration.json");
}

double response_error_against_truth(const Response& estimate, const Response& truth) {
    constexpr int kFirstCode = 64, kLastCode = 250, kReferenceCode = 128;
    double worst = 0;
    for (int z = kFirstCode; z <= kLastCode; ++z) {
        const double est = estimate.inverse[std::size_t(z)] / estimate.inverse[kReferenceCode];
        const double tru = truth.inverse[std::size_t(z)] / truth.inverse[kReferenceCode];
        worst = std::max(worst, std::abs(est / tru - 1));
    }
    return worst;
}

NoiseError noise_error_against_truth(double full_well_electrons, double read_noise, const Response& response,
                                     const CameraCalibration& truth) {
    std::vector<double> ratios;
    for (int z = 64; z <= 200; ++z)
        ratios.push_back(response.inverse[std::size_t(z)] / truth.response.inverse[std::size_t(z)]);
    std::nth_element(ratios.begin(), ratios.begin() + std::ptrdiff_t(ratios.size() / 2), ratios.end());
    const double scale = ratios[ratios.size() / 2];
    return {full_well_electrons / (truth.noise_full_well_electrons / scale) - 1,
            read_noise / (truth.noise_read * scale) - 1};
}

double mounting_error_deg(const glm::dquat& estimate, const glm::dquat& truth) {
    return angle_between(estimate, truth) * 180 / kPi;
}

}  // namespace glint::capture
