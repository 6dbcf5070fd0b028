#!/usr/bin/env bash
# Installs the Debian 12 packages Glint needs to build, test and benchmark.
# Idempotent: it asks apt only for what is missing and runs `apt-get update`
# only when something is missing. Run as root.
set -euo pipefail

packages=(
  build-essential cmake pkg-config git
  libopenexr-dev libimath-dev          # EXR load/save (appliance/core)
  libcli11-dev                         # command line of `glint`
  nlohmann-json3-dev                   # report.json
  libgtest-dev googletest              # unit tests through CTest
  libbenchmark-dev                     # tests/bench
  blender-data                         # CC0 HDR maps used by tests and benchmarks
  gnuplot-nox                          # speed-against-error plots in images/
  python3                              # JSON checks in tests/cli
  libmodbus-dev                        # Modbus pan/tilt head (firmware_bridge/host)
  libgpiod-dev                         # buttons and lamps, libgpiod 1.6 C++ API (firmware_bridge/host)
  libegl-dev libgles-dev libgbm-dev libdrm-dev   # EGL/GLES3 platform, KMS display (appliance/gl)
  libx11-dev                           # the window display (appliance/gl/display_window.cpp)
  xvfb                                 # the window display's tests: an X server without a screen
  libegl-mesa0 libgl1-mesa-dri         # Mesa llvmpipe: the GPU of tests and CI
  zlib1g-dev                           # PNG screenshots of the GPU benchmark
  clang libclang-rt-14-dev lld         # libFuzzer targets with ASan/UBSan (scripts/run-fuzz.sh; lld drops the parsers' unreached code, tests/fuzz)
  libopencv-dev                        # capture: frames, calibration, features (appliance/capture)
  libcamera-dev                        # capture: the real camera source (appliance/capture)
  libglm-dev                           # the appliance's vectors, quaternions and matrices (appliance/core/rotation.hpp)
  libeigen3-dev                        # capture: the global adjustment's sparse Cholesky (appliance/capture)
  libtinygltf-dev                      # glTF 2.0 models for glint render (appliance/render)
  libtomlplusplus-dev                  # the kiosk's TOML configuration (appliance/ui)
  libimgui-dev libfreetype-dev fonts-dejavu-core   # visitor screens and maintenance menu: Dear ImGui, FreeType, DejaVu (appliance/ui)
  libsystemd-dev systemd               # sd_notify and the service file's verification (systemd/)
  libapriltag-dev                      # AprilTag 3 beside ArUco in the tracking benchmark (tests/bench)
  libembree-dev                        # ambient occlusion baked by ray tracing, glint bake-ao (appliance/render)
  help2man                             # man pages from each tool's --help (cmake/ManPages.cmake)
  dpkg-dev                             # dpkg-shlibdeps: the .deb's library dependencies (cmake/Packaging.cmake)
  libjemalloc2                         # the kiosk's allocator, preloaded at run time (appliance/core/memory.hpp)
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

if [ "$(id -u)" -ne 0 ]; then
  echo "install-deps: missing packages (${missing[*]}); run this script as root" >&2
  exit 1
fi

echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq --no-install-recommends "${missing[@]}"
