#!/usr/bin/env bash
# The home output's peers (tests/live/output_mqtt.rs): Debian's Mosquitto
# broker and clients (each test starts its own broker on a free port; the
# packaged service, which would hold port 1883, is stopped and disabled),
# and PyPI's paho-mqtt 2.x in a venv under target/peers/paho, the
# independent subscriber. Idempotent; run as root on a fresh Debian machine.
set -euo pipefail
root="$(cd "$(dirname "$0")/../../.." && pwd)"
venv="$root/target/peers/paho"

if ! command -v mosquitto >/dev/null || ! command -v mosquitto_pub >/dev/null ||
    ! python3 -c 'import ensurepip, venv' 2>/dev/null; then
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
        mosquitto mosquitto-clients python3 python3-venv >/dev/null
fi
# The package starts a broker on 1883 where an init system runs; the tests
# start their own.
if command -v systemctl >/dev/null && systemctl is-active --quiet mosquitto 2>/dev/null; then
    systemctl disable --now mosquitto >/dev/null 2>&1 || true
elif [ -x /etc/init.d/mosquitto ]; then
    /etc/init.d/mosquitto stop >/dev/null 2>&1 || true
fi
if [ ! -x "$venv/bin/python" ]; then
    mkdir -p "$(dirname "$venv")"
    python3 -m venv "$venv"
fi
if ! "$venv/bin/python" -c 'import paho.mqtt' 2>/dev/null; then
    "$venv/bin/pip" install --quiet --disable-pip-version-check 'paho-mqtt==2.1.0'
fi
echo "mqtt peers: $(mosquitto -h 2>/dev/null | head -n 1), paho-mqtt $("$venv/bin/python" -c 'import importlib.metadata as m; print(m.version("paho-mqtt"))')"
