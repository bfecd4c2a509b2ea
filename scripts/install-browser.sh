#!/usr/bin/env bash
# Installs what the real-browser tests (web/browser-test) and the slow-link
# benchmark need: Debian's chromium package at /usr/bin/chromium (never a
# browser build downloaded by playwright) and web/'s npm devDependencies
# (playwright-core drives that chromium).
#
# Usage: scripts/install-browser.sh      (scripts/test-all.sh runs it)
set -euo pipefail
cd "$(dirname "$0")/.."

if [ ! -x /usr/bin/chromium ]; then
    echo "==> installing chromium (Debian package)" >&2
    if [ "$(id -u)" -ne 0 ]; then
        echo "error: /usr/bin/chromium is missing and this is not root: run 'sudo apt-get install -y chromium'" >&2
        exit 1
    fi
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null
fi
/usr/bin/chromium --version >&2 2>/dev/null || true

if [ ! -d web/node_modules/playwright-core ] || [ ! -d web/node_modules/esbuild ]; then
    echo "==> npm ci --prefix web (playwright-core, esbuild)" >&2
    npm ci --prefix web --no-audit --no-fund
fi
