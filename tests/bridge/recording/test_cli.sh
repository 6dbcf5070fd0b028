#!/bin/bash
# glint-recording on the committed session and on damaged copies: exit codes and key lines.
# Usage: test_cli.sh GLINT_RECORDING SESSIONS_DIR
set -u
tool=$1
session=$2/synthetic-rotation-4s.glrec
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail=0
check() {  # check NAME EXPECTED_EXIT COMMAND... ; output in $tmp/out, $tmp/err
    local name=$1 want=$2
    shift 2
    "$@" >"$tmp/out" 2>"$tmp/err"
    local got=$?
    if [ "$got" != "$want" ]; then
        echo "FAIL $name: exit $got, expected $want"; cat "$tmp/err"; fail=1
    fi
}
contains() {  # contains NAME FILE TEXT
    if ! grep -qF -- "$3" "$2"; then echo "FAIL $1: no \"$3\" in output"; head -5 "$2"; fail=1; fi
}

check help 0 "$tool" --help
contains help "$tmp/out" "verify"
check info 0 "$tool" info "$session"
contains info "$tmp/out" "transport    simulator"
contains info "$tmp/out" "damage       0 issue(s)"
check verify 0 "$tool" verify "$session"
contains verify "$tmp/out" "OK"
check dump 0 "$tool" dump "$session"
contains dump "$tmp/out" 'marker t=7200299000us "capture started"'
check play 0 "$tool" play --fast "$session"
contains play "$tmp/out" "frames_ok"
check play-exclusive 2 "$tool" play --fast --realtime "$session"

# Cut the last 5 bytes: verify fails, unless a torn tail is allowed; the warning names the offset.
size=$(stat -c %s "$session")
head -c $((size - 5)) "$session" >"$tmp/cut.glrec"
check verify-cut 1 "$tool" verify "$tmp/cut.glrec"
contains verify-cut "$tmp/err" "torn record at byte"
check verify-cut-allowed 0 "$tool" verify --allow-torn-tail "$tmp/cut.glrec"

# One flipped byte in the middle: reported with its offset, verify fails.
cp "$session" "$tmp/flip.glrec"
printf '\xff' | dd of="$tmp/flip.glrec" bs=1 seek=50000 conv=notrunc status=none
check verify-flip 1 "$tool" verify "$tmp/flip.glrec"
contains verify-flip "$tmp/err" "damaged record at byte"
check info-flip 0 "$tool" info "$tmp/flip.glrec"

# Not a recording, missing file, cut header: exit 2 with the reason.
echo "hello" >"$tmp/text.txt"
check stranger 2 "$tool" info "$tmp/text.txt"
contains stranger "$tmp/err" "not a Glint recording"
check missing 2 "$tool" info "$tmp/none.glrec"
contains missing "$tmp/err" "none.glrec: cannot open"
head -c 30 "$session" >"$tmp/head.glrec"
check cut-header 2 "$tool" info "$tmp/head.glrec"
contains cut-header "$tmp/err" "truncated header: the file ends at byte 30"

# generate refuses to overwrite without --force.
check generate 0 "$tool" generate --duration-ms 200 "$tmp/gen.glrec"
check generate-exists 2 "$tool" generate --duration-ms 200 "$tmp/gen.glrec"
check generate-force 0 "$tool" generate --force --duration-ms 200 "$tmp/gen.glrec"
exit $fail
