#!/usr/bin/env bash
# Prints the README's encode table: `pqm encode --json` with default options
# on the shared meshes (../shared/meshes beside the repository), one Markdown
# row per mesh. Needs a release build: cargo build --release -p pqm-cli (or
# PQM=path/to/pqm).
#
# Triangle meshes go through `--triangles $TRIANGLES`, `split` unless set:
# issue 4's figures are those of the quad-split meshes (the files of sessions
# up to 23); TRIANGLES=pair gives `pqm encode`'s default since session 24.
#
# Usage: [TRIANGLES=pair] scripts/encode-table.sh [--large]   (--large adds the two large/ meshes)
set -euo pipefail
cd "$(dirname "$0")/.."
shared=../shared/meshes
pqm=${PQM:-target/release/pqm}
triangles=${TRIANGLES:-split}
[ -x "$pqm" ] || { echo "build first: cargo build --release -p pqm-cli" >&2; exit 1; }
meshes=(quad/spot_control_mesh.obj quad/fandisk_quads.off quad/suzanne.obj
    quad/spot_quadrangulated.obj quad/makehuman_base.obj tri/fertility.off quad/loki.obj
    tri/fandisk.off quad/sword-quad-dominant.obj tri/bunny.off)
[ "${1:-}" = "--large" ] && meshes+=(large/skull.obj large/amo.off)
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
echo "| input | faces | base faces | records | .pqm bytes | bits/vertex | encode (s) | coarsening stopped because |"
echo "|---|---|---|---|---|---|---|---|"
for m in "${meshes[@]}"; do
    "$pqm" -q encode "$shared/$m" -o "$out/x.pqm" --triangles "$triangles" --json > "$out/r.json"
    python3 - "$m" "$out/r.json" <<'PY'
import json, sys
r = json.load(open(sys.argv[2]))["files"][0]
split = {"split": " (split)", "paired": " (paired)"}.get(r["conversion"], "")
stop = {"nothing_legal": "nothing legal", "target_reached": "target reached"}.get(r["stop"], r["stop"])
print(f"| {sys.argv[1]} | {r['faces']:,}{split} | {r['base_faces']:,} | {r['records']:,} | "
      f"{r['bytes']:,} | {r['bits_per_vertex']:.0f} | {r['encode_time_s']:.2f} | {stop} |")
PY
done
