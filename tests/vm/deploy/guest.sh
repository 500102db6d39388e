#!/bin/bash
# The deployment test's guest side (tests/vm/deploy/run.sh builds the
# Debian guest it runs in): the package installed, its service booted,
# restarted, killed, stalled, upgraded, removed and purged as a deploying
# engineer would, each step one `PASS <name> <figures>` or
# `FAIL <name> <reason>` line on the console.
#
#   guest.sh gadget    plug in the sip-and-puff joystick (vmtest-gadget.service, every boot)
#   guest.sh joystick  the joystick at rest: reports the neutral whenever
#                      the host polls, as a real sensor does
#                      (vmtest-joystick.service); a step's feeder takes
#                      its place while it plays a pattern
#   guest.sh stage     run this boot's steps (vmtest.service): the first
#                      boot installs and reboots, the second checks the
#                      service and powers off
set -u
V=/opt/vmtest            # the harness's files: debs, feeders, patterns, expected events
STATE=/var/lib/vmtest    # which boot this is, the figures kept across the reboot
ART=$STATE/art           # artifacts, read by the host from the image after power-off
G=/sys/kernel/config/usb_gadget
UNIT=sipnpuff.service
CONF=/etc/sipnpuff/sipnpuff.toml
HID_DESC="05 01 09 04 a1 01 05 01 09 30 15 00 26 ff 03 75 0a 95 01 81 02 05 09 19 01 29 02 15 00 25 01 75 01 95 02 81 02 75 04 95 01 81 03 c0"
NEUTRAL=2.5
mkdir -p $ART

console() { echo "$*" > /dev/ttyS0; }
say() { console "vm: $*"; }
pass() { console "PASS $*"; }
fail() { console "FAIL $*"; }

# now_us: CLOCK_MONOTONIC, µs (systemd's *TimestampMonotonic clock).
now_us() { echo | $V/bin/stamp | cut -d' ' -f1; }
ms_between() { echo $(( ($2 - $1) / 1000 )); } # FROM_US TO_US
prop() { systemctl show -p "$1" --value $UNIT; }
is_active() { [ "$(prop ActiveState)" = active ]; }

# wait_for SECONDS COMMAND...: polls every 100 ms until COMMAND succeeds.
wait_for() {
    local until=$(( $(now_us) + $1 * 1000000 )); shift
    until "$@" >/dev/null 2>&1; do
        [ "$(now_us)" -ge "$until" ] && return 1
        sleep 0.1
    done
}

# ------------------------------------------------------------ the device

# The joystick's event node, once udev has given it its group.
hid_event() {
    local e
    for e in /sys/class/input/event*; do
        case "$(cat $e/device/name 2>/dev/null)" in
        *"sipnpuff test"*) [ -c /dev/input/${e##*/} ] && { echo /dev/input/${e##*/}; return 0; } ;;
        esac
    done
    return 1
}

# The USB HID joystick (tests/vm/guest/init has the same): plugged in at
# boot before the service starts, as a person's sensor is.
gadget() {
    local d=$G/joy
    modprobe dummy_hcd && modprobe usb_f_hid || return 1
    mountpoint -q /sys/kernel/config || mount -t configfs none /sys/kernel/config
    mkdir -p $d/strings/0x409 $d/configs/c.1/strings/0x409 $d/functions/hid.usb0 || return 1
    echo 0x1d6b > $d/idVendor; echo 0x0104 > $d/idProduct
    echo 0x0100 > $d/bcdDevice; echo 0x0200 > $d/bcdUSB
    echo Harness > $d/strings/0x409/manufacturer
    echo "sipnpuff test joystick" > $d/strings/0x409/product
    echo 0001 > $d/strings/0x409/serialnumber
    echo hid > $d/configs/c.1/strings/0x409/configuration
    echo 100 > $d/configs/c.1/MaxPower
    echo 0 > $d/functions/hid.usb0/protocol; echo 0 > $d/functions/hid.usb0/subclass
    echo 2 > $d/functions/hid.usb0/report_length
    echo "$HID_DESC" | tr -d ' ' | xxd -r -p > $d/functions/hid.usb0/report_desc
    ln -s $d/functions/hid.usb0 $d/configs/c.1/
    echo dummy_udc.0 > $d/UDC || return 1
    wait_for 10 hid_event || { say "gadget: no event node"; return 1; }
    wait_for 10 test -c /dev/hidg0 || { say "gadget: no /dev/hidg0"; return 1; }
    udevadm settle
}

# The joystick at rest: the neutral, one report per period whenever the
# host polls (a write waits while no one has the event node open).
joystick() {
    exec $V/bin/hidfeed --linger $V/rest.txt
}

# feed NAME PATTERN: plays the pattern on the joystick in place of the
# rest (once the service has it open and runs its control loop), then
# holds its last level; unfeed gives the joystick back to the rest.
feed() {
    systemctl stop vmtest-joystick.service
    $V/bin/hidfeed --linger --start-when-open "$(hid_event)" --sync-rt --ends $ART/$1.ends \
        "$2" > $ART/$1.feed 2>&1 &
    FEEDER=$!
}
unfeed() {
    kill $FEEDER 2>/dev/null
    wait $FEEDER 2>/dev/null
    systemctl start vmtest-joystick.service
}

# ------------------------------------------------------------ the service's output

# The cursor of the service's newest journal entry, and its lines after
# one. The cursor is the service's own: journalctl --after-cursor with
# -u skips the first match when the cursor's entry is not one.
cursor() { journalctl -u $UNIT -n 1 --show-cursor -q | sed -n 's/^-- cursor: //p'; }
lines_after() { journalctl -u $UNIT -o cat --after-cursor="$1" -q; }
# events FILE: bursts and modes of a JSON Lines log (tests/vm/guest/events.sed).
events() { sed -n -f $V/events.sed "$1"; }

# The Kinova stand-in's log (the arm): moving points since a line count.
KINOVA_LOG=/var/lib/sipnpuff/kinova.log
kinova_lines() { wc -l < $KINOVA_LOG 2>/dev/null || echo 0; }
moving_since() { # LINE: points after it with a non-zero velocity
    tail -n +"$(( $1 + 1 ))" $KINOVA_LOG 2>/dev/null |
        awk '$2 == "SendAdvanceTrajectory" { for (i = 6; i <= 11; i++) { split($i, kv, "="); if (kv[2] + 0 != 0) { n++; break } } } END { print n + 0 }'
}
moving_more() { [ "$(moving_since "$1")" -gt 20 ]; }
wait_moving() { wait_for "$2" moving_more "$1"; } # LINE SECONDS: 20 moving points since LINE

# The service's main process, once active with a new one.
active_with_new_pid() { [ "$(prop ActiveState)" = active ] && [ "$(prop MainPID)" != "$1" ] && [ "$(prop MainPID)" != 0 ]; }

# threads PID: "name policy/priority" of each thread.
threads() {
    local t
    for t in /proc/$1/task/*; do
        awk '{ sub(/^[^)]*\) /, ""); print $38, $39 }' $t/stat | {
            read -r prio policy
            case $policy in 0) p=OTHER ;; 1) p=FIFO ;; 2) p=RR ;; *) p=$policy ;; esac
            echo "$(cat $t/comm) $p/$prio"
        }
    done
}

# report_after CURSOR: the final report (the last JSON line with "settings").
report_after() { lines_after "$1" | grep '"settings"' | tail -n 1; }

# ------------------------------------------------------------ first boot

step_install() {
    local t0 t1 groups
    t0=$(now_us)
    if ! apt-get install -y -q /opt/vmtest/debs/sipnpuff_A.deb > $ART/install.txt 2>&1; then
        fail install "apt install: $(tail -n 3 $ART/install.txt | tr '\n' ' ')"; return
    fi
    t1=$(now_us)
    groups=$(id -nG sipnpuff 2>/dev/null)
    for g in sipnpuff input dialout; do
        echo " $groups " | grep -q " $g " || { fail install "user sipnpuff is in '$groups', not $g"; return; }
    done
    [ "$(systemctl is-enabled $UNIT)" = enabled ] || { fail install "the unit is $(systemctl is-enabled $UNIT), not enabled"; return; }
    [ "$(systemctl is-active $UNIT)" != active ] || { fail install "the service started at install (it must wait for the setup)"; return; }
    if ! systemd-analyze verify $UNIT > $ART/verify.txt 2>&1 || [ -s $ART/verify.txt ]; then
        fail install "systemd-analyze verify: $(head -c 300 $ART/verify.txt)"; return
    fi
    pass install "$(dpkg-query -W -f '${Version}' sipnpuff) in $(ms_between $t0 $t1) ms; user sipnpuff in $groups; $UNIT enabled, not started; systemd-analyze verify clean"
}

# The person's setup, as the clinician writes it: the HID sensor, the
# arm through Kinova's library (the stand-in at its default folder), the
# virtual keyboard, the emulated guest's allowance for stalls.
step_configure() {
    sed -i 's/^SIPNPUFF_SENSOR=.*/SIPNPUFF_SENSOR="evdev:name=sipnpuff test joystick"/; s/^SIPNPUFF_ARM=.*/SIPNPUFF_ARM=kinova-sdk:usb/; s/^#SIPNPUFF_OUTPUTS=.*/SIPNPUFF_OUTPUTS=uinput/' /etc/default/sipnpuff
    echo "KINOVA_STANDIN_LOG=$KINOVA_LOG" >> /etc/default/sipnpuff
    cp $V/sipnpuff.toml $CONF
    md5sum < $CONF > $STATE/conf.md5
    md5sum < /etc/default/sipnpuff > $STATE/default.md5
    pass configure "SIPNPUFF_SENSOR, _ARM, _OUTPUTS set in /etc/default/sipnpuff; $CONF replaced"
}

# doctor as the service will run (its user, limits and environment).
step_doctor_service() {
    local rc
    systemd-run --quiet --pipe --wait -p User=sipnpuff -p LimitRTPRIO=90 -p LimitMEMLOCK=infinity \
        -p EnvironmentFile=/etc/default/sipnpuff sipnpuff doctor --config $CONF > $ART/doctor-service.txt 2>&1
    rc=$?
    if [ $rc -ne 0 ] || grep -q DENIED $ART/doctor-service.txt; then
        fail doctor-service "exit $rc: $(grep -A1 DENIED $ART/doctor-service.txt | head -c 400 | tr '\n' ' ')"; return
    fi
    pass doctor-service "exit 0, $(grep -c '^  ok' $ART/doctor-service.txt) ok, 0 denied: $(tail -n 1 $ART/doctor-service.txt)"
}

# doctor as a user without the service's groups and limits: each
# missing grant named.
step_doctor_plain() {
    local rc missing=""
    id plain >/dev/null 2>&1 || useradd --no-create-home --shell /usr/sbin/nologin plain
    runuser -u plain -- bash -c "set -a; . /etc/default/sipnpuff; exec sipnpuff doctor --config $CONF" \
        > $ART/doctor-plain.txt 2>&1
    rc=$?
    for what in SCHED_FIFO mlockall "sipnpuff test joystick" uinput; do
        grep DENIED $ART/doctor-plain.txt | grep -q "$what" || missing="$missing '$what'"
    done
    if [ $rc -ne 1 ] || [ -n "$missing" ]; then
        fail doctor-plain "exit $rc; no DENIED line for$missing: $(head -c 400 $ART/doctor-plain.txt | tr '\n' ' ')"; return
    fi
    pass doctor-plain "exit 1, $(grep -c '^  DENIED' $ART/doctor-plain.txt) denied: $(grep '^  DENIED' $ART/doctor-plain.txt | sed 's/^ *DENIED *//; s/: .*//' | tr '\n' ';' | sed 's/;$//')"
}

# ------------------------------------------------------------ second boot

step_boot() {
    local pid active user fifo lck node
    if ! wait_for 120 is_active; then
        fail boot "$UNIT is $(prop ActiveState)/$(prop SubState) 120 s after the test began: $(journalctl -u $UNIT -o cat -q | tail -n 3 | tr '\n' ' ')"; return
    fi
    pid=$(prop MainPID)
    active=$(prop ActiveEnterTimestampMonotonic)
    echo "$active" > $STATE/boot-active
    user=$(ps -o user= -p $pid)
    threads $pid > $ART/boot-threads.txt
    fifo=$(grep ' FIFO/' $ART/boot-threads.txt | tr '\n' ',' | sed 's/,$//')
    lck=$(awk '/^VmLck/ { print $2 }' /proc/$pid/status)
    node=$(hid_event)
    ls -l "$node" > $ART/boot-node.txt
    if [ "$user" != sipnpuff ] || [ "${lck:-0}" -eq 0 ]; then
        fail boot "user $user, VmLck ${lck:-0} kB"; return
    fi
    # The loop and the threads it waits on, each at its priority.
    for want in "control FIFO/80" "sensor-evdev FIFO/70" "arm FIFO/60" "kinova-sdk FIFO/60" "output uinput FIFO/50"; do
        grep -qx "$want" $ART/boot-threads.txt || { fail boot "no thread '$want' among: $fifo"; return; }
    done
    if ! ls -l /proc/$pid/fd 2>/dev/null | grep -q "$node"; then
        fail boot "the service does not hold $node open ($(cat $ART/boot-node.txt))"; return
    fi
    pass boot "boot to first tick $(( active / 1000 )) ms (READY=1 once the loop runs; systemd: $(systemd-analyze time 2>/dev/null | head -n 1 | sed 's/^Startup finished in //')); user $user; SCHED_FIFO: $fifo; VmLck $lck kB; $node $(awk '{ print $1, $3, $4 }' $ART/boot-node.txt)"
}

step_breaths() {
    local c k secs
    c=$(cursor)
    k=$(kinova_lines)
    secs=$(awk '!/^[ \t]*(#|$)/ && NF == 2 { t += $2 } END { printf "%d\n", (t + 999) / 1000 }' $V/pattern.txt)
    feed breaths $V/pattern.txt
    sleep $((secs + 8))
    unfeed
    lines_after "$c" > $ART/breaths.jsonl
    events $ART/breaths.jsonl > $ART/breaths.events
    if ! cmp -s $V/expected.txt $ART/breaths.events; then
        fail breaths "events '$(tr '\n' ' ' < $ART/breaths.events)', expected '$(tr '\n' ' ' < $V/expected.txt)'; feeder: $(tail -n 2 $ART/breaths.feed | tr '\n' ' ')"; return
    fi
    pass breaths "$(grep -c '^burst' $V/expected.txt) bursts and $(grep -c '^match' $V/expected.txt) modes as the host's replay ($(tr '\n' ' ' < $V/expected.txt | sed 's/ $//')); arm points moving: $(moving_since $k)"
}

# move STEP: plays a puff held in translate_x (move.txt) and returns
# once the arm moves, the service to be stopped mid-motion; sets C (the
# journal's cursor), K (the arm log's line count) and PID (the service's
# process) from before.
move() {
    C=$(cursor)
    K=$(kinova_lines)
    PID=$(prop MainPID)
    feed "$1" $V/move.txt
    wait_moving "$K" 30 && return 0
    unfeed
    fail "$1" "the arm never moved"
    return 1
}

step_restart() {
    local t0 t1 report c pid
    move restart || return
    c=$C pid=$PID
    t0=$(now_us)
    systemctl restart $UNIT
    t1=$(prop ActiveEnterTimestampMonotonic)
    unfeed
    report=$(lines_after "$c" | grep '"settings"' | tail -n 1)
    echo "$report" > $ART/restart-report.json
    if ! echo "$report" | grep -q '"stream_ended_with_zero":true'; then
        fail restart "the stopped run's report: $(echo "$report" | head -c 300)"; return
    fi
    if echo "$report" | grep -q '"braking_ticks":0[,}]'; then
        fail restart "the arm had stopped before the restart (the puff ended first): $(echo "$report" | grep -o '"velocity_at_stop":\[[^]]*\]')"; return
    fi
    if ! active_with_new_pid $pid; then fail restart "not active again: $(prop ActiveState)"; return; fi
    pass restart "stop and start $(ms_between $t0 $t1) ms (restart to first tick); stopped while moving: $(echo "$report" | grep -o '"velocity_at_stop":\[[^]]*\]'), braked in $(echo "$report" | grep -o '"braking_ticks":[0-9]*' | cut -d: -f2) ticks, the stream ended at zero"
}

step_kill() {
    local pid n t0 t1
    pid=$(prop MainPID)
    n=$(prop NRestarts)
    t0=$(now_us)
    systemctl kill -s SIGKILL --kill-whom=main $UNIT
    if ! wait_for 30 active_with_new_pid $pid; then
        fail kill "not restarted in 30 s: $(prop ActiveState)/$(prop SubState), NRestarts $(prop NRestarts)"; return
    fi
    t1=$(prop ActiveEnterTimestampMonotonic)
    pass kill "SIGKILL to first tick of the new process $(ms_between $t0 $t1) ms (RestartSec=1s); NRestarts $n -> $(prop NRestarts)"
}

step_watchdog() {
    local c k pid t0 t1 init last first gap timeout
    move watchdog || return
    c=$C k=$K pid=$PID
    t0=$(now_us)
    kill -STOP $pid
    if ! wait_for 60 active_with_new_pid $pid; then
        unfeed; fail watchdog "not restarted in 60 s: $(prop ActiveState)/$(prop SubState)"; return
    fi
    t1=$(prop ActiveEnterTimestampMonotonic)
    sleep 2
    unfeed
    journalctl -u $UNIT -o short-monotonic --after-cursor="$c" -q > $ART/watchdog.journal
    grep -q 'Watchdog timeout' $ART/watchdog.journal || { fail watchdog "no watchdog timeout in the journal"; return; }
    # The arm's points: the stopped process's last, the new one's first
    # (after its InitAPI; the old one may send a point or two between
    # t0 and the signal).
    tail -n +"$((k + 1))" $KINOVA_LOG > $ART/watchdog.kinova
    init=$(awk -v t="$t0" '$1 / 1000 > t && $2 ~ /^InitAPI/ { print NR; exit }' $ART/watchdog.kinova)
    [ -n "$init" ] || { fail watchdog "the new process never opened the arm (no InitAPI after the stop)"; return; }
    last=$(head -n "$init" $ART/watchdog.kinova | awk '$2 == "SendAdvanceTrajectory" { l = $0 } END { print l }')
    first=$(tail -n +"$init" $ART/watchdog.kinova | awk '$2 == "SendAdvanceTrajectory" { print; exit }')
    gap=$(awk -v a="${last%% *}" -v b="${first%% *}" 'BEGIN { printf "%d", (b - a) / 1e6 }')
    if ! echo "$first" | grep -q ' x=0 y=0 z=0 tx=0 ty=0 tz=0 '; then
        fail watchdog "the new process's first point moves: $first"; return
    fi
    timeout=$(sed -n 's/^\[ *\([0-9.]*\)\].*Watchdog timeout.*/\1/p' $ART/watchdog.journal | head -n 1)
    pass watchdog "SIGSTOP to the watchdog's timeout $(awk -v s="$timeout" -v t=$t0 'BEGIN { printf "%d", s * 1000 - t / 1000 }') ms, to the new process's first tick $(ms_between $t0 $t1) ms; no arm point for $gap ms: the stopped process's last$(echo "$last" | grep -o ' x=[^ ]*'), the new one's first zero"
}

step_upgrade() {
    local pid
    pid=$(prop MainPID)
    if ! apt-get install -y -q /opt/vmtest/debs/sipnpuff_B.deb > $ART/upgrade.txt 2>&1; then
        fail upgrade "apt install: $(tail -n 3 $ART/upgrade.txt | tr '\n' ' ')"; return
    fi
    md5sum < $CONF | cmp -s - $STATE/conf.md5 || { fail upgrade "$CONF changed by the upgrade"; return; }
    md5sum < /etc/default/sipnpuff | cmp -s - $STATE/default.md5 || { fail upgrade "/etc/default/sipnpuff changed by the upgrade"; return; }
    if ! wait_for 30 active_with_new_pid $pid; then
        fail upgrade "the service was not restarted on the new version: $(prop ActiveState), MainPID $(prop MainPID) (was $pid)"; return
    fi
    pass upgrade "$(dpkg-query -W -f '${Version}' sipnpuff) over A; $CONF and /etc/default/sipnpuff kept as changed; the service restarted (MainPID $pid -> $(prop MainPID))"
}

step_remove() {
    tail -n 3000 $KINOVA_LOG > $ART/kinova.tail
    apt-get remove -y -q sipnpuff > $ART/remove.txt 2>&1 || { fail remove "apt remove: $(tail -n 3 $ART/remove.txt | tr '\n' ' ')"; return; }
    [ ! -e /usr/bin/sipnpuff ] || { fail remove "/usr/bin/sipnpuff still there"; return; }
    [ "$(systemctl is-active $UNIT)" != active ] || { fail remove "the service still runs"; return; }
    md5sum < $CONF | cmp -s - $STATE/conf.md5 || { fail remove "$CONF not kept"; return; }
    id sipnpuff >/dev/null 2>&1 || { fail remove "the user is gone"; return; }
    pass remove "service stopped, program gone; $CONF kept as changed, user sipnpuff kept"
}

step_purge() {
    apt-get purge -y -q sipnpuff > $ART/purge.txt 2>&1 || { fail purge "apt purge: $(tail -n 3 $ART/purge.txt | tr '\n' ' ')"; return; }
    local left=""
    for p in /etc/sipnpuff /etc/default/sipnpuff /var/lib/sipnpuff; do [ -e $p ] && left="$left $p"; done
    getent passwd sipnpuff > /dev/null && left="$left user"
    getent group sipnpuff > /dev/null && left="$left group"
    [ -z "$left" ] || { fail purge "left behind:$left"; return; }
    pass purge "/etc/sipnpuff, /etc/default/sipnpuff, /var/lib/sipnpuff, the user and its group gone"
}

# ------------------------------------------------------------ artifacts
# The journals beside the steps' files; the host reads them from the
# image (debugfs) once the guest is off.

keep_artifacts() {
    journalctl -u $UNIT -o short-monotonic -q > $ART/service.journal 2>&1
    journalctl -b -o short-monotonic -q > $ART/boot.journal 2>&1
    sync
}

stage() {
    local boot
    boot=$(cat $STATE/boot 2>/dev/null || echo 0)
    boot=$((boot + 1))
    echo $boot > $STATE/boot
    say "boot $boot at $(( $(now_us) / 1000 )) ms (systemd: $(systemd-analyze time 2>/dev/null | head -n 1))"
    case $boot in
    1)
        step_install
        step_configure
        step_doctor_service
        step_doctor_plain
        say "rebooting"
        systemctl reboot
        ;;
    2)
        step_boot
        step_breaths
        step_restart
        step_kill
        step_watchdog
        step_upgrade
        step_remove
        step_purge
        keep_artifacts
        console DONE
        systemctl poweroff
        ;;
    *)
        say "boot $boot: nothing to do"
        systemctl poweroff
        ;;
    esac
}

case "${1:-}" in
gadget) gadget ;;
joystick) joystick ;;
stage) stage ;;
*) echo "usage: guest.sh gadget|stage" >&2; exit 2 ;;
esac
