// `glint run --record DIR`: the live kiosk's inputs written as a session that `glint replay` reads
// (docs/capture.md "Session directory", "Kiosk sessions"): session.json and calibration.json at
// once, then as they come the camera frames (JPEG, quality 90: a 320x180 frame in ~15 kB) with
// frames.csv, the sensor (sensors.glrec, host::SensorRecording, synced every second: a serial
// board's byte stream, or an I2C or Modbus source's published samples, which have no byte stream)
// and the button events (events.csv). Lines are
// flushed as written; a power cut loses at most the last second, and the reader skips a torn
// last record.
#pragma once

#include <cstdio>
#include <filesystem>
#include <memory>
#include <mutex>
#include <string>

#include "appliance/capture/camera_frame.hpp"
#include "appliance/capture/camera_model.hpp"
#include "appliance/capture/kiosk_session.hpp"
#include "firmware_bridge/host/sample_recording.hpp"
#include "firmware_bridge/host/source_spec.hpp"

namespace glint::app {

class SessionRecorder {
public:
    // DIR must not exist (a recording is never written over). The sensor is recorded from any live
    // source (a replay is not recorded again): attach() before it starts, and for a source
    // without a byte stream pass each published sample to sample().
    SessionRecorder(const std::filesystem::path& dir, const capture::CameraCalibration& calibration,
                    const host::SourceSpec& sensor, recording::Clock& clock);
    ~SessionRecorder();
    SessionRecorder(const SessionRecorder&) = delete;
    SessionRecorder& operator=(const SessionRecorder&) = delete;

    // The source whose sensor is recorded: a serial board's bytes go into sensors.glrec from its
    // reader; for the others it sets up the recording of what sample() is given.
    void attach(host::OrientationSource& source);
    // A sample the attached source published (its sample callback): recorded when the source
    // has no byte stream (I2C, Modbus), ignored otherwise (its bytes are recorded).
    void sample(const host::OrientationSample& sample);
    void frame(const capture::CameraFrame& frame);
    void event(const capture::SessionEvent& event);
    // Closes every file; returns "" or what failed (the recording stays readable up to there).
    std::string close();
    std::uint64_t frames() const { return frames_; }

private:
    std::filesystem::path dir_;
    std::unique_ptr<host::SensorRecording> sensors_;  // none for a replayed sensor
    std::FILE* frames_csv_ = nullptr;
    std::FILE* events_csv_ = nullptr;
    std::uint64_t frames_ = 0;
    std::string error_;
    std::mutex mutex_;
};

}  // namespace glint::app
