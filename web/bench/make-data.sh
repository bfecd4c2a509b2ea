#!/usr/bin/env bash
# Writes the benchmark inputs into web/bench/data/ (gitignored): real meshes
# encoded as .pqm with the project's encoder, default settings (14 bits,
# 16 KiB chunks), but the bunny's triangles split into quads
# (`--triangles split`: issue 4's quad-split bunny, 209k quads; `pqm
# encode`'s default since session 24 pairs them instead, 35k quads). Used by `npm run bench` (decode.mjs picks the biggest file)
# and `npm run bench:draco` (draco.mjs compares every file it finds).
#
#   bash bench/make-data.sh            # from web/; skips files already there
#   PQM=/path/to/pqm bash bench/make-data.sh
#
# The encoder is $PQM, else target/release/pqm of this checkout, else of the
# main tree beside it; build it with `cargo build --release -p pqm-cli`.
# Timing (release, one core): spot < 1 s, makehuman ~20 s, loki ~30 s,
# bunny (69,666 triangles split into 209k quads) ~60 s.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
meshes="${MESHES:-$root/../shared/meshes}"
pqm="${PQM:-}"
if [ -z "$pqm" ]; then
  for p in "$root/target/release/pqm" "$root/../main/target/release/pqm"; do
    if [ -x "$p" ]; then pqm="$p"; break; fi
  done
fi
if [ -z "$pqm" ]; then
  echo "no pqm binary: build it with 'cargo build --release -p pqm-cli' or set PQM" >&2
  exit 1
fi
mkdir -p "$here/data"
for src in quad/spot_quadrangulated.obj quad/makehuman_base.obj quad/loki.obj tri/bunny.off; do
  name="$(basename "${src%.*}")"
  out="$here/data/$name.pqm"
  if [ -s "$out" ]; then echo "$out exists"; continue; fi
  if [ ! -f "$meshes/$src" ]; then echo "skipping $src: not in $meshes" >&2; continue; fi
  echo "encoding $src → $out"
  "$pqm" encode -q "$meshes/$src" -o "$out" --triangles split
done
