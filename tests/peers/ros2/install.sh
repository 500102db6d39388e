#!/usr/bin/env bash
# The ROS 2 peer: Eclipse Cyclone DDS (the DDS under rmw_cyclonedds), from
# PyPI's `cyclonedds` (its wheel carries the C library), in a venv under
# target/peers/cyclonedds. Idempotent; run as root on a fresh Debian
# machine (apt for python3-venv and iproute2: the tests run each peer and
# sipnpuff in a private network namespace, whose loopback `ip` brings up).
set -euo pipefail
root="$(cd "$(dirname "$0")/../../.." && pwd)"
venv="$root/target/peers/cyclonedds"

if ! python3 -c 'import ensurepip, venv' 2>/dev/null || ! command -v ip >/dev/null; then
    apt-get update
    DEBIAN_FRONTEND=noninteractive apt-get install -y python3 python3-venv iproute2
fi
if [ ! -x "$venv/bin/python" ]; then
    mkdir -p "$(dirname "$venv")"
    python3 -m venv "$venv"
fi
if ! "$venv/bin/python" -c 'import cyclonedds' 2>/dev/null; then
    "$venv/bin/pip" install --quiet --disable-pip-version-check 'cyclonedds==11.0.1'
fi
"$venv/bin/python" -c 'import importlib.metadata as m; print("cyclonedds", m.version("cyclonedds"))'
