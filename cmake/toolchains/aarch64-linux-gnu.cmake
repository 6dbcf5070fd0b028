# Cross-compiling Glint for arm64 (aarch64) Debian 12 from an amd64 Debian 12 machine
# (docs/packaging.md, "The arm64 build"). scripts/cross-arm64.sh uses it; by hand:
#
#   cmake -S . -B build-arm64 --toolchain cmake/toolchains/aarch64-linux-gnu.cmake \
#         -DGLINT_SYSROOT=/work/sysroot-arm64
#
# The compiler is the host's aarch64-linux-gnu-g++ (crossbuild-essential-arm64). The headers
# and libraries come from an arm64 root (GLINT_SYSROOT) that holds Debian's arm64 -dev packages,
# because several of them (libopenexr-dev, libgdcm-dev under libopencv-dev) cannot be installed
# beside their amd64 versions on the build machine. Executables run under qemu-user with that
# root as its library prefix: gtest's test discovery, the man pages and ctest.

set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(GLINT_CROSS_TRIPLE aarch64-linux-gnu)

set(GLINT_SYSROOT "$ENV{GLINT_SYSROOT}" CACHE PATH "arm64 Debian root with Glint's -dev packages")
if(NOT GLINT_SYSROOT)
  set(GLINT_SYSROOT /work/sysroot-arm64)
endif()
if(NOT EXISTS "${GLINT_SYSROOT}/usr/include/${GLINT_CROSS_TRIPLE}")
  message(FATAL_ERROR "arm64 sysroot ${GLINT_SYSROOT} has no usr/include/${GLINT_CROSS_TRIPLE}: "
                      "make it with scripts/cross-arm64.sh sysroot")
endif()
# Try-compiles (and the toolchain file, which CMake reads again for each) see the same root.
list(APPEND CMAKE_TRY_COMPILE_PLATFORM_VARIABLES GLINT_SYSROOT)

set(CMAKE_SYSROOT "${GLINT_SYSROOT}")
set(CMAKE_C_COMPILER ${GLINT_CROSS_TRIPLE}-gcc)
set(CMAKE_CXX_COMPILER ${GLINT_CROSS_TRIPLE}-g++)
set(CMAKE_LIBRARY_ARCHITECTURE ${GLINT_CROSS_TRIPLE})

# Headers, libraries and CMake/pkg-config packages only from the root; programs (help2man,
# python3, glslang if any) from the build machine.
set(CMAKE_FIND_ROOT_PATH "${GLINT_SYSROOT}")
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)
set(ENV{PKG_CONFIG_SYSROOT_DIR} "${GLINT_SYSROOT}")
set(ENV{PKG_CONFIG_LIBDIR}
    "${GLINT_SYSROOT}/usr/lib/${GLINT_CROSS_TRIPLE}/pkgconfig:${GLINT_SYSROOT}/usr/share/pkgconfig")
set(ENV{PKG_CONFIG_PATH} "")

# The linker resolves the libraries' own dependencies (libopencv_* -> libtbb, libgdcm, ...) by
# their sonames; -rpath-link makes it look for them in the root, not on this machine.
set(CMAKE_EXE_LINKER_FLAGS_INIT
    "-Wl,-rpath-link,${GLINT_SYSROOT}/usr/lib/${GLINT_CROSS_TRIPLE}:${GLINT_SYSROOT}/lib/${GLINT_CROSS_TRIPLE}")
set(CMAKE_SHARED_LINKER_FLAGS_INIT "${CMAKE_EXE_LINKER_FLAGS_INIT}")

# Built programs run under qemu-user: -L makes the root's dynamic loader and libraries theirs
# (and its files seen first: /usr/share/glvnd, /usr/lib/.../dri for Mesa).
find_program(GLINT_QEMU_AARCH64 qemu-aarch64)
if(GLINT_QEMU_AARCH64)
  set(CMAKE_CROSSCOMPILING_EMULATOR "${GLINT_QEMU_AARCH64};-L;${GLINT_SYSROOT}")
endif()

set(GLINT_DEB_ARCHITECTURE arm64 CACHE STRING "Debian architecture of the package")
