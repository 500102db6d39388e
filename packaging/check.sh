#!/usr/bin/env bash
# Builds the Debian package (`cargo deb`) and checks it as a deploying
# engineer would before installing it: its files and conffiles, lintian
# (no error; only the warnings docs/deploy.md lists), and the unit
# (`systemd-analyze verify`, its ExecStart pointed at the built binary:
# the VM harness verifies the installed one).
#
#   bash packaging/check.sh        # as root on Debian 12 the first time
#
# Installs what it lacks: cargo-deb (cargo install, about 75 s), lintian,
# systemd (for systemd-analyze).
set -euo pipefail
cd "$(dirname "$0")/.."
say() { echo "packaging: $*"; }
die() {
    echo "packaging: error: $*" >&2
    exit 1
}

CARGO_DEB_VERSION=3.8.0
if ! cargo deb --version >/dev/null 2>&1; then
    say "installing cargo-deb $CARGO_DEB_VERSION"
    cargo install --locked --quiet cargo-deb --version "$CARGO_DEB_VERSION"
fi
missing=()
command -v lintian >/dev/null || missing+=(lintian)
command -v systemd-analyze >/dev/null || missing+=(systemd)
if ((${#missing[@]})); then
    [ "$(id -u)" = 0 ] || die "missing ${missing[*]}: run as root (apt-get install) or install them"
    say "installing ${missing[*]}"
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

say "cargo deb"
deb=$(cargo deb 2>/dev/null | tail -n 1)
[ -f "$deb" ] || die "cargo deb made no package"
say "$deb ($(du -h "$deb" | cut -f1))"

listing=$(dpkg-deb -c "$deb" | awk '{ print $6 }')
for path in ./usr/bin/sipnpuff ./usr/lib/systemd/system/sipnpuff.service \
    ./usr/lib/udev/rules.d/70-sipnpuff.rules ./etc/sipnpuff/sipnpuff.toml ./etc/default/sipnpuff \
    ./usr/share/doc/sipnpuff/deploy.md ./usr/share/doc/sipnpuff/changelog.Debian.gz; do
    grep -qx "$path" <<<"$listing" || die "$deb lacks $path"
done
conffiles=$(dpkg-deb -f "$deb" Package >/dev/null && dpkg-deb --ctrl-tarfile "$deb" | tar -xO ./conffiles | sort | tr '\n' ' ')
[ "$conffiles" = "/etc/default/sipnpuff /etc/sipnpuff/sipnpuff.toml " ] ||
    die "conffiles are '$conffiles', not /etc/default/sipnpuff and /etc/sipnpuff/sipnpuff.toml"
say "files and conffiles as expected: $conffiles"

# The warnings docs/deploy.md lists, with its reasons.
allowed="initial-upload-closes-no-bugs no-manual-page"
report=$(lintian --tag-display-limit 0 "$deb" 2>&1 | grep -v 'running with root privileges' || true)
echo "$report" | sed '/^$/d; s/^/packaging: lintian: /'
errors=$(grep -c '^E:' <<<"$report" || true)
[ "$errors" = 0 ] || die "lintian: $errors error(s)"
for tag in $(awk '$1 == "W:" { print $3 }' <<<"$report"); do
    grep -qw -- "$tag" <<<"$allowed" || die "lintian warns $tag, which docs/deploy.md does not list"
done

unit=$(mktemp -d)
trap 'rm -rf "$unit"' EXIT
sed "s#/usr/bin/sipnpuff#$PWD/target/release/sipnpuff#" packaging/sipnpuff.service >"$unit/sipnpuff.service"
systemd-analyze verify "$unit/sipnpuff.service" || die "systemd-analyze verify: the unit has problems (above)"
say "systemd-analyze verify: clean; lintian: 0 errors"
