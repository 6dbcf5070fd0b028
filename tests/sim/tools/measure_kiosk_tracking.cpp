// Prints the tracker's detection rate and pose error on the AR frames of kiosk sessions against
// their truth/board.csv (docs/capture.md "Kiosk sessions": the frame size was chosen with it).
//   glint_measure_kiosk_tracking SESSION [HIDDEN_START_NS HIDDEN_END_NS]
// (the span `glint simulate --kiosk` prints as "hidden", on the appliance clock, is left out).
#include <cstdio>
#include <exception>
#include <string>

#include "appliance/capture/session.hpp"
#include "tests/sim/kiosk_tracking.hpp"

int main(int argc, char** argv) {
    if (argc != 2 && argc != 4) {
        std::fprintf(stderr, "usage: %s SESSION [HIDDEN_START_NS HIDDEN_END_NS]\n", argv[0]);
        return 2;
    }
    try {
        {
            const int i = 1;
            const glint::capture::Session s = glint::capture::open_session(argv[i]);
            const glint::sim_test::KioskTracking m = glint::sim_test::measure_kiosk_tracking(
                s, argc == 4 ? std::stoll(argv[2]) : 0, argc == 4 ? std::stoll(argv[3]) : 0);
            using glint::sim_test::percentile;
            std::printf("%s: %dx%d, %d AR frames, %d with >= 3 markers in view; detector %d (%.1f %%), tracker %d "
                        "(%.1f %%), false %d; rotation error median %.3f p95 %.3f max %.3f deg; translation "
                        "median %.3f p95 %.3f %% of distance\n",
                        argv[i], s.calibration.intrinsics.width, s.calibration.intrinsics.height, m.ar_frames,
                        m.in_view, m.detected, 100.0 * m.detected / std::max(1, m.in_view), m.tracked,
                        100.0 * m.tracked / std::max(1, m.in_view), m.false_detections,
                        percentile(m.rotation_error_deg, 0.5), percentile(m.rotation_error_deg, 0.95),
                        percentile(m.rotation_error_deg, 1.0), 100 * percentile(m.translation_error, 0.5),
                        100 * percentile(m.translation_error, 0.95));
            std::printf("  turning < %.0f deg/s: %d in view, detector %d (%.1f %%); rotation error median %.3f p95 "
                        "%.3f max %.3f deg\n",
                        glint::sim_test::kSlowDegS, m.slow_in_view, m.slow_detected,
                        100.0 * m.slow_detected / std::max(1, m.slow_in_view),
                        percentile(m.slow_rotation_error_deg, 0.5), percentile(m.slow_rotation_error_deg, 0.95),
                        percentile(m.slow_rotation_error_deg, 1.0));
        }
    } catch (const std::exception& e) {
        std::fprintf(stderr, "ERROR: %s\n", e.what());
        return 1;
    }
    return 0;
}
