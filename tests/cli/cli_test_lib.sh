# Shared by the command-line test scripts (source it after setting GLINT): a work directory
# removed at exit, ok/FAIL lines, and `run` capturing glint's output and exit code.
work=$(mktemp -d "${TMPDIR:-/tmp}/glint_cli.XXXXXX")
trap 'rm -rf "$work"' EXIT

checks=0
pass() { checks=$((checks + 1)); echo "ok   - $*"; }
fail() { echo "FAIL - $*"; exit 1; }

# Runs glint with stdout/stderr captured in $work/stdout, $work/stderr; sets $rc.
run() {
    rc=0
    "$GLINT" "$@" >"$work/stdout" 2>"$work/stderr" || rc=$?
}
stderr_lines() { awk 'END { print NR }' "$work/stderr"; }
stderr_text() { tr '\n' ' ' <"$work/stderr"; }
