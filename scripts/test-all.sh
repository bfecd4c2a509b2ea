#!/usr/bin/env bash
# Runs every check and test of the project: rustfmt, clippy, the whole
# cargo test suite (benches compiled in test mode, not timed), and the node
# test suites that exist. Installs what the tests need first.
#
# Usage: scripts/test-all.sh        (from anywhere; CI runs it via .ci/run)
set -euo pipefail
cd "$(dirname "$0")/.."

log() { printf '\n==> %s\n' "$*" >&2; }

# --- what the tests need ------------------------------------------------
if ! command -v node >/dev/null || ! command -v npm >/dev/null; then
    log "installing Node.js and npm (Debian packages)"
    apt-get update -qq && apt-get install -y -qq nodejs npm >/dev/null
fi
if [ -f tools/gltf-validate/package.json ] && [ ! -d tools/gltf-validate/node_modules ]; then
    log "npm ci --prefix tools/gltf-validate (Khronos glTF-Validator)"
    npm ci --prefix tools/gltf-validate --no-audit --no-fund
fi
if [ -f web/package.json ] && [ ! -d web/node_modules ]; then
    log "npm ci --prefix web"
    if [ -f web/package-lock.json ]; then
        npm ci --prefix web --no-audit --no-fund
    else
        npm install --prefix web --no-audit --no-fund
    fi
fi

if [ -f web/package.json ]; then
    # Debian chromium + playwright-core for web/browser-test (pqm view in a real browser)
    log "scripts/install-browser.sh"
    scripts/install-browser.sh
fi

# --- static checks --------------------------------------------------------
log "cargo fmt --check"
cargo fmt --all --check

log "cargo clippy --workspace --all-targets -- -D warnings"
cargo clippy --workspace --all-targets -- -D warnings

log "RUSTDOCFLAGS=\"-D warnings\" cargo doc --workspace --no-deps"
# Broken, ambiguous or private intra-doc links fail here, as clippy's do.
RUSTDOCFLAGS="-D warnings" cargo doc --workspace --no-deps

# --- tests ----------------------------------------------------------------
out=$(mktemp)
trap 'rm -f "$out"' EXIT

log "cargo test --workspace --all-targets"
# --all-targets builds the benches in test mode (each runs once, untimed).
set +e
cargo test --workspace --all-targets 2>&1 | tee "$out"
status=${PIPESTATUS[0]}
set -e
if [ "$status" -ne 0 ]; then
    echo "cargo test failed (exit $status)" >&2
    exit "$status"
fi

webout=$(mktemp)
trap 'rm -f "$out" "$webout"' EXIT
target="${CARGO_TARGET_DIR:-target}"
if [ -f web/package.json ] && [ -d ../shared/meshes ]; then
    # Real meshes for the JavaScript decoder's bigfiles test: the bench
    # files (spot, makehuman, loki, the quad-split bunny; kept once made)
    # encoded by the pqm just built, and the Rust decoder's digests of
    # them, which that test must match level by level.
    log "web/bench/make-data.sh and their digests (examples/digest)"
    PQM="$target/debug/pqm" bash web/bench/make-data.sh
    cargo run -q -p pqm-format --example digest -- web/bench/data/*.pqm
fi
if [ -f web/package.json ]; then
    # web/browser-test serves with target/debug/pqm (`pqm view`): the
    # `cargo test --workspace` above built it (test profile, optimized).
    log "npm test --prefix web"
    set +e
    npm test --prefix web 2>&1 | tee "$webout"
    status=${PIPESTATUS[0]}
    set -e
    if [ "$status" -ne 0 ]; then
        echo "web tests failed (exit $status)" >&2
        exit "$status"
    fi
else
    log "web/ has no package.json yet: skipping the web tests"
fi

# --- summary (as cargo prints it) -------------------------------------------
log "summary"
grep -E '^# (tests|pass|fail|skipped) ' "$webout" || true
grep -E '^test result:' "$out" || true
