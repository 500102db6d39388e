#!/usr/bin/env bash
# The deployment test: the Debian package installed and booted in a
# Debian 12 guest with systemd and the PREEMPT_RT kernel under QEMU, as
# the controller by the wheelchair runs it (docs/deploy.md).
#
#   bash tests/vm/deploy/run.sh             # about 5 minutes the first time, 3 after
#   bash tests/vm/deploy/run.sh --prepare   # only the tools and the root file system
#
# On a Debian 12 machine as root, after `bash packaging/check.sh` (it
# installs cargo-deb): builds the package twice (versions A and B, for
# the upgrade), a root file system with mmdebstrap (systemd, udev, the
# RT kernel; cached under VM_DIR/deploy/ by its package list), and an
# ext4 image of it holding the packages, the feeders (tests/vm/feeders),
# the Kinova SDK stand-in at /opt/kinova/API and the guest's steps
# (tests/vm/deploy/guest.sh, run by vmtest.service at each boot). The
# guest installs the package, checks `doctor`, reboots, then checks the
# service at boot (SCHED_FIFO, locked memory, the USB HID sensor through
# udev, the breaths' events against the host's replay), a restart, a
# SIGKILL, a SIGSTOPped loop (the watchdog), an upgrade, remove and
# purge, printing `PASS name figures` / `FAIL name reason`. Exits 1 on a
# FAIL, a step that printed nothing, or a guest still running after
# VM_TIMEOUT seconds (default 900).
#
# Environment: VM_DIR (default target/vm), VM_TIMEOUT (s).
# Kept after a run: VM_DIR/deploy/console.log, VM_DIR/deploy/artifacts/
# (the journals, doctor's outputs, the arm's log), summary.txt.
set -euo pipefail
cd "$(dirname "$0")/../../.."
ROOT=$PWD
HERE=$ROOT/tests/vm/deploy
OUT=${VM_DIR:-$ROOT/target/vm}/deploy
TIMEOUT=${VM_TIMEOUT:-900}
TARGET_DIR=${CARGO_TARGET_DIR:-$ROOT/target}
started=$SECONDS
step() { echo "vm-deploy: $* (at $((SECONDS - started)) s)"; }
die() {
    echo "vm-deploy: error: $*" >&2
    exit 1
}
# The steps the guest must report on, in order.
STEPS=(install configure doctor-service doctor-plain boot breaths restart kill watchdog upgrade remove purge)
# What the root file system holds besides the essentials.
PACKAGES=systemd-sysv,udev,dbus,kmod,linux-image-rt-amd64,adduser,procps,xxd
SUITE=bookworm
MIRRORS=("deb http://deb.debian.org/debian $SUITE main"
    "deb http://deb.debian.org/debian-security $SUITE-security main")
mkdir -p "$OUT"

# ------------------------------------------------------------ tools
step "tools"
missing=()
command -v mmdebstrap >/dev/null || missing+=(mmdebstrap)
# What the boot needs (with --prepare, only the root file system is made).
if [ "${1:-}" != --prepare ]; then
    command -v qemu-system-x86_64 >/dev/null || missing+=(qemu-system-x86)
    command -v mke2fs >/dev/null || missing+=(e2fsprogs)
    command -v gcc >/dev/null || missing+=(gcc)
    [ -f /usr/lib/x86_64-linux-gnu/libc.a ] || missing+=(libc6-dev)
fi
if ((${#missing[@]})); then
    [ "$(id -u)" = 0 ] || die "missing ${missing[*]}: run as root (apt-get install) or install them"
    step "installing ${missing[*]}"
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

# ------------------------------------------------------------ root file system
# Built once per package list and hook (about 80 s, 670 MB; most of it
# downloads). Its initrd holds only what mounts the root (virtio, ext4): Debian's
# full one takes TCG 10-50 s to unpack at each boot.
INITRD_HOOK='mkdir -p "$1/etc/initramfs-tools/conf.d" &&
    echo MODULES=list >"$1/etc/initramfs-tools/conf.d/vmtest" &&
    printf "%s\n" virtio_pci virtio_blk ext4 >>"$1/etc/initramfs-tools/modules" &&
    chroot "$1" update-initramfs -u -k all'
key=$(echo "$PACKAGES ${MIRRORS[*]} $INITRD_HOOK" | md5sum | cut -c1-12)
pristine=$OUT/rootfs-$key
if ! [ -f "$pristine/.complete" ]; then
    step "root file system: mmdebstrap $SUITE with $PACKAGES"
    rm -rf "$OUT"/rootfs-*
    mmdebstrap --quiet --variant=apt --include="$PACKAGES" --customize-hook="$INITRD_HOOK" \
        "$SUITE" "$pristine" "${MIRRORS[@]}" ||
        die "mmdebstrap failed"
    touch "$pristine/.complete"
fi
kernel=$(ls "$pristine"/boot/vmlinuz-* | head -n 1)
initrd=$(ls "$pristine"/boot/initrd.img-* | head -n 1)
[ -f "$kernel" ] && [ -f "$initrd" ] || die "$pristine has no kernel and initrd in /boot"
step "root file system: $(basename "$kernel")"

if [ "${1:-}" = --prepare ]; then
    exit 0
fi

# ------------------------------------------------------------ packages
cargo deb --version >/dev/null 2>&1 || die "no cargo-deb: run bash packaging/check.sh first (it installs it)"
step "packages: cargo deb, versions A and B"
cargo build --release --quiet
DEBS=$OUT/debs
rm -rf "$DEBS"
mkdir -p "$DEBS"
version=$(cargo metadata --no-deps --format-version 1 | sed 's/.*"name":"sipnpuff","version":"\([^"]*\)".*/\1/')
cargo deb --no-build --quiet --output "$DEBS/sipnpuff_A.deb" >/dev/null
cargo deb --no-build --quiet --deb-version "$version-99" --output "$DEBS/sipnpuff_B.deb" >/dev/null
step "packages: $(dpkg-deb -f "$DEBS/sipnpuff_A.deb" Version) and $(dpkg-deb -f "$DEBS/sipnpuff_B.deb" Version)"

# ------------------------------------------------------------ the guest's files
step "guest: feeders, Kinova stand-in, expected events"
tree=$OUT/tree
rm -rf "$tree"
cp -a "$pristine" "$tree"
rm -f "$tree/.complete"
V=$tree/opt/vmtest
mkdir -p "$V/bin" "$V/debs" "$tree/opt/kinova/API"
cp "$DEBS"/*.deb "$V/debs/"
for feeder in hidfeed stamp; do
    gcc -static -O2 -Wall -Wextra -Werror -o "$V/bin/$feeder" "$ROOT/tests/vm/feeders/$feeder.c" -lm
done
gcc -shared -fPIC -O2 -Wall -Werror -fvisibility=hidden -o "$tree/opt/kinova/API/Kinova.API.USBCommandLayerUbuntu.so" \
    "$ROOT/tests/peers/kinova_sdk/standin.c" -lm -lpthread
cp "$HERE/guest.sh" "$V/guest.sh"
cp "$ROOT/tests/vm/guest/events.sed" "$ROOT/tests/vm/pattern.txt" "$V/"
# The person's setup as the test's clinician writes it (the emulated
# guest stalls now and then: 1 s allowed, as in the VM harness).
cp "$ROOT/tests/vm/guest.toml" "$V/sipnpuff.toml"
# A puff held in translate_x: the arm moving when the service is stopped
# (2.5 s at 0.2 m/s from where the stand-in starts: short of the reach).
printf '2.5 1000\n3.6 170\n2.5 340\n3.6 160\n2.5 620\n3.6 2500\n2.5 1000\n' >"$V/move.txt"
# The joystick at rest between the steps' patterns.
printf '%s 1000\n' 2.5 >"$V/rest.txt"
# The breaths' events, from the host's replay of the pattern.
awk 'BEGIN { print "tick,volts" } { sub(/#.*/, "") } NF == 2 { for (i = 0; i < $2; i++) print t++ "," $1 }' \
    "$ROOT/tests/vm/pattern.txt" >"$OUT/pattern.csv"
"$TARGET_DIR/release/sipnpuff" replay "$OUT/pattern.csv" --config "$V/sipnpuff.toml" --events "$OUT/expected.jsonl" \
    2>"$OUT/replay.txt" || die "sipnpuff replay failed: $(cat "$OUT/replay.txt")"
sed -n -f "$ROOT/tests/vm/guest/events.sed" "$OUT/expected.jsonl" >"$V/expected.txt"
[ -s "$V/expected.txt" ] || die "the pattern's replay selects nothing"
step "guest: expected $(tr '\n' ' ' <"$V/expected.txt")"

# The test's units: the joystick plugged in before the service starts,
# the steps once the system is up; the console kept for their lines.
cat >"$tree/etc/systemd/system/vmtest-gadget.service" <<'EOF'
[Unit]
Description=VM test: the sip-and-puff joystick plugged in (a USB HID gadget)
After=systemd-udevd.service systemd-modules-load.service
Before=sipnpuff.service
[Service]
Type=oneshot
RemainAfterExit=yes
ExecStart=/opt/vmtest/guest.sh gadget
[Install]
WantedBy=multi-user.target
EOF
cat >"$tree/etc/systemd/system/vmtest-joystick.service" <<'EOF'
[Unit]
Description=VM test: the sip-and-puff joystick at rest
After=vmtest-gadget.service
Requires=vmtest-gadget.service
Before=sipnpuff.service
[Service]
ExecStart=/opt/vmtest/guest.sh joystick
[Install]
WantedBy=multi-user.target
EOF
cat >"$tree/etc/systemd/system/vmtest.service" <<'EOF'
[Unit]
Description=VM test: this boot's steps
After=multi-user.target
[Service]
Type=simple
ExecStart=/opt/vmtest/guest.sh stage
[Install]
WantedBy=multi-user.target
EOF
wants=$tree/etc/systemd/system/multi-user.target.wants
mkdir -p "$wants"
ln -sf /etc/systemd/system/vmtest-gadget.service "$wants/"
ln -sf /etc/systemd/system/vmtest-joystick.service "$wants/"
ln -sf /etc/systemd/system/vmtest.service "$wants/"
# No login prompts, timers or fsck: the console is for results.
for unit in serial-getty@ttyS0.service getty@tty1.service apt-daily.timer apt-daily-upgrade.timer \
    dpkg-db-backup.timer fstrim.timer e2scrub_all.timer systemd-fsck-root.service; do
    ln -sf /dev/null "$tree/etc/systemd/system/$unit"
done
echo controller >"$tree/etc/hostname"
echo "/dev/vda / ext4 rw,noatime 0 1" >"$tree/etc/fstab"
# The journal kept on disk: the second boot reads the first's.
mkdir -p "$tree/var/log/journal"

step "guest: ext4 image"
image=$OUT/controller.img
rm -f "$image"
mke2fs -q -t ext4 -d "$tree" -L controller "$image" 2G >/dev/null
rm -rf "$tree"

# ------------------------------------------------------------ boot
step "boot: QEMU TCG, 2 CPUs, 1 GiB, timeout ${TIMEOUT} s"
: >"$OUT/console.log"
rm -rf "$OUT/artifacts"
# The guest's reboot ends QEMU (-no-reboot) and the next boot is a new
# QEMU on the same disk: a reset inside TCG left the second boot 3-4
# times slower (its kernel 52 s against the first's 6 s).
boot_start=$SECONDS
qemu_status=0
for boot in 1 2 3; do
    left=$((TIMEOUT - (SECONDS - boot_start)))
    [ "$left" -gt 0 ] || { qemu_status=124; break; }
    mark=$(wc -l <"$OUT/console.log")
    set +e
    timeout --kill-after=10 "$left" qemu-system-x86_64 \
        -accel tcg -cpu max -smp 2 -m 1024 -no-reboot \
        -nodefaults -display none -monitor none \
        -kernel "$kernel" -initrd "$initrd" \
        -append "root=/dev/vda rw console=ttyS0 quiet systemd.show_status=0 net.ifnames=0" \
        -drive "file=$image,format=raw,if=virtio" \
        -serial stdio </dev/null |
        stdbuf -oL tr -d '\r' | tee -a "$OUT/console.log"
    qemu_status=${PIPESTATUS[0]}
    set -e
    [ "$qemu_status" = 0 ] || break
    grep -qx DONE "$OUT/console.log" && break
    # Another boot only when this one asked for it.
    tail -n +"$((mark + 1))" "$OUT/console.log" | grep -q '^vm: rebooting' || break
done
boot_seconds=$((SECONDS - boot_start))

# ------------------------------------------------------------ results
# The guest's artifacts, from its file system.
rm -rf "$OUT/art"
debugfs -R "rdump /var/lib/vmtest/art $OUT" "$image" >/dev/null 2>&1 || true
mv "$OUT/art" "$OUT/artifacts" 2>/dev/null || mkdir -p "$OUT/artifacts"
. "$ROOT/tests/vm/summary.sh"
{
    echo "VM deploy: $(basename "$kernel"), two boots and the steps ${boot_seconds} s, whole run $((SECONDS - started)) s"
    vm_summary "$OUT/console.log" "$qemu_status" "$TIMEOUT" "${STEPS[@]}"
} >"$OUT/summary.txt"
echo
echo "==== VM deploy summary (log: $OUT/console.log, artifacts: $OUT/artifacts/)"
cat "$OUT/summary.txt"
echo "vm-deploy: ${PASSED} passed, $((${#STEPS[@]} - PASSED)) failed"
exit $FAILED
