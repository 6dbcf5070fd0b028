# glint_ui: the kiosk program (docs/kiosk.md): the visitor flow, the frame scheduler, the capture
# job, the AR view, the replay.
add_library(glint_ui STATIC kiosk_flow.cpp frame_scheduler.cpp capture_job.cpp ar_camera.cpp image_quad.cpp kiosk_loop.cpp kiosk_replay.cpp
            device_watch.cpp fault_injection.cpp lens_undistortion.cpp)
target_link_libraries(glint_ui PUBLIC glint_ui_config glint_capture glint_tracking glint_render glint_display glint_gl glint_core
                      nlohmann_json::nlohmann_json PRIVATE glint_warnings glint_tuning)
