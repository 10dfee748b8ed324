#!/usr/bin/env bash
# Opens a polymap report.html in headless Chromium: runs the page's self-test (URL #selftest:
# moves the slider, redraws, catches script errors) and takes a screenshot.
#
#   scripts/check-report-in-browser.sh REPORT.html OUT.png
#
# Installs Debian's chromium with apt-get when it is missing (needs root, as in CI). Set
# CHROMIUM to use a particular binary. Exits non-zero with the reason when the self-test fails.
set -euo pipefail

if [ "$#" -ne 2 ]; then
  echo "usage: $0 REPORT.html OUT.png" >&2
  exit 2
fi
report=$(realpath "$1")
out=$(realpath -m "$2")
[ -f "$report" ] || { echo "error: $report: no such file" >&2; exit 2; }

find_chromium() {
  if [ -n "${CHROMIUM:-}" ]; then echo "$CHROMIUM"; return; fi
  command -v chromium || command -v chromium-browser || true
}

chrome=$(find_chromium)
if [ -z "$chrome" ]; then
  if [ "$(id -u)" -ne 0 ] || ! command -v apt-get >/dev/null; then
    echo "error: chromium is not installed and cannot be installed here (needs root and apt-get)" >&2
    exit 1
  fi
  echo "installing chromium with apt-get ..." >&2
  apt-get update -qq >&2
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >&2
  chrome=$(find_chromium)
  [ -n "$chrome" ] || { echo "error: chromium still not found after apt-get install" >&2; exit 1; }
fi

profile=$(mktemp -d)
trap 'rm -rf "$profile"' EXIT
flags=(--headless --no-sandbox --disable-gpu --disable-quic --no-first-run
  --disable-background-networking --disable-component-update --disable-sync
  --disable-dev-shm-usage --user-data-dir="$profile")
url="file://${report// /%20}"

# 1. The self-test: the page writes SELFTEST PASS / SELFTEST FAIL: reason into <pre id="selftest">.
if ! dom=$(timeout 180 "$chrome" "${flags[@]}" --window-size=1400,1000 \
    --virtual-time-budget=10000 --dump-dom "$url#selftest" 2>"$profile/selftest.log"); then
  echo "error: chromium failed while loading the report:" >&2
  tail -n 20 "$profile/selftest.log" >&2
  exit 1
fi
# Only the <pre id="selftest"> element counts (the page's script text holds the words too).
result=$(printf '%s' "$dom" | tr '\n' ' ' | grep -o '<pre id="selftest"[^>]*>[^<]*' | head -n 1 |
  sed 's/^<pre[^>]*>//' || true)
case "$result" in
  "SELFTEST PASS"*) echo "$result" ;;
  "") echo "error: the page wrote no self-test result (did its script run?)" >&2; exit 1 ;;
  *) echo "error: $result" >&2; exit 1 ;;
esac

# 2. A screenshot of the page as a person sees it.
rm -f "$out"
if ! timeout 180 "$chrome" "${flags[@]}" --hide-scrollbars --window-size=1400,1000 \
    --virtual-time-budget=5000 --screenshot="$out" "$url" 2>"$profile/screenshot.log"; then
  echo "error: chromium failed to take the screenshot:" >&2
  tail -n 20 "$profile/screenshot.log" >&2
  exit 1
fi
[ -s "$out" ] || { echo "error: no screenshot written to $out" >&2; exit 1; }
echo "screenshot: $out"
