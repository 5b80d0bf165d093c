#!/usr/bin/env bash
# Fetches the real meshes used by the tests: Debian's libcgal-demo package ships
# usr/share/doc/libcgal-dev/data.tar.gz, whose data/meshes/*.off we unpack into
# DEST/meshes. Idempotent: does nothing when the meshes are already there.
set -euo pipefail
dest=${1:?usage: fetch-test-data.sh DEST}
if [ -f "$dest/meshes/bunny00.off" ] && [ -f "$dest/meshes/rotor.off" ]; then exit 0; fi
mkdir -p "$dest"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
tarball=/usr/share/doc/libcgal-dev/data.tar.gz
if [ ! -f "$tarball" ]; then
  (cd "$work" && apt-get download libcgal-demo >/dev/null 2>&1) || {
    if [ "$(id -u)" = 0 ]; then apt-get update -qq >/dev/null && (cd "$work" && apt-get download libcgal-demo >/dev/null 2>&1); fi
  } || { echo "fetch-test-data: cannot download libcgal-demo (apt-get download failed)" >&2; exit 1; }
  dpkg -x "$work"/libcgal-demo_*.deb "$work/pkg"
  tarball="$work/pkg/usr/share/doc/libcgal-dev/data.tar.gz"
fi
tar -xzf "$tarball" -C "$work" data/meshes
rm -rf "$dest/meshes.partial"
mv "$work/data/meshes" "$dest/meshes.partial"
rm -rf "$dest/meshes"
mv "$dest/meshes.partial" "$dest/meshes"
echo "fetch-test-data: $(ls "$dest/meshes" | wc -l) files in $dest/meshes"
