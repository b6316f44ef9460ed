# Two commands do all the set-up on a fresh Debian bookworm machine:
#   make render   installs what is missing, builds in release mode, renders the canonical scene
#   make test     installs what is missing, runs every test
SCENE ?= scenes/caustic-sphere.toml
OUT   ?= out
APT_PACKAGES := libembree-dev libclang-dev
SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)

.PHONY: render test bench deps check

render: deps
	cargo build --release
	./target/release/photondiff render $(SCENE) -o $(OUT)/caustic-sphere.exr --png $(OUT)/caustic-sphere.png --stats-json $(OUT)/caustic-sphere.stats.json
	@echo "image: $(OUT)/caustic-sphere.png (linear EXR: $(OUT)/caustic-sphere.exr)"

test: deps
	cargo test

bench: deps
	cargo bench

# Debian packages: Embree 3 headers and library, and libclang for bindgen.
deps:
	@if [ ! -f /usr/include/embree3/rtcore.h ] && [ -z "$$EMBREE_DIR" ] || ! ls /usr/lib/llvm-*/lib/libclang*.so* >/dev/null 2>&1; then \
		echo "installing $(APT_PACKAGES)"; \
		$(SUDO) apt-get update -qq && $(SUDO) apt-get install -y --no-install-recommends $(APT_PACKAGES); \
	fi
	@command -v cargo >/dev/null || { echo "cargo not found: install Rust (rustup) first"; exit 1; }

# What runs before each commit.
check:
	cargo fmt --all -- --check
	cargo clippy --all-targets -- -D warnings
	cargo test
