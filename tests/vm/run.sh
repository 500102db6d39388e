#!/usr/bin/env bash
# The VM harness: proves sipnpuff's sensor paths through the real Linux
# kernel (USB HID and CDC-ACM gadgets on dummy_hcd, an ADS1115 on i2c-stub
# with the real IIO driver, Debian's PREEMPT_RT kernel) in a QEMU guest,
# and its keyboard and pointer output through uinput and evdev.
#
#   bash tests/vm/run.sh
#
# On a Debian 12 machine as root: installs what it lacks (qemu-system-x86,
# busybox-static, kmod, cpio, rt-tests), downloads Debian's PREEMPT_RT
# kernel once (cached under target/vm/kernel/), builds sipnpuff and the C
# test drivers (tests/vm/feeders/), computes the expected events on the
# host (`sipnpuff replay` of tests/vm/pattern.txt and
# tests/vm/uinput-pattern.txt), packs an initramfs,
# boots it under QEMU (TCG: nested KVM hangs here), and reads the guest's
# `PASS name ...` / `FAIL name ...` lines from the serial console. Exits 1
# on any FAIL, on a test of tests/vm/tests.txt that printed nothing, or on
# a boot that did not finish within VM_TIMEOUT seconds (default 900). A test
# that fails in the guest is run once more there (an emulated guest on a
# busy host can be starved); the first attempt's failure is printed and
# the retries counted.
#
# Environment: VM_DIR (default target/vm: the log, artifacts and cache),
# VM_TIMEOUT (s), VM_TESTS ("kernel modules ..." to run only those),
# VM_SOAK_LOADS (the soak test's loads, default "cpu"; also "vm hdd"),
# VM_REFRESH_KERNEL=1 (download the newest RT kernel again).
# Kept after a run: VM_DIR/console.log (the guest's console),
# VM_DIR/artifacts/ (each test's events, reports and feeder logs; dmesg),
# VM_DIR/expected/ (the expected events), VM_DIR/summary.txt.
set -euo pipefail
cd "$(dirname "$0")/../.."
ROOT=$PWD
HERE=$ROOT/tests/vm
OUT=${VM_DIR:-$ROOT/target/vm}
TIMEOUT=${VM_TIMEOUT:-900}
TARGET_DIR=${CARGO_TARGET_DIR:-$ROOT/target}
started=$SECONDS
step() { echo "vm-harness: $* (at $((SECONDS - started)) s)"; }
die() {
    echo "vm-harness: error: $*" >&2
    exit 1
}

# The modules the guest loads (their dependencies are added in order).
MODULES=(uinput evdev dummy_hcd usb_f_hid usb_f_acm usbhid hid-generic cdc-acm
    i2c-stub i2c-dev ti-ads1015 bmi160_i2c)
# Sample periods (ms) of the serial dialects: FLipMouse 50, LipSync 100.
DIALECTS=(flipmouse:50 lipsync:100)

mkdir -p "$OUT"

# ------------------------------------------------------------ tools
step "tools"
missing=()
command -v qemu-system-x86_64 >/dev/null || missing+=(qemu-system-x86)
# The guest needs a static busybox (busybox-static replaces busybox).
if ! [ -x /bin/busybox ] || ldd /bin/busybox >/dev/null 2>&1; then missing+=(busybox-static); fi
command -v cpio >/dev/null || missing+=(cpio)
command -v depmod >/dev/null && command -v modprobe >/dev/null || missing+=(kmod)
command -v cyclictest >/dev/null || missing+=(rt-tests)
command -v stress-ng >/dev/null || missing+=(stress-ng)
command -v gcc >/dev/null || missing+=(gcc)
command -v make >/dev/null || missing+=(make)
[ -f /usr/lib/x86_64-linux-gnu/libc.a ] || missing+=(libc6-dev)
[ -f /usr/include/linux/i2c-dev.h ] || missing+=(linux-libc-dev)
apt_updated=0
apt_update() {
    if [ $apt_updated = 0 ]; then
        apt-get update -qq
        apt_updated=1
    fi
}
if ((${#missing[@]})); then
    [ "$(id -u)" = 0 ] || die "missing ${missing[*]}: run as root (apt-get install) or install them"
    step "installing ${missing[*]}"
    apt_update
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

# ------------------------------------------------------------ kernel
# Cached as VM_DIR/kernel/<package>/: vmlinuz, the needed modules and
# their insmod order; the 400 MB unpacked tree is not kept.
wanted="${MODULES[*]}"
kernel=""
if [ "${VM_REFRESH_KERNEL:-0}" != 1 ]; then
    for d in "$OUT"/kernel/*/; do
        if [ -f "$d/complete" ] && [ "$(cat "$d/complete")" = "$wanted" ]; then kernel=${d%/}; fi
    done
fi
if [ -z "$kernel" ]; then
    step "kernel: finding Debian's PREEMPT_RT kernel package"
    pkg=$(apt-cache depends linux-image-rt-amd64 2>/dev/null |
        awk '$1 == "Depends:" && $2 ~ /^linux-image-[0-9]/ { print $2; exit }') || true
    if [ -z "$pkg" ]; then
        apt_update
        pkg=$(apt-cache depends linux-image-rt-amd64 |
            awk '$1 == "Depends:" && $2 ~ /^linux-image-[0-9]/ { print $2; exit }')
    fi
    [ -n "$pkg" ] || die "apt-cache finds no linux-image-*-rt-amd64 behind linux-image-rt-amd64"
    kernel=$OUT/kernel/$pkg
    tmp=$OUT/kernel/download
    rm -rf "$tmp" "$kernel"
    mkdir -p "$tmp" "$kernel/modules"
    step "kernel: downloading $pkg"
    (cd "$tmp" && apt-get -o APT::Sandbox::User=root download -qq "$pkg")
    dpkg-deb -x "$tmp"/*.deb "$tmp/root"
    kver=$(ls "$tmp/root/lib/modules")
    [ -f "$tmp/root/boot/vmlinuz-$kver" ] || die "$pkg has no boot/vmlinuz-$kver"
    depmod -b "$tmp/root" "$kver"
    # Each module after its dependencies, each once.
    for m in "${MODULES[@]}"; do
        modprobe -d "$tmp/root" -S "$kver" --show-depends "$m" ||
            die "$pkg has no module $m"
    done | awk '$1 == "insmod" { print $2 }' | awk '!seen[$0]++' >"$tmp/paths"
    while read -r path; do
        name=$(basename "$path")
        name=${name%.ko*}
        case "$path" in
        *.ko) cp "$path" "$kernel/modules/$name.ko" ;;
        *.ko.xz) xz -dc "$path" >"$kernel/modules/$name.ko" ;;
        *.ko.zst) zstd -qdc "$path" >"$kernel/modules/$name.ko" ;;
        *) die "unexpected module file $path" ;;
        esac
        echo "$name"
    done <"$tmp/paths" >"$kernel/modules/order"
    cp "$tmp/root/boot/vmlinuz-$kver" "$kernel/vmlinuz"
    echo "$kver" >"$kernel/version"
    rm -rf "$tmp"
    echo "$wanted" >"$kernel/complete"
fi
step "kernel: $(basename "$kernel") ($(cat "$kernel/version")), $(wc -l <"$kernel/modules/order") modules"

# The BMI160 emulated on i2c-stub has no interrupt line, and Debian's
# kernel builds no software IIO trigger: tests/vm/kmod/ is an hrtimer
# trigger standing in for its data-ready interrupt, built against the
# kernel's headers (linux-headers-KVER, installed once) and cached beside
# the kernel until its source changes.
kver=$(cat "$kernel/version")
TRIGGER_KO=$kernel/extra/sipnpuff_tick_trigger.ko
trigger_sum=$(cat "$HERE"/kmod/* | md5sum | cut -d' ' -f1)
if [ "$(cat "$kernel/extra/sum" 2>/dev/null)" != "$trigger_sum" ]; then
    if ! [ -d "/usr/src/linux-headers-$kver" ]; then
        [ "$(id -u)" = 0 ] || die "missing linux-headers-$kver: run as root (apt-get install) or install it"
        step "installing linux-headers-$kver"
        apt_update
        DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "linux-headers-$kver" >/dev/null
    fi
    step "kernel: building tests/vm/kmod against linux-headers-$kver"
    rm -rf "$kernel/extra"
    mkdir -p "$kernel/extra/src"
    cp "$HERE"/kmod/* "$kernel/extra/src/"
    make -s -C "/usr/src/linux-headers-$kver" M="$kernel/extra/src" modules 2>&1 | grep -v "Skipping BTF" || true
    [ -f "$kernel/extra/src/sipnpuff_tick_trigger.ko" ] || die "tests/vm/kmod did not build against linux-headers-$kver"
    cp "$kernel/extra/src/sipnpuff_tick_trigger.ko" "$TRIGGER_KO"
    echo "$trigger_sum" >"$kernel/extra/sum"
fi

# ------------------------------------------------------------ build
step "build: cargo build --release"
cargo build --release --quiet
SIPNPUFF=$TARGET_DIR/release/sipnpuff
[ -x "$SIPNPUFF" ] || die "no $SIPNPUFF after cargo build"
BUILD=$OUT/build
rm -rf "$BUILD"
mkdir -p "$BUILD/bin"
step "build: the test drivers (gcc -static)"
for src in "$HERE"/feeders/*.c; do
    gcc -static -O2 -Wall -Wextra -Werror -o "$BUILD/bin/$(basename "$src" .c)" "$src" -lm
done

# ------------------------------------------------------------ expected events
step "expected events: sipnpuff replay of the patterns"
EXP=$OUT/expected
rm -rf "$EXP"
mkdir -p "$EXP"

# A pattern as a 1 ms CSV, checked line by line. Its `unplug`/`replug`
# markers become NaN samples (the detector's sensor fault): GAP=none
# ignores them, GAP=end is NaN from `unplug` to the end (no reconnect),
# GAP=N is NaN from `unplug` to N ms after `replug`.
pattern_csv() { # PATTERN GAP > CSV
    awk -v file="$1" -v gap="$2" '
        BEGIN { print "tick,volts"; nan_from = -1; nan_to = -1 }
        { sub(/#.*/, "") }
        NF == 0 { next }
        NF == 1 && ($1 == "unplug" || $1 == "replug") {
            if (steps == 0) { printf "%s line %d: the pattern must begin with the neutral\n", file, NR > "/dev/stderr"; exit 1 }
            if ($1 == "unplug") unplug = t; else replug = t
            next }
        NF != 2 || $1 !~ /^[0-9]+(\.[0-9]+)?$/ || $2 !~ /^[0-9]+$/ || $1 + 0 > 5 || $2 + 0 == 0 {
            printf "%s line %d: expected `<volts 0..5> <ms>`, `unplug` or `replug`\n", file, NR > "/dev/stderr"; exit 1 }
        { steps++
          if (steps == 1 && $2 + 0 < 3000) {
              printf "%s line %d: the first step (the neutral) must last at least 3000 ms for the re-zero\n", file, NR > "/dev/stderr"; exit 1 }
          for (i = 0; i < $2; i++) v[t++] = $1 }
        END {
            if (gap != "none" && unplug == "") { printf "%s: no `unplug`\n", file > "/dev/stderr"; exit 1 }
            if (gap == "end") { nan_from = unplug; nan_to = t }
            else if (gap != "none") {
                if (replug == "") { printf "%s: no `replug`\n", file > "/dev/stderr"; exit 1 }
                nan_from = unplug; nan_to = replug + gap }
            for (i = 0; i < t; i++) printf "%d,%s\n", i, (i >= nan_from && i < nan_to ? "NaN" : v[i]) }
    ' "$1"
}
pattern_csv "$HERE/pattern.txt" none >"$OUT/pattern.csv" || die "bad pattern"
pattern_ms=$(($(wc -l <"$OUT/pattern.csv") - 1))

expected_from() { # CSV NAME [CONFIG]: replay it, keep the events and their bursts and modes
    "$SIPNPUFF" replay "$1" --config "${3:-$HERE/guest.toml}" --events "$EXP/$2.jsonl" 2>"$EXP/$2.replay.txt" ||
        die "sipnpuff replay $1 failed: $(cat "$EXP/$2.replay.txt")"
    sed -n -f "$HERE/guest/events.sed" "$EXP/$2.jsonl" >"$EXP/$2.txt"
    [ -s "$EXP/$2.txt" ] || die "the replay of $1 gave no burst and no mode: the pattern selects nothing"
}
expected_from "$OUT/pattern.csv" kHz
echo "vm-harness: at 1 kHz: $(tr '\n' ' ' <"$EXP/kHz.txt")"

# Switches are levels: a sip key held reads 0 V, a puff key 5 V, nothing
# the neutral (src/sensor/evdev/events.rs).
awk -F, 'NR == 1 { print; next } NR == 2 { n = $2 }
         { printf "%s,%s\n", $1, ($2 < n ? "0.0" : $2 > n ? "5.0" : $2) }' "$OUT/pattern.csv" >"$OUT/switches.csv"
expected_from "$OUT/switches.csv" switches

# The unplug pattern: without reconnecting (the device is gone to the end)
# and with (back 1 s after `replug`).
pattern_csv "$HERE/pattern-unplug.txt" end >"$OUT/unplug.csv" || die "bad pattern"
expected_from "$OUT/unplug.csv" unplug
pattern_csv "$HERE/pattern-unplug.txt" 1000 >"$OUT/reconnect.csv" || die "bad pattern"
expected_from "$OUT/reconnect.csv" reconnect
echo "vm-harness: unplugged: $(tr '\n' ' ' <"$EXP/unplug.txt"); reconnecting: $(tr '\n' ' ' <"$EXP/reconnect.txt")"

# The keyboard and pointer (--output uinput): the breaths of
# uinput-pattern.txt with the library of uinput-library.toml (a chord, a
# click, a double click, the pointer's axes).
cat "$HERE/guest.toml" "$HERE/uinput-library.toml" >"$OUT/uinput.toml"
pattern_csv "$HERE/uinput-pattern.txt" none >"$OUT/uinput.csv" || die "bad pattern"
expected_from "$OUT/uinput.csv" uinput "$OUT/uinput.toml"
echo "vm-harness: uinput: $(tr '\n' ' ' <"$EXP/uinput.txt")"

# The head-worn IMU (an evdev accelerometer played by imufeed): the
# simulated `typical` person drives the arm with their gestures
# (fixtures/gesture-user/: a nod selects translate_x, a shake translate_y,
# each followed by the head pitched 20° for 2.5 s). The feeder writes
# counts (4096 per g, 1000 per °/s: the device's resolutions); the host
# replays those counts as sipnpuff's backend reads them (count × 9.80665 /
# 4096 m/s², count × π / 180 / 1000 rad/s).
IMU_UNPLUG_MS=6500 # 1 s into the first hold: the arm moving along x
"$SIPNPUFF" generate --imu-user typical --session drive --gestures nod,shake --tilt-deg 20 \
    --hold-ms 2500 --seed 3 --out "$OUT/imu-drive.csv" 2>/dev/null || die "sipnpuff generate of the IMU session failed"
awk -F, 'NR == 1 { next }
    function r(x) { return x < 0 ? -int(-x + 0.5) : int(x + 0.5) }
    { pi = atan2(0, -1); printf "%d", $1
      for (i = 2; i <= 4; i++) printf " %d", r($i / 9.80665 * 4096)
      for (i = 5; i <= 7; i++) printf " %d", r($i * 180 / pi * 1000)
      printf "\n" }' "$OUT/imu-drive.csv" >"$OUT/imu-drive.counts"
imu_csv() { # LAST_MS: the counts as the backend reads them, up to LAST_MS
    awk -v last="$1" 'BEGIN { print "tick,ax,ay,az,gx,gy,gz"; pi = atan2(0, -1); a = 9.80665 / 4096; g = pi / 180 / 1000 }
        $1 > last { exit }
        { printf "%d,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g\n", $1, $2 * a, $3 * a, $4 * a, $5 * g, $6 * g, $7 * g }' "$OUT/imu-drive.counts"
}
IMU_MS=$(tail -n 1 "$OUT/imu-drive.counts" | cut -d' ' -f1)
# The gesture user's configuration, its set where the guest has it; the
# IMU allowed 1 s of silence (as guest.toml allows the breath sensor).
imu_config() { # SET_PATH
    cat "$HERE/guest.toml"
    printf '[gestures]\nset = "%s"\nstale_ms = 1000\n' "$1"
    sed -n '/^\[\[sequence\]\]/,$p' "$ROOT/fixtures/gesture-user/config.toml"
}
imu_config "$ROOT/fixtures/gesture-user/gestures.toml" >"$OUT/imu.host.toml"
imu_config /harness/gestures.toml >"$OUT/imu.toml"
# expected_drive NAME CSV_FUNCTION: the expected events of the drive as
# CSV_FUNCTION LAST_MS writes it: whole (NAME), up to the unplug
# (NAME-to-unplug) and driving on 500 ms past it (NAME-unplug).
expected_drive() {
    local name=$1 csv=$2 part last
    for part in ":$IMU_MS" "-to-unplug:$IMU_UNPLUG_MS" "-unplug:$((IMU_UNPLUG_MS + 500))"; do
        last=${part##*:}
        "$csv" "$last" >"$OUT/$name${part%:*}.csv"
        expected_from "$OUT/$name${part%:*}.csv" "$name${part%:*}" "$OUT/imu.host.toml"
    done
}
expected_drive imu imu_csv
printf 'IMU_MS=%s\nIMU_UNPLUG_MS=%s\n' "$IMU_MS" "$IMU_UNPLUG_MS" >"$OUT/imu.env"
echo "vm-harness: IMU: $(tr '\n' ' ' <"$EXP/imu.txt"); to the unplug: $(tr '\n' ' ' <"$EXP/imu-to-unplug.txt")"

# The same drive as an IIO IMU (a BMI160 on i2c-stub, the tests iio-imu
# and iio-imu-buffered): counts at the ranges imufeed --prime sets (±4 g,
# ±500 °/s), read back at the scales its driver gives (in_accel_scale
# 0.001197 m/s², in_anglvel_scale 0.000266 rad/s a count).
BMI_A=0.001197
BMI_G=0.000266
awk -F, -v a=$BMI_A -v g=$BMI_G 'NR == 1 { next }
    function r(x) { return x < 0 ? -int(-x + 0.5) : int(x + 0.5) }
    { printf "%d %d %d %d %d %d %d\n", $1, r($2 / a), r($3 / a), r($4 / a), r($5 / g), r($6 / g), r($7 / g) }' \
    "$OUT/imu-drive.csv" >"$OUT/imu-drive.bmi160"
awk '{ for (i = 2; i <= 7; i++) if ($i > 32767 || $i < -32768) { print "the drive overflows the BMI160 at tick " $1; exit 1 } }' \
    "$OUT/imu-drive.bmi160" || die "the IMU drive does not fit the BMI160's ranges"
bmi160_csv() { # LAST_MS: the BMI160's counts as the backend reads them
    awk -v last="$1" -v a=$BMI_A -v g=$BMI_G 'BEGIN { print "tick,ax,ay,az,gx,gy,gz" }
        $1 > last { exit }
        { printf "%d,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g\n", $1, $2 * a, $3 * a, $4 * a, $5 * g, $6 * g, $7 * g }' "$OUT/imu-drive.bmi160"
}
expected_drive bmi160 bmi160_csv
echo "vm-harness: BMI160: $(tr '\n' ' ' <"$EXP/bmi160.txt"); to the unplug: $(tr '\n' ' ' <"$EXP/bmi160-to-unplug.txt")"

# Both sensors at once (`run --sensor HID --imu IMU`): the IMU plays the
# same drive while the HID gadget rests; once the drive is over and the
# head rests (the feeder holds its last counts: `frozen_ms` allows it), a
# long sip and a short puff on the gadget select save_point. What the
# guest must see is the IMU's events, then the breaths' as the host's
# replay of them alone reads them.
BOTH_REST_MS=$((IMU_MS + 1500))
printf '2.5 %s\n1.4 830\n2.5 370\n3.6 160\n2.5 2500\n' "$BOTH_REST_MS" >"$OUT/both-pattern.txt"
BOTH_MS=$((BOTH_REST_MS + 830 + 370 + 160 + 2000))
both_config() { # SET_PATH
    cat "$HERE/guest.toml"
    printf '[gestures]\nset = "%s"\nstale_ms = 1000\nfrozen_ms = 60000\n' "$1"
    sed -n '/^\[\[sequence\]\]/,$p' "$ROOT/fixtures/gesture-user/config.toml"
    printf '\n[[sequence]]\nactions = [2, -1]\nmode = "save_point"\n'
}
both_config /harness/gestures.toml >"$OUT/both.toml"
{ cat "$HERE/guest.toml"; printf '\n[[sequence]]\nactions = [2, -1]\nmode = "save_point"\n'; } >"$OUT/both-breath.toml"
printf '2.5 3500\n1.4 830\n2.5 370\n3.6 160\n2.5 2500\n' >"$OUT/both-breath-pattern.txt"
pattern_csv "$OUT/both-breath-pattern.txt" none >"$OUT/both-breath.csv" || die "bad pattern"
expected_from "$OUT/both-breath.csv" both-breath "$OUT/both-breath.toml"
cat "$EXP/imu.txt" "$EXP/both-breath.txt" >"$EXP/both.txt"
printf 'BOTH_MS=%s\n' "$BOTH_MS" >>"$OUT/imu.env"
echo "vm-harness: breath and IMU: $(tr '\n' ' ' <"$EXP/both.txt")"

# A dialect samples the pattern every P ms; the loop holds each value until
# the next. Which ms the samples fall on is chance: replay four phases. The
# guest accepts any of the outcomes (usually all four agree).
for d in "${DIALECTS[@]}"; do
    name=${d%%:*}
    period=${d##*:}
    for k in 0 1 2 3; do
        phase=$((period * k / 4))
        awk -F, -v p="$period" -v f="$phase" '
            NR == 1 { print; next }
            { v[NR - 2] = $2 }
            END { n = NR - 1
                  for (t = 0; t < n; t++) {
                      s = t < f ? 0 : int((t - f) / p) * p + f
                      printf "%d,%s\n", t, v[s] } }' "$OUT/pattern.csv" >"$OUT/$name.$k.csv"
        expected_from "$OUT/$name.$k.csv" "$name.$k"
        rm -f "$OUT/$name.$k.csv"
    done
    outcomes=$(for k in 0 1 2 3; do md5sum <"$EXP/$name.$k.txt"; done | sort -u | wc -l)
    same=no
    cmp -s "$EXP/$name.0.txt" "$EXP/kHz.txt" && [ "$outcomes" = 1 ] && same=yes
    echo "vm-harness: $name at ${period} ms: $outcomes outcome(s) over 4 phases; as at 1 kHz: $same"
done

# ------------------------------------------------------------ initramfs
step "initramfs"
RD=$OUT/initramfs
rm -rf "$RD"
mkdir -p "$RD"/{bin,dev,proc,sys,tmp,harness/bin,harness/modules,harness/expected}
cp /bin/busybox "$RD/bin/busybox"
cp "$HERE/guest/init" "$RD/init"
chmod 755 "$RD/init"
cp "$BUILD"/bin/* "$RD/harness/bin/"
cp "$kernel"/modules/* "$TRIGGER_KO" "$RD/harness/modules/"
echo sipnpuff_tick_trigger >>"$RD/harness/modules/order"
cp "$HERE/pattern.txt" "$HERE/pattern-unplug.txt" "$HERE/uinput-pattern.txt" "$HERE/guest.toml" "$HERE/guest/events.sed" \
    "$OUT/pattern.csv" "$OUT/uinput.csv" "$OUT/uinput.toml" "$RD/harness/"
cp "$OUT/imu-drive.counts" "$OUT/imu-drive.bmi160" "$OUT/imu.toml" "$OUT/imu.env" "$OUT/both.toml" "$OUT/both-pattern.txt" "$RD/harness/"
cp "$ROOT/fixtures/gesture-user/gestures.toml" "$RD/harness/gestures.toml"
cp "$ROOT/fixtures/demo.csv" "$RD/harness/demo.csv"
echo "${VM_SOAK_LOADS:-cpu}" >"$RD/harness/soak-loads" # the soak test's loads
cp "$EXP"/*.txt "$EXP"/*.jsonl "$RD/harness/expected/"
if [ -n "${VM_TESTS:-}" ]; then
    printf "%s\n" $VM_TESTS >"$RD/harness/tests.txt" # one name a line
else
    cp "$HERE/tests.txt" "$RD/harness/tests.txt"
fi
# Dynamic programs with the shared libraries ldd lists and the loader.
with_libs() { # BINARY DEST
    cp "$1" "$2"
    ldd "$1" | awk '$2 == "=>" && $3 ~ /^\// { print $3 } $1 ~ /^\// { print $1 }' |
        while read -r lib; do
            mkdir -p "$RD$(dirname "$lib")"
            cp -L "$lib" "$RD$lib"
        done
}
with_libs "$SIPNPUFF" "$RD/harness/bin/sipnpuff"
with_libs "$(command -v cyclictest)" "$RD/bin/cyclictest"
with_libs "$(command -v stress-ng)" "$RD/bin/stress-ng"
(cd "$RD" && find . | cpio -o -H newc --quiet) | gzip -1 >"$OUT/initrd.gz"
step "initramfs: $(du -h "$OUT/initrd.gz" | cut -f1)"

# ------------------------------------------------------------ boot
# The tests the guest must report on.
if [ -n "${VM_TESTS:-}" ]; then
    read -r -a tests <<<"$VM_TESTS"
else
    mapfile -t tests < <(sed 's/#.*//; s/[[:space:]]//g; /^$/d' "$HERE/tests.txt")
fi
step "boot: QEMU TCG, 2 CPUs, 1 GiB, timeout ${TIMEOUT} s (pattern ${pattern_ms} ms)"
rm -f "$OUT/console.log" "$OUT/artifacts.txt"
rm -rf "$OUT/artifacts"
boot_start=$SECONDS
set +e
timeout --kill-after=10 "$TIMEOUT" qemu-system-x86_64 \
    -accel tcg -cpu max -smp 2 -m 1024 \
    -nodefaults -display none -no-reboot -monitor none \
    -kernel "$kernel/vmlinuz" -initrd "$OUT/initrd.gz" \
    -append "console=ttyS0 panic=-1 quiet" \
    -serial stdio -serial "file:$OUT/artifacts.txt" </dev/null |
    tr -d '\r' | tee "$OUT/console.log"
qemu_status=${PIPESTATUS[0]}
set -e
boot_seconds=$((SECONDS - boot_start))

# ------------------------------------------------------------ results
mkdir -p "$OUT/artifacts"
if [ -f "$OUT/artifacts.txt" ]; then
    tr -d '\r' <"$OUT/artifacts.txt" | awk -v dir="$OUT/artifacts" '
        /^=== FILE / { f = dir "/" substr($0, 10); printf "" > f; next }
        /^=== END$/ { close(f); f = ""; next }
        f != "" { print >> f }'
fi
. "$HERE/summary.sh"
{
    echo "VM harness: $(cat "$kernel/version"), boot and tests ${boot_seconds} s, whole run $((SECONDS - started)) s"
    vm_summary "$OUT/console.log" "$qemu_status" "$TIMEOUT" "${tests[@]}"
} >"$OUT/summary.txt"
echo
echo "==== VM harness summary (log: $OUT/console.log, artifacts: $OUT/artifacts/)"
cat "$OUT/summary.txt"
retried=$(grep -c "^vm: retry " "$OUT/console.log" || true)
grep "^vm: first attempt: FAIL" "$OUT/console.log" || true
echo "vm-harness: ${PASSED} passed (${retried} of the tests run a second time after a first attempt failed), $((${#tests[@]} - PASSED)) failed"
exit $FAILED
