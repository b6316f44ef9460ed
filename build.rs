//! Picks the Embree backend (Embree 4 or Embree 3), generates Rust bindings for its *installed*
//! headers and links the installed library.
//!
//! - Headers are never vendored: headers that do not match the library corrupt memory. When the
//!   library file can be found, the version in its headers (`RTC_VERSION_STRING` in
//!   `rtcore_config.h`) must appear in it, or the build stops (the device checks again at run time).
//! - `EMBREE_DIR` sets the prefix (headers in `$EMBREE_DIR/include/embree{3,4}`, library in
//!   `$EMBREE_DIR/lib`, which also goes into the binaries' rpath); otherwise Debian's locations.
//! - Embree 4 is preferred when both are installed; the feature `embree3` or `embree4` forces one.
//!   Only one backend is ever linked: both libraries export the same C symbol names.
//!
//! The choice reaches the code as `cfg(embree_api = "3")` / `cfg(embree_api = "4")` and the
//! header version as the environment variable `PHOTONDIFF_EMBREE_VERSION`.

use std::env;
use std::path::{Path, PathBuf};

const INSTALL_HINT: &str = "On Debian/Ubuntu install them with (Embree 3 on bookworm, Embree 4 on trixie and noble):\n    \
     sudo apt-get install -y --no-install-recommends libembree-dev libclang-dev\n\
     or set EMBREE_DIR to an Embree installation prefix.";

/// Stops the build with a message cargo shows in full.
fn fail(message: &str) -> ! {
    eprintln!("\n\nphotondiff: {message}\n");
    std::process::exit(1);
}

fn main() {
    println!("cargo:rerun-if-env-changed=EMBREE_DIR");
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo::rustc-check-cfg=cfg(embree_api, values(\"3\", \"4\"))");

    let force3 = env::var_os("CARGO_FEATURE_EMBREE3").is_some();
    let force4 = env::var_os("CARGO_FEATURE_EMBREE4").is_some();
    let apis: &[u32] = match (force3, force4) {
        (true, true) => fail(
            "the features `embree3` and `embree4` are mutually exclusive (both libraries export \
             the same C symbols); enable at most one",
        ),
        (true, false) => &[3],
        (false, true) => &[4],
        (false, false) => &[4, 3],
    };
    let prefix = env::var_os("EMBREE_DIR").map(PathBuf::from);
    let include_dir = prefix
        .as_ref()
        .map_or_else(|| PathBuf::from("/usr/include"), |p| p.join("include"));
    let header_of = |api: u32| include_dir.join(format!("embree{api}")).join("rtcore.h");
    let Some(api) = apis.iter().copied().find(|&api| header_of(api).exists()) else {
        let looked: Vec<String> = apis
            .iter()
            .map(|&api| header_of(api).display().to_string())
            .collect();
        fail(&format!(
            "Embree headers not found (looked for {}).\n{INSTALL_HINT}",
            looked.join(", ")
        ));
    };
    let header = header_of(api);
    // Embree 4 installed beside Embree 3 must not leave the build on the old headers' outputs.
    // A header that is not there is not watched itself: cargo takes a missing file for a
    // change, and rebuilt photondiff on every `cargo bench` (2-3 minutes each). What installs
    // it is watched instead: the package database, or the include folder under EMBREE_DIR.
    for other in [3, 4] {
        let header = header_of(other);
        let dpkg = Path::new("/var/lib/dpkg/status");
        let watched = match (header.exists(), prefix.is_none() && dpkg.exists()) {
            (true, _) => header,
            (false, true) => dpkg.to_path_buf(),
            (false, false) => include_dir.clone(),
        };
        println!("cargo:rerun-if-changed={}", watched.display());
    }

    let config = include_dir
        .join(format!("embree{api}"))
        .join("rtcore_config.h");
    println!("cargo:rerun-if-changed={}", config.display());
    let (version, version_string) = header_version(&config);
    if version / 10000 != api {
        fail(&format!(
            "{} says RTC_VERSION {version}, not an Embree {api} version",
            config.display()
        ));
    }

    let lib_name = format!("embree{api}");
    let lib_dirs: Vec<PathBuf> = match &prefix {
        Some(p) => vec![p.join("lib"), p.join("lib64")],
        None => {
            let arch = env::var("CARGO_CFG_TARGET_ARCH").unwrap_or_default();
            vec![
                PathBuf::from(format!("/usr/lib/{arch}-linux-gnu")),
                PathBuf::from("/usr/lib"),
            ]
        }
    };
    let library = lib_dirs
        .iter()
        .map(|dir| dir.join(format!("lib{lib_name}.so")))
        .find(|path| path.exists());
    match &library {
        Some(library) => {
            println!("cargo:rerun-if-changed={}", library.display());
            check_library_version(library, &version_string, &config);
            let dir = library.parent().expect("a library file has a directory");
            if prefix.is_some() {
                println!("cargo:rustc-link-search=native={}", dir.display());
                // Binaries, tests and examples find the library without LD_LIBRARY_PATH.
                println!("cargo:rustc-link-arg=-Wl,-rpath,{}", dir.display());
            }
        }
        None if prefix.is_some() => fail(&format!(
            "EMBREE_DIR has Embree {version_string} headers but no lib{lib_name}.so in {}",
            lib_dirs
                .iter()
                .map(|d| d.display().to_string())
                .collect::<Vec<_>>()
                .join(" or ")
        )),
        // The linker searches its own default paths; the device checks the version at run time.
        None => println!(
            "cargo:warning=lib{lib_name}.so not found in {}: its version is checked only at run time",
            lib_dirs[0].display()
        ),
    }
    println!("cargo:rustc-link-lib=dylib={lib_name}");
    println!("cargo:rustc-cfg=embree_api=\"{api}\"");
    println!("cargo:rustc-env=PHOTONDIFF_EMBREE_VERSION={version_string}");

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
            fail(&format!(
                "bindgen could not read the Embree headers ({e}).\n\
                 bindgen needs libclang: sudo apt-get install -y --no-install-recommends libclang-dev"
            ))
        });
    let out = PathBuf::from(env::var("OUT_DIR").expect("OUT_DIR is set by cargo"));
    bindings
        .write_to_file(out.join("embree_bindings.rs"))
        .expect("write Embree bindings");
}

/// `RTC_VERSION` and `RTC_VERSION_STRING` of an `rtcore_config.h`.
fn header_version(config: &Path) -> (u32, String) {
    let text = std::fs::read_to_string(config)
        .unwrap_or_else(|e| fail(&format!("cannot read {}: {e}", config.display())));
    let define = |name: &str| {
        text.lines()
            .filter_map(|line| line.trim().strip_prefix("#define "))
            .find_map(|rest| {
                let (key, value) = rest.split_once(char::is_whitespace)?;
                (key == name).then(|| value.trim().to_string())
            })
            .unwrap_or_else(|| fail(&format!("{} does not define {name}", config.display())))
    };
    let number = define("RTC_VERSION");
    let version = number.parse().unwrap_or_else(|_| {
        fail(&format!(
            "{}: RTC_VERSION is `{number}`, not a number",
            config.display()
        ))
    });
    let string = define("RTC_VERSION_STRING").trim_matches('"').to_string();
    let expected = format!(
        "{}.{}.{}",
        version / 10000,
        version / 100 % 100,
        version % 100
    );
    if string != expected {
        fail(&format!(
            "{}: RTC_VERSION {version} and RTC_VERSION_STRING \"{string}\" disagree",
            config.display()
        ));
    }
    (version, string)
}

/// Stops the build unless `library` contains `version` as a whole word ("4.3.3" but not
/// "14.3.3" or "4.3.31"): Embree compiles its version string into the library.
fn check_library_version(library: &Path, version: &str, config: &Path) {
    let bytes = std::fs::read(library)
        .unwrap_or_else(|e| fail(&format!("cannot read {}: {e}", library.display())));
    let needle = version.as_bytes();
    let part_of_version = |b: u8| b.is_ascii_digit() || b == b'.';
    let found = bytes.windows(needle.len()).enumerate().any(|(i, w)| {
        w == needle
            && (i == 0 || !part_of_version(bytes[i - 1]))
            && bytes
                .get(i + needle.len())
                .is_none_or(|&b| !part_of_version(b))
    });
    if !found {
        fail(&format!(
            "the Embree headers ({}) are version {version}, but {} does not contain that version: \
             refusing to build with mismatched headers and library (that corrupts memory)",
            config.display(),
            library.display()
        ));
    }
}
