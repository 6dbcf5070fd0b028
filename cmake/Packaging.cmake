# CPack: the Debian package `glint` (docs/packaging.md). `cpack -G DEB` in the build directory
# (or `cmake --build build --target package`) writes glint_<version>-<release>_<arch>.deb from
# what `cmake --install` installs, with prefix /usr.
#
# Dependencies: dpkg-shlibdeps reads the executables' ELF NEEDED entries and gives the runtime
# library packages (never -dev ones); CPACK_DEBIAN_PACKAGE_DEPENDS adds what no ELF names:
# files read at run time, the GL drivers loaded by libglvnd, and the tools the maintainer
# scripts run. The maintainer scripts are in packaging/deb/.

if(GLINT_NATIVE)
  message(WARNING "GLINT_NATIVE=ON: a package from this build runs only on CPUs with this machine's "
                  "instruction set (the package test, tests/package, fails on it)")
endif()

set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME glint)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(GLINT_PACKAGE_RELEASE 1 CACHE STRING "Debian revision of the glint package")
set(GLINT_PACKAGE_CONTACT "Glint developers <glint@example.org>" CACHE STRING
    "Maintainer field of the .deb (set it to the integrator's address)")
set(CPACK_PACKAGE_CONTACT ${GLINT_PACKAGE_CONTACT})
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "HDR environment capture and AR kiosk")
# The extended description: CPack puts the summary above it and indents each line.
set(CPACK_PACKAGE_DESCRIPTION "Glint captures a 360-degree HDR environment map with a camera and an
orientation sensor, convolves it into irradiance and reflection maps, and shades a virtual
object on a printed marker with them. This package holds the kiosk (glint run, as the
systemd service glint), its command-line tools, the service user, udev rules for the
sensor and GPIO, and man pages.")
set(CPACK_DEBIAN_PACKAGE_SECTION misc)
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
set(CPACK_DEBIAN_PACKAGE_RELEASE ${GLINT_PACKAGE_RELEASE})
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)  # glint_<version>-<release>_<arch>.deb
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)

# The architecture of the machine the binaries are for: dpkg's own name (amd64, arm64). A
# cross build sets GLINT_DEB_ARCHITECTURE (e.g. arm64) instead of asking the build machine.
if(NOT GLINT_DEB_ARCHITECTURE)
  find_program(GLINT_DPKG dpkg)
  if(GLINT_DPKG)
    execute_process(COMMAND ${GLINT_DPKG} --print-architecture OUTPUT_VARIABLE glint_arch
                    OUTPUT_STRIP_TRAILING_WHITESPACE)
  endif()
  set(GLINT_DEB_ARCHITECTURE "${glint_arch}" CACHE STRING "Debian architecture of the package")
endif()
set(CPACK_DEBIAN_PACKAGE_ARCHITECTURE ${GLINT_DEB_ARCHITECTURE})

set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
# A cross build (the arm64 one, docs/packaging.md) finds the libraries' packages in its root.
if(CMAKE_CROSSCOMPILING AND CMAKE_SYSROOT)
  set(CPACK_GLINT_SYSROOT "${CMAKE_SYSROOT}")
  set(CPACK_GLINT_TRIPLE "${CMAKE_LIBRARY_ARCHITECTURE}")
  set(CPACK_PROJECT_CONFIG_FILE "${PROJECT_SOURCE_DIR}/cmake/CrossPackaging.cmake")
endif()
set(CPACK_DEBIAN_PACKAGE_GENERATE_SHLIBS OFF)  # no shared library of ours in the package
# Read at run time, so no ELF names them:
#   fonts-dejavu-core      DejaVuSans(-Bold).ttf of the visitor screens (appliance/ui/imgui_layer.hpp)
#   libegl-mesa0           the EGL vendor libglvnd's libEGL loads (KMS, headless, llvmpipe)
#   libgl1-mesa-dri        Mesa's GPU drivers (and llvmpipe without a GPU), loaded by EGL and GBM
#   systemd                systemd-sysusers and systemd-tmpfiles in postinst, the unit itself
#   libjemalloc2           the kiosk's allocator, preloaded by glint-vision run/replay (core/memory.hpp)
set(CPACK_DEBIAN_PACKAGE_DEPENDS "fonts-dejavu-core, libegl-mesa0, libgl1-mesa-dri, libjemalloc2, systemd")
# libcamera-ipa: the image processing modules of most camera pipelines (the Raspberry Pi's
# among them); the kiosk starts without it, so recommended, not required. udev: the sensor's
# /dev/glint-sensor name and the GPIO group (not there in a container).
set(CPACK_DEBIAN_PACKAGE_RECOMMENDS "libcamera-ipa, udev")
set(CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA
    ${PROJECT_SOURCE_DIR}/packaging/deb/postinst
    ${PROJECT_SOURCE_DIR}/packaging/deb/prerm
    ${PROJECT_SOURCE_DIR}/packaging/deb/postrm
    ${PROJECT_SOURCE_DIR}/packaging/deb/conffiles)
# Keep the scripts' modes (0755) as they are in the repository.
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)

include(CPack)
