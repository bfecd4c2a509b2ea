#!/usr/bin/env bash
# Prints the README's Rust decode-speed table: each .pqm file decoded whole to
# its finest level by a decoder on new memory (cold), by a new decoder that
# takes over the last one's allocations, and by a reused decoder (general and
# forward-only), each way in processes of its own, beside the same finest mesh
# as gltfpack would ship it (meshoptimizer's index and vertex codecs + zstd-19)
# decoded in the same run (crates/pqm-format/examples/decode_table.rs); then
# the peak resident memory of a process decoding each file once, beside the
# peer's (Linux: VmHWM).
#
# Usage: scripts/decode-table.sh [FILE.pqm ...] [--large] [--runs N] [--rounds R]
#   default files: web/bench/data/*.pqm (`npm run bench:data --prefix web`)
#   --large: also the two large shared meshes (../shared/meshes/large: skull,
#   amo), encoded with `pqm encode`'s defaults but `--triangles split` (issue
#   4's quad-split meshes) into $target/bench-large (again whenever the pqm
#   binary is newer than the file)
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -q -p pqm-format --example decode_table
target="${CARGO_TARGET_DIR:-target}"
large=0
args=()
for a in "$@"; do
  if [ "$a" = "--large" ]; then large=1; else args+=("$a"); fi
done
files=0
for a in "${args[@]}"; do [[ "$a" == *.pqm ]] && files=$((files + 1)); done
if [ "$files" -eq 0 ]; then
  shopt -s nullglob
  data=(web/bench/data/spot_quadrangulated.pqm web/bench/data/makehuman_base.pqm web/bench/data/loki.pqm web/bench/data/bunny.pqm)
  present=()
  for f in "${data[@]}"; do [ -f "$f" ] && present+=("$f"); done
  [ ${#present[@]} -gt 0 ] || [ "$large" -eq 1 ] || { echo "no .pqm files: run 'npm run bench:data --prefix web' or name files" >&2; exit 1; }
  args+=("${present[@]}")
fi
if [ "$large" -eq 1 ]; then
  cargo build --release -q -p pqm-cli
  dir="$target/bench-large"
  mkdir -p "$dir"
  for m in skull.obj amo.off; do
    src="../shared/meshes/large/$m"
    [ -f "$src" ] || { echo "$src: not found (../shared beside the repository)" >&2; exit 1; }
    out="$dir/${m%.*}.pqm"
    if [ ! -f "$out" ] || [ "$target/release/pqm" -nt "$out" ]; then
      echo "encoding $src -> $out" >&2
      "$target/release/pqm" -q encode "$src" -o "$out" --triangles split
    fi
    args+=("$out")
  done
fi
"$target/release/examples/decode_table" "${args[@]}"
