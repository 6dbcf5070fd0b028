// The virtual camera of an AR frame (docs/kiosk.md, "The AR view"): the tracked board pose and the
// camera's orientation from the sensor, turned into the renderer's camera (render/renderer.hpp).
//
// Frames: the renderer's world has the environment map's axes (docs/conventions.md: +Y up), so
// the object is lit by the room as it is; its origin is the object's centre and its unit the
// object's radius. The board (docs/tracking.md) lies on the table with +Z up; the object stands on
// the board's centre. The camera's position comes from the board pose (camera_from_board, OpenCV
// camera frame), its orientation from world_from_camera (Glint's camera frame, +Y up, -Z forward),
// so that the lighting turns with the sensor and the object stays on the marker.
#pragma once

#include <glm/gtc/quaternion.hpp>

#include "appliance/capture/camera_model.hpp"
#include "appliance/render/renderer.hpp"
#include "appliance/tracking/camera.hpp"

namespace glint::ui {

struct ArPlacement {
    double object_radius_m = 0.08;  // the object's bounding sphere, metres
    double model_bottom = -1;       // the model's lowest y in its unit-sphere frame (render::model_bottom)
};

// OpenCV's camera frame -> Glint's: C = diag(1, -1, -1), a half turn about X.
inline const glm::dquat kGlFromCv{0.0, 1.0, 0.0, 0.0};

// The calibration's intrinsics as the tracker's camera: the same numbers (both are OpenCV's model).
tracking::Camera tracking_camera(const capture::Intrinsics& intrinsics);

// The board's orientation in the world: world_from_camera x C x camera_from_board.
glm::dquat world_from_board(const glm::dquat& world_from_camera, const tracking::Pose& camera_from_board);

// The renderer's camera for the frame. The vertical field of view is the calibration's
// (2 atan(h / 2 fy)); the principal point's offset from the centre and the lens distortion are
// not applied to the virtual view (docs/kiosk.md says what that costs).
render::Camera ar_camera(const glm::dquat& world_from_camera, const tracking::Pose& camera_from_board,
                         const capture::Intrinsics& intrinsics, const ArPlacement& placement);

// The object's motion on the AR view during the camera's exposure, for its motion blur
// (render::Renderer::set_camera_match; docs/render.md, "Matching the camera"): the object's centre
// as the camera sees it at two tracked frames `dt_s` apart, on a view `view_height` pixels high
// (the virtual camera's focal length, as ar_camera: fy scaled to the view), times exposure / dt.
// Pixels, x right and y up. Zero when dt_s <= 0 or the centre is not in front of the camera in
// both; under 256 pixels long (set_camera_match's limit).
glm::dvec2 ar_motion_blur_px(const tracking::Pose& previous, const tracking::Pose& current, double dt_s, double exposure_s,
                             const capture::Intrinsics& intrinsics, int view_height, const ArPlacement& placement);

// The attract screen's camera: orbiting the object at `distance` (object radii), `elevation_deg`
// above the horizon, turned `azimuth_deg` about world +Y.
render::Camera orbit_camera(double azimuth_deg, double elevation_deg = 20, double distance = 3.5, double fov_y_deg = 40);

}  // namespace glint::ui
