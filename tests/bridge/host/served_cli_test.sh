# Sourced by the CLI tests that run glint against a server process (a board simulator on a pty,
# a Modbus head on TCP): named failures, a temporary directory, and the server started with its
# first stdout line (its port or device) read, then stopped on exit.
#   start_server WHAT COMMAND...   sets $served to the first line (fails naming WHAT without one)
#   stop_server                    SIGINT, then waits for it
#   finish NAME                    prints the summary; the script's exit code
set -u
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }
tmp=$(mktemp -d)
sim_pid=
served=
cleanup() {
    [ -n "$sim_pid" ] && kill "$sim_pid" 2>/dev/null
    rm -rf "$tmp"
}
trap cleanup EXIT

start_server() {
    local what=$1
    shift
    mkfifo "$tmp/sim.out"
    "$@" >"$tmp/sim.out" 2>"$tmp/sim.err" &
    sim_pid=$!
    exec 3<"$tmp/sim.out"
    read -r -t 5 served <&3 || fail "$what printed no port"
}

stop_server() {
    kill -INT "$sim_pid" 2>/dev/null
    wait "$sim_pid" 2>/dev/null
    sim_pid=
}

finish() {
    if [ $failures -eq 0 ]; then echo "$1: all checks passed"; else echo "$1: $failures failure(s)"; fi
    [ $failures -eq 0 ]
}
