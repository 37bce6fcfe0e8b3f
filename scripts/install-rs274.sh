#!/usr/bin/env bash
# Install LinuxCNC's standalone G-code interpreter `rs274` into .tools/rs274 (no system
# install: the Debian packages are downloaded and unpacked). Used by the tests that
# compare `lampost trace` with a real interpreter. Safe to run again.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
dest="$here/.tools/rs274"
bin="$dest/root/usr/bin/rs274"
libs="$dest/root/usr/lib:$dest/root/usr/lib/x86_64-linux-gnu"
if [ -x "$bin" ] && LD_LIBRARY_PATH="$libs" ldd "$bin" | grep -q "not found" ; then
  rm -rf "$dest"
fi
if [ ! -x "$bin" ]; then
  mkdir -p "$dest/debs"
  cd "$dest/debs"
  pkgs="linuxcnc-uspace libboost-python1.74.0"
  if ! apt-get download $pkgs >/dev/null 2>&1; then
    apt-get update >/dev/null
    apt-get download $pkgs >/dev/null
  fi
  for d in ./*.deb; do dpkg-deb -x "$d" "$dest/root"; done
  cd "$here"
  rm -rf "$dest/debs"
fi
missing=$(LD_LIBRARY_PATH="$libs" ldd "$bin" | grep "not found" || true)
if [ -n "$missing" ]; then
  echo "rs274 still lacks libraries:" >&2
  echo "$missing" >&2
  exit 1
fi
echo "rs274 ready: $bin"
