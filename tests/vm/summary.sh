# The VM tests' summary, sourced by tests/vm/run.sh and
# tests/vm/deploy/run.sh.
#
# vm_summary CONSOLE QEMU_STATUS TIMEOUT NAME...: prints each NAME's
# first `PASS NAME …` or `FAIL NAME …` line of CONSOLE (MISSING if the
# guest printed none), then a timeout, QEMU's own failure, or a guest
# that never printed DONE. Sets PASSED (the count) and FAILED (0 or 1).
vm_summary() {
    local console=$1 status=$2 timeout=$3 name line
    shift 3
    PASSED=0
    FAILED=0
    for name in "$@"; do
        line=$(grep -E "^(PASS|FAIL) $name( |$)" "$console" | head -n 1 || true)
        if [ -z "$line" ]; then
            echo "MISSING $name (the guest printed no result)"
            FAILED=1
        else
            echo "$line"
            case "$line" in FAIL*) FAILED=1 ;; *) PASSED=$((PASSED + 1)) ;; esac
        fi
    done
    if [ "$status" = 124 ] || [ "$status" = 137 ]; then
        echo "TIMEOUT: the guest did not power off within ${timeout} s"
        FAILED=1
    elif [ "$status" != 0 ]; then
        echo "QEMU exited with status $status"
        FAILED=1
    fi
    grep -qx DONE "$console" || {
        echo "the guest did not reach the end of its steps (no DONE line)"
        FAILED=1
    }
}
