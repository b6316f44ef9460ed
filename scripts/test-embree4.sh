#!/usr/bin/env bash
# Builds and tests photondiff's Embree 4 backend on a machine without an Embree 4 package
# (Debian bookworm, where the CI runs). `make test` runs it after the Embree 3 suite.
#
# Headers and library must be the same Embree version (mismatched headers corrupt memory):
# - headers: trixie's libembree-dev 4.3.3+dfsg-1, fetched with `apt-get download` through a
#   private apt state and configuration (own lists, cache, status and source list; the system's
#   apt.conf.d hooks are not run) from the Debian mirror this machine already uses;
# - library: the official Embree 4.3.3 build (with its TBB) bundled in the PyPI wheel
#   raybender==4.0.3, checked by sha256 (trixie's own library needs glibc 2.38, bookworm has 2.36).
# Both versions are checked (RTC_VERSION 40303 in the headers, "4.3.3" in the library) before
# building; build.rs and the device check them again.
#
# Then, in a separate target directory (target/embree4) with EMBREE_DIR set: the library's unit
# tests and the Embree layer, differentials and direct-light tests; and the canonical scene rendered
# by the Embree 4 and the Embree 3 builds, whose images and ray statistics must agree
# (examples/backend_agreement.rs says how closely). Downloads are cached in target/embree4-deps.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD

HEADERS_DEB_VERSION=4.3.3+dfsg-1
HEADER_RTC_VERSION=40303
LIBRARY_VERSION=4.3.3
WHEEL=raybender==4.0.3
WHEEL_SHA256=1308889d8a1b913d93c8afb9288e26d685b5060e4c66e03e3bc5de645d29a037
WHEEL_LIBS=(raybender.libs/libembree4-92ec4c98.so.4 raybender.libs/libtbb-ba4fac04.so.12)

DEPS=$ROOT/target/embree4-deps
PREFIX=$DEPS/prefix
TARGET=$ROOT/target/embree4
OUT=$TARGET/agreement
SUDO=$([ "$(id -u)" = 0 ] || echo sudo)

say() { echo "test-embree4: $*" >&2; }
die() {
    echo "test-embree4: error: $*" >&2
    exit 1
}

# --- tools -------------------------------------------------------------------------------------
for tool in apt-get dpkg-deb sha256sum cargo; do
    command -v "$tool" >/dev/null || die "$tool not found"
done
if ! python3 -m pip --version >/dev/null 2>&1; then
    say "installing python3-pip (pip downloads the wheel holding the Embree 4 library)"
    { $SUDO apt-get update -qq && $SUDO apt-get install -y --no-install-recommends python3-pip; } ||
        die "could not install python3-pip; install it by hand"
fi

# --- headers: trixie's libembree-dev through a private apt state ---------------------------------
# The Debian mirror of this machine's own sources (the first that is not a security mirror).
mirror() {
    python3 - "$@" <<'PY'
import glob, re, sys
files = ["/etc/apt/sources.list"] + sorted(glob.glob("/etc/apt/sources.list.d/*.list"))
uris = []
for path in files:
    try:
        for line in open(path):
            m = re.match(r"\s*deb\s+(\[[^]]*\]\s+)?(\S+)\s+(\S+)", line)
            if m:
                uris.append((m.group(2), m.group(3)))
    except OSError:
        pass
for path in sorted(glob.glob("/etc/apt/sources.list.d/*.sources")):
    for stanza in re.split(r"\n\s*\n", open(path).read()):
        fields = {}
        for line in stanza.splitlines():
            if line.strip().startswith("#") or ":" not in line:
                continue
            key, value = line.split(":", 1)
            fields[key.strip().lower()] = value.split()
        if "deb" not in fields.get("types", []) or fields.get("enabled", ["yes"]) == ["no"]:
            continue
        for uri in fields.get("uris", []):
            for suite in fields.get("suites", []):
                uris.append((uri, suite))
for uri, suite in uris:
    if "security" not in uri and "security" not in suite and re.match(r"https?://", uri):
        print(uri.rstrip("/"))
        sys.exit(0)
sys.exit(1)
PY
}

headers_ok() {
    grep -q "^#define RTC_VERSION $HEADER_RTC_VERSION\$" "$PREFIX/include/embree4/rtcore_config.h" 2>/dev/null
}

fetch_headers() {
    local deb
    deb=$(ls "$DEPS"/libembree-dev_*.deb 2>/dev/null | head -n1 || true)
    if [ -z "$deb" ]; then
        local url apt=$DEPS/apt
        url=$(mirror) || die "no Debian mirror found in /etc/apt/sources.list or /etc/apt/sources.list.d/"
        [ -f /usr/share/keyrings/debian-archive-keyring.gpg ] ||
            die "/usr/share/keyrings/debian-archive-keyring.gpg missing (package debian-archive-keyring)"
        rm -rf "$apt"
        mkdir -p "$apt/lists/partial" "$apt/cache/archives/partial" "$apt/conf.d" "$apt/preferences.d"
        : >"$apt/status"
        : >"$apt/main.conf"
        echo "deb [signed-by=/usr/share/keyrings/debian-archive-keyring.gpg] $url trixie main" >"$apt/sources.list"
        # The whole configuration is private: no system apt.conf.d (whose update hooks would
        # clean the system's caches), only this machine's proxy settings if it has any.
        {
            echo "Dir::Etc::Parts \"$apt/conf.d\";"
            echo "Dir::Etc::main \"$apt/main.conf\";"
            echo "Dir::Etc::SourceList \"$apt/sources.list\";"
            echo "Dir::Etc::SourceParts \"-\";"
            echo "Dir::Etc::Preferences \"$apt/preferences\";"
            echo "Dir::Etc::PreferencesParts \"$apt/preferences.d\";"
            echo "Dir::State \"$apt\";"
            echo "Dir::State::Lists \"$apt/lists\";"
            echo "Dir::State::status \"$apt/status\";"
            echo "Dir::Cache \"$apt/cache\";"
            echo "APT::Sandbox::User \"root\";"
            echo "Acquire::Languages \"none\";"
            apt-config dump 2>/dev/null | grep -i '^Acquire::[a-z]*::proxy' || true
        } >"$apt/apt.conf"
        say "fetching the headers: libembree-dev $HEADERS_DEB_VERSION from trixie on $url (private apt state in $apt)"
        APT_CONFIG=$apt/apt.conf apt-get -q update >"$apt/update.log" 2>&1 ||
            { cat "$apt/update.log" >&2; die "apt-get update for trixie on $url failed"; }
        (cd "$DEPS" && APT_CONFIG=$apt/apt.conf apt-get -q download "libembree-dev=$HEADERS_DEB_VERSION") ||
            die "could not download libembree-dev=$HEADERS_DEB_VERSION from trixie on $url"
        deb=$(ls "$DEPS"/libembree-dev_*.deb | head -n1)
        rm -rf "$apt/lists" # 10 MB of package lists, not needed once the .deb is cached
    fi
    rm -rf "$DEPS/deb" "$PREFIX/include"
    dpkg-deb -x "$deb" "$DEPS/deb" || die "cannot unpack $deb"
    mkdir -p "$PREFIX/include"
    cp -r "$DEPS/deb/usr/include/embree4" "$PREFIX/include/" || die "$deb has no usr/include/embree4"
}

# --- library: the official Embree 4.3.3 from the raybender wheel ----------------------------------
library_ok() {
    [ -e "$PREFIX/lib/libembree4.so" ] && [ -e "$PREFIX/lib/${WHEEL_LIBS[1]##*/}" ] &&
        grep -q -a -F "$LIBRARY_VERSION" "$PREFIX/lib/libembree4.so"
}

fetch_library() {
    local wheel
    wheel=$(ls "$DEPS"/wheel/raybender-*.whl 2>/dev/null | head -n1 || true)
    if [ -z "$wheel" ] || ! echo "$WHEEL_SHA256  $wheel" | sha256sum -c --quiet - 2>/dev/null; then
        rm -rf "$DEPS/wheel"
        say "fetching the library: the wheel $WHEEL (PyPI)"
        python3 -m pip download --disable-pip-version-check -q --no-deps --only-binary=:all: \
            --python-version 3.11 --implementation cp --abi cp311 --platform manylinux_2_28_x86_64 \
            -d "$DEPS/wheel" "$WHEEL" || die "could not download $WHEEL from PyPI"
        wheel=$(ls "$DEPS"/wheel/raybender-*.whl | head -n1)
        echo "$WHEEL_SHA256  $wheel" | sha256sum -c --quiet - ||
            die "$wheel: sha256 is not $WHEEL_SHA256; refusing to use it"
    fi
    rm -rf "$PREFIX/lib"
    mkdir -p "$PREFIX/lib"
    python3 - "$wheel" "$PREFIX/lib" "${WHEEL_LIBS[@]}" <<'PY' || die "cannot extract ${WHEEL_LIBS[*]} from $wheel"
import os, shutil, sys, zipfile
wheel, dest, members = sys.argv[1], sys.argv[2], sys.argv[3:]
with zipfile.ZipFile(wheel) as z:
    for member in members:
        with z.open(member) as src, open(os.path.join(dest, os.path.basename(member)), "wb") as dst:
            shutil.copyfileobj(src, dst)
PY
    # The linker finds it as -lembree4; the binaries record its soname and find it by rpath, and
    # it finds its TBB beside it (its own rpath is $ORIGIN).
    ln -s "${WHEEL_LIBS[0]##*/}" "$PREFIX/lib/libembree4.so"
}

mkdir -p "$DEPS"
headers_ok || fetch_headers
headers_ok || die "$PREFIX/include/embree4/rtcore_config.h does not say #define RTC_VERSION $HEADER_RTC_VERSION"
library_ok || fetch_library
library_ok || die "$PREFIX/lib/libembree4.so does not contain the version string $LIBRARY_VERSION"
say "Embree 4 headers and library: version $LIBRARY_VERSION in $PREFIX"

# --- build and test the Embree 4 backend in its own target directory -----------------------------
export CARGO_TARGET_DIR=$TARGET
say "testing the Embree 4 backend (target directory $TARGET)"
# Building integration tests builds the binary too (same profile and features: a separate
# `cargo build --bin` would resolve dependency features without the dev-dependencies and rebuild).
# Besides the Embree layer: `instances` (Embree 4's instance calls differ) and `memory` (BVH
# options, the memory monitor and out-of-memory errors; Embree 4's compact BVH answers a few
# rays otherwise, which that suite checks apart). The other suites' answers do not depend on
# the backend (a sweep of stop 59 ran twelve of them against it); the canonical render below
# covers the rest.
EMBREE_DIR=$PREFIX cargo test --features embree4 --lib \
    --test embree_layer --test differentials --test direct_light --test instances --test memory
# And `merge`'s refusal of parts made with the compact BVH and the ordinary one, which only
# this backend records (`embree::COMPACT_CHANGES_HITS`).
EMBREE_DIR=$PREFIX cargo test --features embree4 --test farm merge_refuses_foreign
unset CARGO_TARGET_DIR

# --- the canonical render with both backends -----------------------------------------------------
say "rendering the canonical scene with the Embree 3 and the Embree 4 builds"
# The Embree 3 build of `make test` (its binary and examples); up to date after its `cargo test`.
env -u EMBREE_DIR cargo test --no-run
rm -rf "$OUT"
mkdir -p "$OUT"
for build in 3:"$ROOT/target/debug/photondiff" 4:"$TARGET/debug/photondiff"; do
    api=${build%%:*}
    bin=${build#*:}
    "$bin" --version | grep -q "Embree $api\." || die "$bin is not an Embree $api build: $("$bin" --version)"
    "$bin" render scenes/caustic-sphere.toml -q -o "$OUT/embree$api.exr" --png "$OUT/embree$api.png" \
        --stats-json "$OUT/embree$api.stats.json" >/dev/null
done
"$ROOT/target/debug/examples/backend_agreement" "$OUT/embree3.exr" "$OUT/embree4.exr" \
    "$OUT/embree3.stats.json" "$OUT/embree4.stats.json"
say "passed: the Embree 4 build's tests pass and its canonical render agrees with the Embree 3 build's"
