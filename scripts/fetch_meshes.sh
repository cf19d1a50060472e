#!/bin/sh
# SPDX-License-Identifier: Apache-2.0
# Fetches the real test meshes (data/meshes/*.off: armadillo, bunny00, cow,
# elephant, knot1, fandisk, ChineseDragon-10kv, ...) from Debian's
# libcgal-demo package without installing it (it depends on Qt): the .deb is
# downloaded with `apt-get download` into build/cache, unpacked with
# `dpkg-deb -x`, and data/meshes/*.off is taken out of its data.tar.gz.
# data/ is git-ignored. Idempotent: does nothing when the meshes are there.
# Usage: sh scripts/fetch_meshes.sh [--force]
set -eu
here=$(cd "$(dirname "$0")/.." && pwd)
cd "$here"
dest=data/meshes
cache=build/cache
stamp=$dest/.fetched-libcgal-demo
force=0
[ "${1:-}" = "--force" ] && force=1

# Triangles in an OFF file (polygons count as n-2 triangles).
off_tris() {
  awk 'BEGIN { st = 0; t = 0 }
       { sub(/#.*/, "") }
       NF == 0 { next }
       st == 0 { if ($1 ~ /OFF$/) { $1 = ""; if (NF == 0 || $0 ~ /^ *$/) next; $0 = $0 }
                 nv = $1; nf = $2; st = 1; if (nf == 0) exit; next }
       st == 1 { if (++v >= nv) st = 2; next }
       st == 2 { t += $1 - 2; if (++f >= nf) exit }
       END { print t }' "$1"
}

report() {
  n=$(ls "$dest"/*.off 2>/dev/null | wc -l)
  echo "meshes: $n OFF files in $here/$dest"
  for m in armadillo bunny00 cow elephant knot1 fandisk ChineseDragon-10kv; do
    [ -f "$dest/$m.off" ] && printf '  %-22s %8s triangles\n' "$m.off" "$(off_tris "$dest/$m.off")"
  done
  return 0
}

if [ "$force" -eq 0 ] && [ -f "$stamp" ] && [ -f "$dest/armadillo.off" ]; then
  report
  exit 0
fi

for tool in apt-get apt-cache dpkg-deb tar; do
  command -v "$tool" >/dev/null 2>&1 || { echo "fetch_meshes.sh: '$tool' not found (needs Debian/apt)" >&2; exit 1; }
done

as_root() {
  if [ "$(id -u)" -eq 0 ]; then "$@"
  elif command -v sudo >/dev/null 2>&1 && sudo -n true 2>/dev/null; then sudo -n "$@"
  else return 1; fi
}

mkdir -p "$cache"
deb=$(ls "$cache"/libcgal-demo_*.deb 2>/dev/null | tail -n 1 || true)
if [ -z "$deb" ]; then
  log=$cache/apt-download.log
  # apt-get download needs the package lists; as root, tell apt not to drop
  # privileges to _apt (which can not write to build/cache).
  dl() { (cd "$cache" && apt-get -o APT::Sandbox::User=root download libcgal-demo) >"$log" 2>&1; }
  if ! apt-cache show libcgal-demo >/dev/null 2>&1 || ! dl; then
    echo "fetch_meshes.sh: updating the apt package lists"
    if ! as_root apt-get update -qq >/dev/null 2>&1; then
      echo "fetch_meshes.sh: could not run 'apt-get update' (needs root or password-less sudo); run it once, then retry" >&2
      exit 1
    fi
    if ! dl; then
      tail -n 5 "$log" >&2
      echo "fetch_meshes.sh: apt-get download libcgal-demo failed" >&2
      exit 1
    fi
  fi
  deb=$(ls "$cache"/libcgal-demo_*.deb | tail -n 1)
fi

tmp=$cache/libcgal-demo.x
rm -rf "$tmp"
mkdir -p "$tmp"
dpkg-deb -x "$deb" "$tmp/deb"
tarball=$(find "$tmp/deb" -name data.tar.gz -type f | head -n 1)
if [ -z "$tarball" ]; then
  echo "fetch_meshes.sh: no data.tar.gz in $deb" >&2; exit 1
fi
tar -xzf "$tarball" -C "$tmp" --wildcards 'data/meshes/*.off'
mkdir -p "$dest"
cp "$tmp"/data/meshes/*.off "$dest"/
rm -rf "$tmp"
[ -f "$dest/armadillo.off" ] || { echo "fetch_meshes.sh: armadillo.off missing from the package" >&2; exit 1; }
echo "$(basename "$deb")" > "$stamp"
report
