#!/usr/bin/env bash
# package.deb (docs/packaging.md, "The test"): builds the .deb from an existing build with cpack,
# checks its contents and control fields, installs it on this machine with dpkg, checks what the
# maintainer scripts made and that the installed programs work (glint --version, the data found
# beside /usr/bin, systemd-analyze verify on the installed unit), then removes and purges it and
# checks that nothing it installed or made is left.
#
# It changes the machine, so: it must run as root; it refuses to start when glint is installed
# or its directories exist already (they would be someone's); and a trap purges the package and
# deletes the user, groups and directories it made on any exit, a failure midway included.
# A /var/lib/glint that is there already (a `glint run` with the default state directory on a
# shared machine) is hidden rather than purged: the test then runs in a private mount namespace
# whose /var/lib shows every other entry as it is (dpkg's database among them).
#
# usage: test_package.sh BUILD_DIR SOURCE_DIR
# Exit status 0 when every check passed, 1 when one failed (each on a FAIL: line).
set -uo pipefail

build=${1:?usage: test_package.sh BUILD_DIR SOURCE_DIR}
src=${2:?usage: test_package.sh BUILD_DIR SOURCE_DIR}
build=$(realpath "$build")
unset GLINT_DATA_DIR  # the installed lookup is what is tested
src=$(realpath "$src")
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }
ok() { echo "ok (${SECONDS} s): $*"; }
die() { echo "FAIL: $*"; exit 1; }

[ "$(id -u)" -eq 0 ] || die "must run as root: it installs and purges the package (CI runs as root)"

# /var/lib as it is but without glint: a tmpfs over it with the real entries bound back in.
varlib_real=""
hide_var_lib_glint() {
    local real
    real=$(mktemp -d /tmp/glint_package_varlib.XXXXXX)
    varlib_real=$real
    mount --make-rprivate / && mount --bind /var/lib "$real" && mount -t tmpfs -o mode=0755 tmpfs /var/lib || return 1
    for e in "$real"/* "$real"/.[!.]*; do
        [ -e "$e" ] || [ -L "$e" ] || continue
        n=$(basename "$e")
        [ "$n" = glint ] && continue
        if [ -L "$e" ]; then cp -P "$e" "/var/lib/$n"
        elif [ -d "$e" ]; then mkdir "/var/lib/$n" && mount --bind "$e" "/var/lib/$n"
        else touch "/var/lib/$n" && mount --bind "$e" "/var/lib/$n"
        fi || return 1
    done
}
if [ -e /var/lib/glint ]; then
    if [ -z "${GLINT_PACKAGE_TEST_NAMESPACE:-}" ]; then
        echo "note: /var/lib/glint exists and is not this test's: running in a mount namespace that hides it"
        exec unshare --mount env GLINT_PACKAGE_TEST_NAMESPACE=1 "$0" "$@"
    fi
    hide_var_lib_glint || die "cannot hide /var/lib/glint in a private mount namespace"
fi
for tool in cpack dpkg dpkg-deb dpkg-statoverride systemd-analyze systemd-sysusers; do
    command -v "$tool" >/dev/null || die "$tool not found (scripts/install-deps.sh)"
done
if dpkg-query -W -f='${Status}' glint 2>/dev/null | grep -qv "not-installed"; then
    die "package glint is installed on this machine (dpkg -s glint): this test would replace and purge it"
fi
for path in /etc/glint /var/lib/glint /usr/bin/glint /usr/share/glint; do
    [ ! -e "$path" ] || die "$path exists before the test: not made by this test, left alone"
done

# What the machine had before, so that the cleanup removes only what the package made.
had_user=0; getent passwd glint >/dev/null && had_user=1
had_groups=()
for g in glint video render input dialout gpio i2c; do getent group "$g" >/dev/null && had_groups+=("$g"); done
had_usb=0; [ -e /media/usb ] && had_usb=1
had_media=0; [ -e /media ] && had_media=1

work=$(mktemp -d /tmp/glint_package_test.XXXXXX)
strings_moved=""
cleanup() {
    # Back where dpkg put it, should a check have stopped with it moved.
    [ -n "$strings_moved" ] && [ -e "$strings_moved" ] && mv "$strings_moved" /usr/share/glint/data/ui/strings.toml
    if dpkg-query -W -f='${Status}' glint 2>/dev/null | grep -qv "not-installed"; then
        echo "cleanup: purging glint"
        dpkg --purge glint >/dev/null 2>&1 || echo "cleanup: dpkg --purge glint failed"
    fi
    if [ "$had_user" -eq 0 ] && getent passwd glint >/dev/null; then userdel glint 2>/dev/null; fi
    for g in glint render input gpio i2c; do
        [[ " ${had_groups[*]} " == *" $g "* ]] && continue
        getent group "$g" >/dev/null && groupdel "$g" 2>/dev/null
    done
    [ "$had_usb" -eq 0 ] && [ -d /media/usb ] && rmdir /media/usb 2>/dev/null
    [ "$had_media" -eq 0 ] && [ -d /media ] && rmdir /media 2>/dev/null
    rm -rf "$work"
    # The real /var/lib's view in the namespace (the namespace goes with this process).
    [ -n "$varlib_real" ] && umount "$varlib_real" 2>/dev/null && rmdir "$varlib_real"
}
trap cleanup EXIT
trap 'exit 1' INT TERM HUP

# --- build the package -----------------------------------------------------------------------
[ -f "$build/CPackConfig.cmake" ] || die "$build/CPackConfig.cmake missing: configure the build first"
if ! (cd "$work" && cpack --config "$build/CPackConfig.cmake" -B "$work/out" >"$work/cpack.log" 2>&1); then
    cat "$work/cpack.log"
    die "cpack failed (log above)"
fi
deb=$(ls "$work"/out/glint_*.deb 2>/dev/null | head -1)
[ -n "$deb" ] || { cat "$work/cpack.log"; die "cpack made no glint_*.deb"; }
ok "built $(basename "$deb") ($(du -k "$deb" | cut -f1) KiB)"

# --- control fields ----------------------------------------------------------------------------
field() { dpkg-deb -f "$deb" "$1"; }
arch=$(dpkg --print-architecture)
[ "$(field Package)" = glint ] || fail "Package: '$(field Package)', not glint"
[ "$(field Architecture)" = "$arch" ] || fail "Architecture: '$(field Architecture)', not this machine's $arch"
depends=$(field Depends)
echo "Depends: $depends"
# Package names only (versions and alternatives split off).
echo "$depends" | tr ',|' '\n\n' | sed 's/(.*)//; s/^ *//; s/ *$//' | grep -v '^$' | sort -u > "$work/depends"
grep -- '-dev$' "$work/depends" && fail "a -dev package among the dependencies (above)"
# From dpkg-shlibdeps (libraries the executables link) and from Packaging.cmake (read at run time).
for want in libc6 libstdc++6 libopenexr-3-1-30 libtomlplusplus3 libcamera0.0.3 libegl1 libgles2 libgbm1 \
            libsystemd0 libembree3-3 fonts-dejavu-core libegl-mesa0 libgl1-mesa-dri systemd; do
    grep -qx -- "$want" "$work/depends" || fail "Depends lacks $want"
done
[ "$(wc -l < "$work/depends")" -le 60 ] || fail "Depends has $(wc -l < "$work/depends") packages: more than expected"
grep -q '^libopencv-core' "$work/depends" || fail "Depends has no OpenCV runtime library (glint-vision links it)"

# --- contents --------------------------------------------------------------------------------
dpkg-deb -c "$deb" | awk '{print $1, $NF}' | sed 's| \./| /|' > "$work/contents"
awk '{print $2}' "$work/contents" > "$work/files"
# From a file, not a pipe: `grep -q` stops reading early, and pipefail would count that as a miss.
listing() { cat "$work/files"; }
for f in /usr/bin/glint /usr/bin/glint-vision /usr/bin/glint-recording /usr/bin/glint-sensor-sim; do
    grep -qx -- "-rwxr-xr-x $f" "$work/contents" || fail "$f missing or not an executable 0755 file"
done
for f in /usr/lib/systemd/system/glint.service /usr/lib/sysusers.d/glint.conf /usr/lib/tmpfiles.d/glint.conf \
         /usr/lib/udev/rules.d/99-glint-sensor.rules /usr/lib/udev/rules.d/99-glint-gpio.rules \
         /etc/glint/glint.toml /usr/share/doc/glint/examples/glint.toml /usr/share/glint/data/ui/strings.toml \
         /usr/share/glint/data/sessions/kiosk/session.json \
         /usr/share/man/man1/glint.1.gz /usr/share/man/man1/glint-vision.1.gz \
         /usr/share/man/man1/glint-recording.1.gz /usr/share/man/man1/glint-sensor-sim.1.gz; do
    grep -qx -- "$f" "$work/files" || fail "$f not in the package"
done
# Nothing of the build's own: headers, static libraries, tests, benchmarks, /usr/local.
listing | grep -E '^/usr/include|\.a$|^/usr/local|_tests$|glint_bench|glint_fuzz|CMakeFiles' \
    && fail "build-only files in the package (above)"
# Every file under a directory the package owns or shares as Debian packages do.
listing | grep -vE '^/(usr/bin|usr/lib/systemd/system|usr/lib/sysusers\.d|usr/lib/tmpfiles\.d|usr/lib/udev/rules\.d|usr/share/glint|usr/share/man/man1|usr/share/doc/glint|etc/glint)(/|$)' \
    | grep -vxE '/|/usr/?|/usr/lib/?|/usr/lib/systemd/?|/usr/lib/udev/?|/usr/share/?|/usr/share/man/?|/usr/share/doc/?|/etc/?' \
    && fail "files outside Glint's directories (above)"
dpkg-deb -e "$deb" "$work/control"
for s in postinst prerm postrm; do
    [ -x "$work/control/$s" ] || fail "maintainer script $s missing or not executable"
done
grep -qx /etc/glint/glint.toml "$work/control/conffiles" 2>/dev/null || fail "/etc/glint/glint.toml is not a conffile"
# The man pages are help2man's, with every command's help.
dpkg-deb -x "$deb" "$work/root"
zcat "$work/root/usr/share/man/man1/glint.1.gz" > "$work/glint.1"
grep -q '^\.TH GLINT' "$work/glint.1" || fail "glint.1 has no .TH header"
for cmd in convolve render run replay capture; do
    grep -q "glint $cmd" "$work/glint.1" || fail "glint.1 lacks the command $cmd"
done
# Portable: on amd64 no AVX instruction (VEX-encoded, or on ymm/zmm registers) in the
# executables, whose baseline is SSE2. A -march=native build (GLINT_NATIVE=ON) has thousands
# and would stop with SIGILL on a CPU without them.
if [ "$arch" = amd64 ]; then
    command -v objdump >/dev/null || die "objdump not found (binutils)"
    for exe in glint glint-vision glint-recording glint-sensor-sim; do
        n=$(objdump -d --no-show-raw-insn "$work/root/usr/bin/$exe" | grep -cE '^\s*[0-9a-f]+:\s+v[a-z0-9]+\s|%[yz]mm[0-9]')
        [ "$n" -eq 0 ] || fail "/usr/bin/$exe has $n AVX instructions: built with -march=native (GLINT_NATIVE=ON)?"
    done
fi
# A page roff renders without warnings (man-db's checker when it is there).
if command -v groff >/dev/null; then
    warnings=$(groff -man -Tutf8 -ww -z "$work/glint.1" 2>&1)
    [ -z "$warnings" ] || fail "groff warns on glint.1: $warnings"
fi
[ "$failures" -eq 0 ] && ok "contents and control fields"

# --- install ---------------------------------------------------------------------------------
if ! dpkg -i "$deb" >"$work/install.log" 2>&1; then
    cat "$work/install.log"
    die "dpkg -i failed (log above; missing dependencies are installed by scripts/install-deps.sh)"
fi
ok "installed"
dpkg-query -W -f='${Status}\n' glint | grep -qx "install ok installed" || fail "dpkg -s glint: not 'install ok installed'"
version=$(/usr/bin/glint --version 2>&1)
[[ "$version" == "glint $(field Version | cut -d- -f1) ("* ]] || fail "/usr/bin/glint --version said '$version'"
ok "glint --version: $version"
for exe in glint-vision glint-recording glint-sensor-sim; do
    /usr/bin/$exe --help >/dev/null 2>&1 || fail "/usr/bin/$exe --help failed"
done
# glint runs glint-vision for the camera commands: from /usr/bin too.
run_help=$(/usr/bin/glint run --help 2>&1)
grep -q -- '--config' <<<"$run_help" || fail "/usr/bin/glint run --help (through glint-vision) failed: $run_help"

# The files are the repository's (the ones tests/service checks).
for pair in "/usr/lib/systemd/system/glint.service systemd/glint.service" \
            "/usr/lib/sysusers.d/glint.conf systemd/glint.sysusers" "/usr/lib/tmpfiles.d/glint.conf systemd/glint.tmpfiles" \
            "/usr/lib/udev/rules.d/99-glint-sensor.rules systemd/99-glint-sensor.rules" \
            "/etc/glint/glint.toml config/glint.example.toml" "/usr/share/glint/data/ui/strings.toml data/ui/strings.toml"; do
    set -- $pair
    cmp -s "$1" "$src/$2" || fail "$1 differs from the repository's $2"
done

# What postinst made: the user and its groups, the state directory, the config's mode.
user=$(getent passwd glint) || fail "postinst made no user glint"
[ "$(echo "$user" | cut -d: -f6,7)" = "/var/lib/glint:/usr/sbin/nologin" ] || fail "user glint: '$user'"
# The groups of the unit's SupplementaryGroups= (the unit adds them; the user is in none).
for g in glint video render input dialout gpio i2c; do
    getent group "$g" >/dev/null || fail "postinst made no group $g"
done
[ "$(stat -c '%U:%G %a' /var/lib/glint 2>/dev/null)" = "glint:glint 750" ] || fail "/var/lib/glint: '$(stat -c '%U:%G %a' /var/lib/glint 2>&1)'"
[ "$(stat -c '%U:%G %a' /etc/glint/glint.toml)" = "root:glint 640" ] || fail "/etc/glint/glint.toml: '$(stat -c '%U:%G %a' /etc/glint/glint.toml)', not root:glint 640"
# The service user can read its configuration.
setpriv --reuid=glint --regid=glint --init-groups cat /etc/glint/glint.toml >/dev/null 2>&1 \
    || fail "user glint cannot read /etc/glint/glint.toml"

# The installed unit, verified as tests/service verifies the source one: no message at all
# (verify exits 0 even on an unknown key).
verify=$(systemd-analyze verify /usr/lib/systemd/system/glint.service 2>&1)
[ $? -eq 0 ] && [ -z "$verify" ] || fail "systemd-analyze verify glint.service: $verify"
# ... and it can fail: a misspelt key in a copy is reported.
sed 's/^ProtectSystem=/ProtectSytem=/' /usr/lib/systemd/system/glint.service > "$work/glint.service"
[ -n "$(systemd-analyze verify "$work/glint.service" 2>&1)" ] || fail "systemd-analyze verify missed a misspelt key"
ok "systemd-analyze verify on the installed unit"

# The installed kiosk finds its data beside /usr/bin: a replay of an empty session gets past the
# strings (read first) and fails on the session itself.
mkdir -p "$work/empty"
out=$(cd / && /usr/bin/glint replay "$work/empty" --out "$work/replay" 2>&1); rc=$?
echo "$out" | grep -q 'strings.toml' && fail "installed glint did not find its strings: $out"
[ "$rc" -ne 0 ] && echo "$out" | grep -q "$work/empty" || fail "glint replay of an empty session: exit $rc, '$out'"
# ... and without them it says where it looked, never in the source tree it was built from.
strings_moved="$work/strings.toml"
mv /usr/share/glint/data/ui/strings.toml "$strings_moved"
out=$(cd / && /usr/bin/glint replay "$work/empty" --out "$work/replay" 2>&1)
echo "$out" | grep -q 'data/ui/strings.toml: not found (looked in /usr/share/glint/data/ui/strings.toml)$' \
    || fail "without its strings the installed glint said: '$out'"
mv "$strings_moved" /usr/share/glint/data/ui/strings.toml; strings_moved=""
ok "data found from /usr/bin (and missing data reported)"
# Every installed file as packaged (the strings put back, nothing else touched). A slim image's
# dpkg path-exclude leaves man pages and docs out: those are reported missing, not changed.
verify=$(dpkg --verify glint 2>&1 | grep -vE '^missing .* /usr/share/(man|doc)/')
[ -z "$verify" ] || fail "dpkg --verify glint: $verify"
dpkg-query -L glint | sort > "$work/installed"

# --- upgrade over itself: an edited configuration and its mode are kept ------------------------
echo "# edited by package.deb" >> /etc/glint/glint.toml
dpkg -i "$deb" >"$work/upgrade.log" 2>&1 || { cat "$work/upgrade.log"; fail "dpkg -i over the installed package failed"; }
tail -1 /etc/glint/glint.toml | grep -qx "# edited by package.deb" || fail "the upgrade replaced the edited /etc/glint/glint.toml"
[ "$(stat -c '%U:%G %a' /etc/glint/glint.toml)" = "root:glint 640" ] || fail "after the upgrade /etc/glint/glint.toml is '$(stat -c '%U:%G %a' /etc/glint/glint.toml)'"
ok "upgraded over itself, the edited conffile and its mode kept"

# --- remove, then purge ----------------------------------------------------------------------
dpkg -r glint >"$work/remove.log" 2>&1 || { cat "$work/remove.log"; fail "dpkg -r glint failed"; }
[ ! -e /usr/bin/glint ] || fail "/usr/bin/glint still there after dpkg -r"
[ -f /etc/glint/glint.toml ] || fail "dpkg -r deleted the conffile (only purge should)"
dpkg --purge glint >"$work/purge.log" 2>&1 || { cat "$work/purge.log"; fail "dpkg --purge glint failed"; }
dpkg-query -W -f='${Status}' glint 2>/dev/null | grep -qv "not-installed" && fail "glint still known to dpkg after purge"
# Every file dpkg installed is gone (directories shared with other packages stay).
while read -r path; do
    [ -d "$path" ] && [ ! -L "$path" ] && continue
    [ -e "$path" ] || [ -L "$path" ] && fail "$path left after purge"
done < "$work/installed"
for d in /etc/glint /var/lib/glint /usr/share/glint /usr/share/doc/glint; do
    [ ! -e "$d" ] || fail "$d left after purge"
done
[ "$had_usb" -eq 1 ] || [ ! -e /media/usb ] || fail "/media/usb (made by tmpfiles) left after purge"
dpkg-statoverride --list /etc/glint/glint.toml >/dev/null && fail "statoverride of /etc/glint/glint.toml left after purge"
[ "$failures" -eq 0 ] && ok "removed and purged, nothing left"

if [ "$failures" -ne 0 ]; then
    echo "$failures check(s) failed"
    exit 1
fi
echo "package.deb: all checks passed"
