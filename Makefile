# Two commands do all the set-up on a fresh Debian bookworm machine:
#   make render   installs what is missing, builds in release mode, renders the canonical scene
#   make test     installs what is missing, runs every test
SCENE ?= scenes/caustic-sphere.toml
OUT   ?= out
APT_PACKAGES := libembree-dev libclang-dev
SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)
# The release decides which Embree libembree-dev holds: 3 on bookworm, 4 on trixie and noble.
RELEASE := $(shell . /etc/os-release 2>/dev/null && echo "$$ID $$VERSION_CODENAME")
EMBREE_OF_RELEASE = $(if $(filter bookworm,$(RELEASE)),Embree 3,$(if $(filter trixie noble,$(RELEASE)),Embree 4,Embree 3 or 4))

.PHONY: render test bench deps check report-example

render: deps
	cargo build --release
	./target/release/photondiff render $(SCENE) -o $(OUT)/caustic-sphere.exr --png $(OUT)/caustic-sphere.png --stats-json $(OUT)/caustic-sphere.stats.json
	@echo "image: $(OUT)/caustic-sphere.png (linear EXR: $(OUT)/caustic-sphere.exr)"

test: deps
	cargo test
	scripts/test-embree4.sh

bench: deps
	cargo bench

# The example report committed in docs/report/ (README): Regular 1x1 and the default
# (integrated, 2 passes) at 320 x 240 beside a split reference of 5 x 10^7 + 5 x 10^7
# paths, with the timing table and the speed-against-error chart of docs/; then checked in
# headless Chromium (scripts/check-report.sh) where Chromium is installed.
EXAMPLE    := out/example
PHOTONDIFF ?= ./target/release/photondiff
report-example: deps
	cargo build --release
	mkdir -p $(EXAMPLE)
	sed -e 's/^width = 640$$/width = 320/' -e 's/^height = 480$$/height = 240/' scenes/caustic-sphere.toml > $(EXAMPLE)/scene.toml
	$(PHOTONDIFF) reference $(EXAMPLE)/scene.toml --light-paths 50000000 --caustic-paths 50000000 -o $(EXAMPLE)/reference.exr
	$(PHOTONDIFF) render $(EXAMPLE)/scene.toml -q --estimator pd -o $(EXAMPLE)/regular-1x1.exr
	$(PHOTONDIFF) render $(EXAMPLE)/scene.toml -q -o $(EXAMPLE)/default.exr
	rm -rf docs/report
	$(PHOTONDIFF) report --reference $(EXAMPLE)/reference.exr --scene $(EXAMPLE)/scene.toml \
		"Regular 1x1=$(EXAMPLE)/regular-1x1.exr" "Default (integrated, 2 passes)=$(EXAMPLE)/default.exr" \
		--table docs/timing_table.json --chart docs/speed_vs_error.svg \
		--title "Example report: canonical scene at 320 x 240" -o docs/report
	if [ -x /usr/bin/chromium ]; then scripts/check-report.sh docs/report; else echo "not checked: /usr/bin/chromium is missing"; fi

# Debian/Ubuntu packages: Embree headers and library (build.rs takes Embree 4, else 3), and
# libclang for bindgen. The same package names on bookworm (Embree 3), trixie and noble (Embree 4).
deps:
	@if [ ! -f /usr/include/embree4/rtcore.h ] && [ ! -f /usr/include/embree3/rtcore.h ] && [ -z "$$EMBREE_DIR" ] \
		|| ! ls /usr/lib/llvm-*/lib/libclang*.so* >/dev/null 2>&1; then \
		echo "installing $(APT_PACKAGES) ($(EMBREE_OF_RELEASE) on $(RELEASE))"; \
		{ $(SUDO) apt-get update -qq && $(SUDO) apt-get install -y --no-install-recommends $(APT_PACKAGES); } \
		|| { echo "photondiff: could not install the packages $(APT_PACKAGES) ($(EMBREE_OF_RELEASE) on $(RELEASE)): install them by hand, or set EMBREE_DIR to an Embree 3 or 4 prefix"; exit 1; }; \
	fi
	@command -v cargo >/dev/null || { echo "cargo not found: install Rust (rustup) first"; exit 1; }

# What runs before each commit.
check:
	cargo fmt --all -- --check
	cargo clippy --all-targets -- -D warnings
	cargo test
