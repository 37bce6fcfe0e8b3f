#!/usr/bin/env bash
# Install real meshes nobody in this project made into .tools/meshes: OFF files from
# CGAL's data set, as Debian ships them in the package libcgal-demo (5.5.1-2, in
# usr/share/doc/libcgal-dev/data.tar.gz, data/meshes/). No root and no system install:
# the package is downloaded (apt-get download) and unpacked (dpkg-deb -x). Each file is
# checked against its pinned sha256. Used by crates/plan/tests/slice_oracle.rs and
# `cargo xtask bench plan`. Safe to run again; sources in docs/mesh.md.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
dest="$here/.tools/meshes"
sums="ab651cb04955c161efaeb079035a1e5e1f0e0d1f816a2df67beaea68f393ff2b  bunny00.off
edffb263f037b023757259befd5532fccb48bdc3c35a1da2e11e235a647bd050  fandisk.off
be4e1ea68f5f840a3d2ada69d828222e76a57d9e25b21e19a9deacd3f2328e02  elephant.off
6f7f3ca1abc506569466b72f2f59d49493a284e7376d7a7e23c08115ec8cec4e  armadillo.off
58fa129fbd64d519034b12c73ecb463ae55832710aa34fddd0504debd044f71d  eight.off
03768b314714676d9305361c7c124be3b2c991c59fe8c752a49047115b4dfa00  mushroom.off
13d9d2f3459189630680dad6a3b5528d5cc794967b791580a0e1f6642903d030  knot1.off
1c5a25c3047fc6b14dd0c962d3562b1796671422ab4634f9d46f9f23814cd54a  cow.off
5009b3400b73ef199b6ac9a24a27f4f76e1aa7b71d957a50cb6dcbe09868ff3b  anchor.off
ab217f67fefdf8a8e01563d09135f05ab02330064a3c0180570546887d01b7f1  blobby.off"
if ! (cd "$dest" 2>/dev/null && echo "$sums" | sha256sum --check --quiet >/dev/null 2>&1); then
  work=$(mktemp -d)
  trap 'rm -rf "$work"' EXIT
  cd "$work"
  if ! apt-get download libcgal-demo=5.5.1-2 >/dev/null 2>&1; then
    apt-get update >/dev/null
    apt-get download libcgal-demo=5.5.1-2 >/dev/null
  fi
  dpkg-deb -x ./libcgal-demo_*.deb root
  names=$(echo "$sums" | awk '{print "data/meshes/" $2}')
  # shellcheck disable=SC2086
  tar xzf root/usr/share/doc/libcgal-dev/data.tar.gz $names
  mkdir -p "$dest"
  cp data/meshes/*.off "$dest/"
  cd "$dest"
  echo "$sums" | sha256sum --check --quiet
fi
echo "meshes ready: $dest ($(echo "$sums" | wc -l) OFF files from Debian libcgal-demo 5.5.1-2)"
