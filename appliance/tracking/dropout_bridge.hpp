// Holding the pose through short detection dropouts with the orientation sensor (docs/tracking.md
// "Dropouts"). The board lies still on the table, so while it is seen its orientation in the
// sensor's world frame is known: world_from_board = world_from_sensor(t0) * sensor_from_camera *
// camera_from_board(t0). Without detection the camera's rotation comes from the sensor:
//   camera_from_board(t).rotation = (world_from_sensor(t) * sensor_from_camera)^-1 * world_from_board
// and the camera's position relative to the board is held (a hand-held viewer turns far more than
// it moves in half a second), so the translation turns with the rotation. For `hold_s` (0.5 s)
// the pose is fully visible, then the visibility falls linearly to 0 over `fade_s` (0.25 s).
// Orientation samples are plain (time, world_from_sensor) values: the app reads the sensor.
#pragma once

#include <deque>
#include <optional>

#include "appliance/tracking/camera.hpp"

namespace glint::tracking {

struct OrientationSample {
    double t = 0;                          // seconds, the camera frames' clock
    glm::dquat world_from_sensor{1, 0, 0, 0};
};

struct BridgedPose {
    Pose pose;
    double visibility = 0;  // 1 .. 0
    bool from_sensor = false;  // false: held without a sensor
};

class DropoutBridge {
public:
    // sensor_from_camera: the mounting, taking OpenCV camera-frame vectors to the sensor frame.
    explicit DropoutBridge(const glm::dquat& sensor_from_camera, double hold_s = 0.5, double fade_s = 0.25);

    void add_orientation(const OrientationSample& sample);  // in time order
    void on_detection(double t, const Pose& camera_from_board);
    // The pose at time t after the last detection; nullopt when there was none or it has faded.
    std::optional<BridgedPose> bridge(double t) const;
    // The sensor's world_from_sensor at t (slerp between samples), nullopt outside their span.
    std::optional<glm::dquat> orientation_at(double t) const;

private:
    glm::dquat sensor_from_camera_;
    double hold_s_, fade_s_;
    std::deque<OrientationSample> samples_;
    std::optional<double> last_t_;
    Pose last_pose_;
    std::optional<glm::dquat> world_from_camera_at_last_;
};

}  // namespace glint::tracking
