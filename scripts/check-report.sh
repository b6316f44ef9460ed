#!/bin/sh
# Checks a report page written by `photondiff report` or a benchmark, the way
# tests/report_browser.rs does: Debian's headless Chromium loads DIR/index.html from disk, the
# page's status line must say that every image loaded, Chromium's console log must hold no
# message, and a 1200 x 1600 screenshot is taken (out/report-screenshots/<DIR's name>.png).
#   scripts/check-report.sh DIR...
# Exits 1 when a page fails. Chromium runs in a process group of its own, killed afterwards.
set -eu
CHROMIUM=${CHROMIUM:-/usr/bin/chromium}
if [ ! -x "$CHROMIUM" ]; then
    echo "check-report: $CHROMIUM is missing: install Debian's chromium package (apt-get install -y --no-install-recommends chromium)" >&2
    exit 1
fi
[ $# -ge 1 ] || { echo "usage: scripts/check-report.sh DIR..." >&2; exit 1; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# Runs Chromium on a page with extra flags; stdout to $work/out, stderr to $work/err.
browse() {
    page=$1
    shift
    setsid "$CHROMIUM" --headless --no-sandbox --disable-gpu --disable-quic --no-first-run \
        --disable-background-networking --disable-component-update --disable-sync \
        --enable-logging=stderr --v=0 --virtual-time-budget=10000 \
        --user-data-dir="$work/profile" "$@" "file://$page" \
        </dev/null >"$work/out" 2>"$work/err" &
    pid=$!
    # setsid makes the browser the leader of a new group whose id is its pid.
    waited=0
    while kill -0 "$pid" 2>/dev/null && [ $waited -lt 1200 ]; do
        sleep 0.1
        waited=$((waited + 1))
    done
    kill -KILL -- "-$pid" 2>/dev/null || true
    wait "$pid" 2>/dev/null || true
}

failed=0
for dir in "$@"; do
    page=$(cd "$dir" && pwd)/index.html
    [ -f "$page" ] || { echo "$dir: no index.html" >&2; failed=1; continue; }
    images=$(grep -o '<img ' "$page" | wc -l)
    bytes=$(du -sk "$dir" | cut -f1)
    browse "$page" --dump-dom
    status=$(grep -o '<p id="status"[^>]*>[^<]*' "$work/out" | sed 's/.*>//')
    console=$(grep -c CONSOLE "$work/err" || true)
    if [ "$status" = "All $images images loaded." ] && [ "$console" = 0 ]; then
        echo "$dir: ok: $status ($bytes KiB, no console message)"
    else
        echo "$dir: FAILED: status '$status', $console console messages:" >&2
        grep CONSOLE "$work/err" >&2 || true
        failed=1
    fi
    mkdir -p out/report-screenshots
    shot="$(pwd)/out/report-screenshots/$(basename "$(dirname "$page")").png"
    browse "$page" --screenshot="$shot" --window-size=1200,1600
    [ -s "$shot" ] && echo "$dir: screenshot $shot"
done
exit $failed
