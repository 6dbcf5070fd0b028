#!/usr/bin/env bash
# Cross-builds Glint for arm64 on an amd64 Debian 12 machine, runs its tests under qemu-user and
# makes the arm64 .deb (docs/packaging.md, "The arm64 build").
set -euo pipefail

usage() {
  cat <<'EOF'
Usage: scripts/cross-arm64.sh [STEP...]

Cross-builds Glint for arm64 (aarch64) Debian 12 on an amd64 Debian 12 machine.

Steps (default: all of them, in this order):
  sysroot   make the arm64 root with Glint's -dev packages if it is not there (mmdebstrap,
            extract only: no arm64 program runs); about 250 MB of downloads, 1.2 GB on disk
  configure configure build-arm64/ with cmake/toolchains/aarch64-linux-gnu.cmake
  build     build everything in build-arm64/ (nice -n 10, -j$JOBS)
  test      ctest -L "$TEST_LABELS" in build-arm64/, every test program under qemu-aarch64
  package   cpack: build-arm64/packages/glint_<version>-<release>_arm64.deb, and its control

Environment:
  GLINT_SYSROOT   the arm64 root (default /work/sysroot-arm64)
  BUILD_DIR       the build tree (default build-arm64 in the source tree)
  JOBS            parallel build jobs (default 2)
  TEST_LABELS     ctest label regex (default '^(unit|bridge|capture)$')
  CTEST_ARGS      more ctest arguments (e.g. "-j2" or "-R Sh")
  BUILD_TARGETS   build only these targets (default: all); "labels": only what the default
                  test labels and the package need (LABEL_TARGETS in this script)

Needs, as root: scripts/install-deps.sh's packages, and mmdebstrap, qemu-user,
crossbuild-essential-arm64 (this script installs the last three when they are missing).
Each step prints its duration in seconds.
EOF
}

src=$(cd "$(dirname "$0")/.." && pwd)
sysroot=${GLINT_SYSROOT:-/work/sysroot-arm64}
build=${BUILD_DIR:-$src/build-arm64}
jobs=${JOBS:-2}
labels=${TEST_LABELS:-'^(unit|bridge|capture)$'}
triple=aarch64-linux-gnu

# The arm64 packages of the root: scripts/install-deps.sh's libraries (their -dev packages) and
# what the programs load at run time (Mesa's EGL and llvmpipe, the font). Tools (cmake, help2man,
# python3, xvfb, clang) are the build machine's own.
sysroot_packages=(
  libc6-dev libstdc++-12-dev
  libopenexr-dev libimath-dev libcli11-dev nlohmann-json3-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libmodbus-dev libgpiod-dev
  libegl-dev libgles-dev libgbm-dev libdrm-dev libx11-dev zlib1g-dev
  libegl-mesa0 libgl1-mesa-dri
  libopencv-dev libcamera-dev libglm-dev libeigen3-dev libtinygltf-dev libtomlplusplus-dev
  libimgui-dev libfreetype-dev fonts-dejavu-core libsystemd-dev libapriltag-dev libembree-dev
)
stamp=$sysroot/.glint-sysroot
PACKAGE_TARGETS="glint glint-vision glint-recording glint-sensor-sim glint_man_pages"
# The targets of the default test labels and of the package (executables and man pages).
LABEL_TARGETS="glint glint-vision glint-recording glint-sensor-sim glint_man_pages glint_unit_tests
  glint_bridge_firmware_tests glint_bridge_host_tests glint_bridge_protocol_tests
  glint_bridge_recording_tests glint_fuzz_protocol_replay glint_fuzz_recording_replay
  glint_capture_tests"

timed() {  # timed NAME COMMAND...: runs it, prints its duration
  local name=$1 t0 rc=0
  shift
  t0=$(date +%s)
  "$@" || rc=$?
  echo "cross-arm64: $name took $(($(date +%s) - t0)) s (exit $rc)"
  return $rc
}

need_tools() {
  local missing=()
  for p in mmdebstrap qemu-user crossbuild-essential-arm64; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  [ ${#missing[@]} -eq 0 ] && return 0
  if [ "$(id -u)" -ne 0 ]; then
    echo "cross-arm64: missing packages (${missing[*]}); install them as root" >&2
    exit 1
  fi
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}"
}

# Absolute symlinks in the root (libz.so -> /lib/aarch64-linux-gnu/libz.so.1.2.13) would point
# into the build machine's own /lib: make them relative to the root.
relative_links() {
  local l t rel
  while IFS= read -r -d '' l; do
    t=$(readlink "$l")
    rel=$(realpath -m -s --relative-to="$(dirname "${l#"$sysroot"}")" "$t")
    ln -sfn "$rel" "$l"
  done < <(find "$sysroot" -type l -lname '/*' -print0)
}

# dpkg-shlibdeps (the .deb's Depends) asks dpkg which package owns each library the executables
# link, and reads that package's shlibs/symbols files. The root was only extracted, so it has no
# dpkg database: build one from the downloaded .debs. Its file lists name the files where they
# are on this machine ($sysroot/usr/lib/...), which is where dpkg-shlibdeps finds them.
shlibdeps_db() {
  local db=$sysroot/var/lib/glint-shlibdeps deb pkg arch ma name tmp
  rm -rf "$db"
  mkdir -p "$db/info" "$db/updates"
  : > "$db/status"
  # Format 1: multiarch file names (info/<package>:arm64.list for Multi-Arch: same packages).
  echo 1 > "$db/info/format"
  printf 'amd64\narm64\n' > "$db/arch"
  tmp=$(mktemp -d)
  for deb in "$sysroot"/var/cache/apt/archives/*.deb; do
    pkg=$(dpkg-deb -f "$deb" Package)
    arch=$(dpkg-deb -f "$deb" Architecture)
    ma=$(dpkg-deb -f "$deb" Multi-Arch)
    name=$pkg
    [ "$ma" = same ] && name=$pkg:$arch
    dpkg-deb -f "$deb" | sed '1a Status: install ok installed' >> "$db/status"
    echo >> "$db/status"
    dpkg-deb --fsys-tarfile "$deb" | tar -t | sed -e 's|^\./|/|' -e 's|/$||' -e 's|^$|/.|' \
      | awk -v root="$sysroot" '$0 == "/." { print; next } { print root $0 }' > "$db/info/$name.list"
    rm -rf "${tmp:?}"/*
    dpkg-deb -e "$deb" "$tmp"
    for f in shlibs symbols; do
      [ -f "$tmp/$f" ] && cp "$tmp/$f" "$db/info/$name.$f"
    done
  done
  rm -rf "$tmp"
}

# Runs "$@" where arm64 executables run like native ones: a private user and mount namespace
# with its own binfmt_misc (Linux 6.7 and later give each user namespace one), where
# qemu-aarch64 is registered for arm64 ELF files and QEMU_LD_PREFIX makes the arm64 root their
# library prefix. That is what lets help2man run the built tools for the man pages, the tests'
# shell scripts run `glint`, and `glint` start `glint-vision`, without changing the machine's own
# binfmt_misc (other users of the machine see nothing). CMAKE_CROSSCOMPILING_EMULATOR (the
# toolchain file) covers the programs CMake starts itself, inside or outside this namespace.
# Inside it, uid 0 is the caller's uid: files stay the caller's.
in_arm64_ns() {
  local magic mask
  magic='\x7fELF\x02\x01\x01\x00\x00\x00\x00\x00\x00\x00\x00\x00\x02\x00\xb7\x00'
  mask='\xff\xff\xff\xff\xff\xff\xff\x00\xff\xff\xff\xff\xff\xff\xff\xff\xfe\xff\xff\xff'
  # shellcheck disable=SC2016  # the inner script expands its own arguments
  QEMU_LD_PREFIX=$sysroot unshare --user --map-root-user --mount --fork -- bash -c '
    set -e
    mount -t binfmt_misc binfmt_misc /proc/sys/fs/binfmt_misc || {
      echo "cross-arm64: cannot mount a private binfmt_misc (needs Linux 6.7 or later and user namespaces)" >&2
      exit 1; }
    # F: qemu-aarch64 is opened now, so it is found whatever the arm64 program sees later.
    printf "%s" ":glint-qemu-aarch64:M::$1:$2:$3:F" > /proc/sys/fs/binfmt_misc/register
    shift 3
    exec "$@"' in_arm64_ns "$magic" "$mask" "$(command -v qemu-aarch64)" "$@"
}

step_sysroot() {
  need_tools
  if [ -f "$stamp" ]; then
    echo "cross-arm64: $sysroot is there ($(cat "$stamp")); delete it to make it again"
    return 0
  fi
  if [ -e "$sysroot" ]; then
    echo "cross-arm64: $sysroot exists but is unfinished (no $stamp): delete it first" >&2
    exit 1
  fi
  local include
  include=$(IFS=,; echo "${sysroot_packages[*]}")
  # extract: the packages and their dependencies unpacked, no maintainer script run (they would
  # need an arm64 CPU or binfmt_misc); the .debs are kept for the dpkg database below.
  nice -n 10 mmdebstrap --variant=extract --arch=arm64 --skip=cleanup/apt/cache \
    --include="$include" bookworm "$sysroot" \
    "deb http://deb.debian.org/debian bookworm main" \
    "deb http://deb.debian.org/debian bookworm-updates main" \
    "deb http://deb.debian.org/debian-security bookworm-security main"
  relative_links
  # qemu-user -L looks for every path in the root first: device nodes made there (dev/ptmx
  # outside a devpts mount gives ENODEV, no pseudo-terminal) and its own tmp/ would hide the
  # machine's. The root is for libraries and data only.
  rm -rf "${sysroot:?}"/dev/* "$sysroot/tmp"
  # The only shared libraries behind alternatives (update-alternatives in their postinst, which
  # did not run): OpenCV's BLAS and LAPACK.
  ln -sfn blas/libblas.so.3 "$sysroot/usr/lib/$triple/libblas.so.3"
  ln -sfn lapack/liblapack.so.3 "$sysroot/usr/lib/$triple/liblapack.so.3"
  shlibdeps_db
  rm -f "$sysroot"/var/cache/apt/archives/*.deb
  echo "bookworm arm64, $(grep -c '^Package:' "$sysroot/var/lib/glint-shlibdeps/status") packages, made $(date -u +%FT%TZ)" > "$stamp"
  echo "cross-arm64: $sysroot made"
}

step_configure() {
  [ -f "$stamp" ] || { echo "cross-arm64: no arm64 root at $sysroot (run the sysroot step)" >&2; exit 1; }
  cmake -S "$src" -B "$build" --toolchain "$src/cmake/toolchains/aarch64-linux-gnu.cmake" \
    -DGLINT_SYSROOT="$sysroot" -DCMAKE_BUILD_TYPE=Release -DGLINT_NATIVE=OFF \
    -DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DGLINT_BUILD_BENCH=OFF \
    -DCMAKE_SKIP_INSTALL_ALL_DEPENDENCY=ON
}

step_build() {
  local targets=()
  # shellcheck disable=SC2206
  case ${BUILD_TARGETS:-} in
    "") ;;
    labels) targets=(--target $LABEL_TARGETS) ;;
    *) targets=(--target $BUILD_TARGETS) ;;
  esac
  in_arm64_ns nice -n 10 cmake --build "$build" -j"$jobs" "${targets[@]}"
}

step_test() {
  # shellcheck disable=SC2086
  in_arm64_ns nice -n 10 ctest --test-dir "$build" -L "$labels" --output-on-failure ${CTEST_ARGS:-}
}

step_package() {
  # What the package holds, built first: the configure step made `install` (and so cpack)
  # independent of `all`, so the package does not wait for test programs it does not contain.
  # shellcheck disable=SC2086
  in_arm64_ns nice -n 10 cmake --build "$build" -j"$jobs" --target $PACKAGE_TARGETS
  rm -rf "$build/packages"
  in_arm64_ns cpack --config "$build/CPackConfig.cmake" -B "$build/packages"
  local deb
  deb=$(ls "$build"/packages/glint_*_arm64.deb)
  echo "cross-arm64: $deb, $(stat -c %s "$deb") bytes"
  dpkg-deb -I "$deb" | grep -E '^ (Package|Version|Architecture|Depends|Recommends|Installed-Size):'
  # CPack runs dpkg-shlibdeps with --ignore-missing-info: a Depends without the libraries means
  # it found none of them (the root's package database, cmake/CrossPackaging.cmake).
  dpkg-deb -f "$deb" Depends | grep -q 'libc6 (>=' \
    || { echo "cross-arm64: $deb: no library dependencies in Depends (dpkg-shlibdeps found nothing)" >&2; exit 1; }
  local x=$build/packages/contents
  rm -rf "$x"
  dpkg-deb -x "$deb" "$x"
  for exe in glint glint-vision glint-recording glint-sensor-sim; do
    file -b "$x/usr/bin/$exe" | grep -q 'ARM aarch64' \
      || { echo "cross-arm64: $deb: /usr/bin/$exe is not an arm64 executable" >&2; exit 1; }
  done
  [ -f "$x/usr/share/man/man1/glint.1.gz" ] \
    || { echo "cross-arm64: $deb: no man pages (were they made under qemu?)" >&2; exit 1; }
  rm -rf "$x"
}

steps=("$@")
[ ${#steps[@]} -eq 0 ] && steps=(sysroot configure build test package)
for s in "${steps[@]}"; do
  case $s in
    -h|--help) usage; exit 0 ;;
    sysroot|configure|build|test|package) ;;
    *) echo "cross-arm64: unknown step '$s' (see --help)" >&2; exit 2 ;;
  esac
done
for s in "${steps[@]}"; do
  timed "$s" "step_$s"
done
