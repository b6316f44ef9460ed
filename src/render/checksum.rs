//! Checksums of an EXR's pixels, written with them as attributes and checked when a part is
//! read back for `photondiff merge`: one flipped byte in a part was merged without a word
//! (relRMSE up to 1.9e13 against the whole render). Files written before the checksums
//! existed carry none and are read as they are.

use xxhash_rust::xxh3::Xxh3;

/// The attribute holding the checksum of the RGB values (every EXR `render` writes).
pub const RGB_KEY: &str = "photondiff/rgb_xxh3";
/// The attribute holding the checksum of a pass part's sums (`render --pass-range`).
pub const SUMS_KEY: &str = "photondiff/sums_xxh3";

/// The checksum of a film's RGB values as the file holds them (f32, row by row), in
/// hexadecimal.
pub fn rgb(film: &super::film::Film) -> String {
    let mut hash = Xxh3::new();
    for p in &film.pixels {
        for c in [p.x, p.y, p.z] {
            hash.update(&(c as f32).to_le_bytes());
        }
    }
    format!("{:016x}", hash.digest())
}

/// The checksum of a pass part's 32-bit channels, given in the order they were written.
pub fn words<'a>(channels: impl Iterator<Item = &'a [u32]>) -> String {
    let mut hash = Xxh3::new();
    for channel in channels {
        for w in channel {
            hash.update(&w.to_le_bytes());
        }
    }
    format!("{:016x}", hash.digest())
}

/// Checks the checksum `key` of the file `name` (if it has one) against `actual`.
pub fn check(
    name: &std::path::Path,
    metadata: &std::collections::BTreeMap<String, String>,
    key: &str,
    actual: impl FnOnce() -> String,
) -> Result<(), String> {
    match metadata.get(key) {
        Some(written) if *written != actual() => Err(format!(
            "{}: its {} do not match the checksum written with them: the file was changed or \
             damaged after it was written",
            name.display(),
            if key == RGB_KEY {
                "pixels"
            } else {
                "pass sums"
            }
        )),
        _ => Ok(()),
    }
}
