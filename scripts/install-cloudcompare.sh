#!/usr/bin/env bash
# Install CloudCompare (Debian's `cloudcompare`, 2.11.3 on bookworm) for `cargo xtask
# bench inspect`, which times its command-line cloud-to-mesh distance (C2M) on the same
# points and mesh as lampost-inspect (issue 16: faster than CloudCompare's C2M). A bench
# baseline only: no test needs it. It is a Qt application with many libraries, so it is
# installed with apt (root) rather than unpacked into .tools/; the bench runs it
# headless (QT_QPA_PLATFORM=offscreen). Safe to run again; prints the binary's path.
set -euo pipefail
if ! command -v CloudCompare >/dev/null 2>&1; then
  if [ "$(id -u)" -ne 0 ]; then
    echo "install-cloudcompare: CloudCompare is not installed and this is not root: run 'sudo apt-get install cloudcompare'" >&2
    exit 1
  fi
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends cloudcompare >/dev/null
fi
echo "C2M baseline ready: $(command -v CloudCompare)"
