# Read by cpack (CPACK_PROJECT_CONFIG_FILE) for a cross build whose libraries come from an arm64
# root (cmake/toolchains/aarch64-linux-gnu.cmake). dpkg-shlibdeps, which gives the .deb's
# Depends, would otherwise look for the executables' libraries in this machine's own
# /usr/lib/<triple> and ask this machine's dpkg who owns them: CPack passes it
# --ignore-missing-info, so the package would come out with those dependencies silently missing.
#
# Here it looks in the root's library directories (-l), asks the root's package database
# (scripts/cross-arm64.sh builds it from the root's .debs, with file lists under the root's
# path) and reads the shlibs and symbols files of the root's packages, and DEB_HOST_ARCH makes
# it use the cross objdump and the target's multiarch directories.
if(NOT EXISTS "${CPACK_GLINT_SYSROOT}/var/lib/glint-shlibdeps/status")
  message(FATAL_ERROR "${CPACK_GLINT_SYSROOT}/var/lib/glint-shlibdeps/status is missing: the .deb's "
                      "dependencies cannot be found (make the root with scripts/cross-arm64.sh sysroot)")
endif()
set(ENV{DPKG_ADMINDIR} "${CPACK_GLINT_SYSROOT}/var/lib/glint-shlibdeps")
set(ENV{DEB_HOST_ARCH} "${CPACK_DEBIAN_PACKAGE_ARCHITECTURE}")
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS_PRIVATE_DIRS
    "${CPACK_GLINT_SYSROOT}/lib/${CPACK_GLINT_TRIPLE}"
    "${CPACK_GLINT_SYSROOT}/usr/lib/${CPACK_GLINT_TRIPLE}")
