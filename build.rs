//! Generates Rust bindings for the *installed* Embree 3 headers and links the installed library.
//!
//! Headers are never vendored: a header that does not match the library corrupts memory.
//! `EMBREE_DIR` overrides the prefix (headers in `$EMBREE_DIR/include/embree3`, library in
//! `$EMBREE_DIR/lib`); otherwise Debian's locations are used.

use std::env;
use std::path::PathBuf;

fn main() {
    println!("cargo:rerun-if-env-changed=EMBREE_DIR");
    println!("cargo:rerun-if-changed=build.rs");

    let (include_dir, lib_dir) = match env::var_os("EMBREE_DIR") {
        Some(dir) => {
            let dir = PathBuf::from(dir);
            (dir.join("include"), Some(dir.join("lib")))
        }
        None => (PathBuf::from("/usr/include"), None),
    };
    let header = include_dir.join("embree3").join("rtcore.h");
    if !header.exists() {
        panic!(
            "\n\nphotondiff: Embree 3 headers not found at {}.\n\
             On Debian/Ubuntu install them with:\n    \
             sudo apt-get install -y --no-install-recommends libembree-dev libclang-dev\n\
             or set EMBREE_DIR to an Embree 3 installation prefix.\n\n",
            header.display()
        );
    }
    println!("cargo:rerun-if-changed={}", header.display());

    if let Some(lib_dir) = lib_dir {
        println!("cargo:rustc-link-search=native={}", lib_dir.display());
    }
    println!("cargo:rustc-link-lib=dylib=embree3");

    let bindings = bindgen::Builder::default()
        .header(header.to_string_lossy())
        .clang_arg(format!("-I{}", include_dir.display()))
        .allowlist_function("rtc.*")
        .allowlist_type("RTC.*")
        .allowlist_var("RTC_.*")
        .bitfield_enum("RTC.*Flags")
        .newtype_enum("RTC.*")
        .derive_default(true)
        .layout_tests(false)
        .generate()
        .unwrap_or_else(|e| {
            panic!(
                "\n\nphotondiff: bindgen could not read the Embree headers ({e}).\n\
                 bindgen needs libclang: sudo apt-get install -y --no-install-recommends libclang-dev\n\n"
            )
        });
    let out = PathBuf::from(env::var("OUT_DIR").expect("OUT_DIR is set by cargo"));
    bindings
        .write_to_file(out.join("embree_bindings.rs"))
        .expect("write Embree bindings");
}
