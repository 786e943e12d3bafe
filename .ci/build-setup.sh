#!/usr/bin/env bash
# What `cargo build` needs besides Rust, installed if missing (idempotent, quiet when present):
#   - libssl-dev and pkg-config: DDS Security (capsule_ros_base's default `security` feature,
#     RustDDS's builtin plugins) links the system's OpenSSL through the `openssl` crate
#   - openssl (the command): launch_scripts/capsule_keystore.sh makes SROS2 keystores with it
# Run before `cargo clippy` / `cargo build`.
set -euo pipefail

need_apt=()
pkg-config --exists openssl 2>/dev/null || need_apt+=(libssl-dev pkg-config)
command -v openssl >/dev/null 2>&1 || need_apt+=(openssl)
if [ "${#need_apt[@]}" -gt 0 ]; then
  echo "build-setup: apt-get install ${need_apt[*]}"
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${need_apt[@]}" >/dev/null
fi
echo "build-setup: ok (OpenSSL $(pkg-config --modversion openssl))"
