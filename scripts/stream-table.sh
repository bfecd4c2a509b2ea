#!/usr/bin/env bash
# Prints the README's streaming table: for each mesh, the share of the .pqm file a
# client must read to show the base mesh and to reach 10 % and 50 % of the final
# faces (at chunk granularity, from `pqm info --json`'s level rows), with
# `pqm encode`'s default options. Needs a release build: cargo build --release -p pqm-cli
# (or PQM=path/to/pqm).
#
# Triangle meshes go through `--triangles $TRIANGLES`, `split` unless set
# (issue 4's quad-split bunny; TRIANGLES=pair: the default since session 24).
#
# Usage: [TRIANGLES=pair] scripts/stream-table.sh [MESH ...]   (paths under ../shared/meshes; default: four)
set -euo pipefail
cd "$(dirname "$0")/.."
shared=../shared/meshes
pqm=${PQM:-target/release/pqm}
triangles=${TRIANGLES:-split}
[ -x "$pqm" ] || { echo "build first: cargo build --release -p pqm-cli" >&2; exit 1; }
meshes=("$@")
[ ${#meshes[@]} -eq 0 ] && meshes=(quad/spot_quadrangulated.obj quad/makehuman_base.obj quad/loki.obj tri/bunny.off)
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
echo "| input | final faces | .pqm bytes | base mesh shown after | 10 % of the faces after | 50 % of the faces after |"
echo "|---|---|---|---|---|---|"
for m in "${meshes[@]}"; do
    "$pqm" -q encode "$shared/$m" -o "$out/x.pqm" --triangles "$triangles"
    "$pqm" info "$out/x.pqm" --json > "$out/i.json"
    python3 - "$m" "$out/i.json" <<'PY'
import json, sys
d = json.load(open(sys.argv[2]))
total, final = d["file_bytes"], d["final_faces"]
levels = d["levels"]
def first(share):
    for row in levels:
        if row["faces"] >= share * final:
            return f"{row['bytes']:,} B ({100 * row['bytes'] / total:.1f} %, {row['faces']:,} faces)"
    return "-"
base = levels[0]
print(f"| {sys.argv[1]} | {final:,} | {total:,} | {base['bytes']:,} B ({100 * base['bytes'] / total:.1f} %, "
      f"{base['faces']:,} faces) | {first(0.10)} | {first(0.50)} |")
PY
done
