#!/usr/bin/env bash
# The Kinova SDK stand-in's only need: a C compiler (the tests build
# tests/peers/kinova_sdk/standin.c into Kinova.API.USBCommandLayerUbuntu.so and
# Kinova.API.EthCommandLayerUbuntu.so in a temporary folder). Rust's toolchain
# links with `cc` already, so this is normally a no-op. Idempotent; run as root
# on a fresh Debian machine.
set -euo pipefail
if command -v cc >/dev/null 2>&1 || command -v gcc >/dev/null 2>&1; then
    echo "kinova-sdk stand-in: a C compiler is installed ($(command -v cc || command -v gcc))"
    exit 0
fi
apt-get update -qq
DEBIAN_FRONTEND=noninteractive apt-get install -y -qq gcc libc6-dev >/dev/null
echo "kinova-sdk stand-in: installed gcc"
