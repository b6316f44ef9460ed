//! EXR files read as input (`merge`, `compare`, `report`, `reference --merge`), checked for a
//! header that claims more pixels than the file can hold before the reader allocates them: a
//! 462-byte file claiming 40,000 x 40,000 pixels made the process allocate 6.4 GB (and abort
//! where that could not be had), and a 240 KB one whose offset table pointed every block at the
//! same bytes drove it to 20 GB for minutes.

use exr::compression::Compression;
use std::path::Path;

/// The most a compressed block can expand, with room to spare: deflate (ZIP, PXR24) at most
/// 1,032 times and PIZ's Huffman runs a few hundred (4,096 taken); RLE's runs 64 times (two
/// bytes for 128; 128 taken: a black 1600 x 1200 render's RLE file is 61 times smaller than its
/// pixels).
fn largest_expansion(compression: Compression) -> u64 {
    match compression {
        Compression::Uncompressed => 1,
        Compression::RLE => 128,
        _ => 4096,
    }
}

/// Bytes beside the pixels (header, offset tables) that the bound leaves room for.
const SLACK: u64 = 1 << 16;

/// Refuses a file whose header claims pixel data larger than the file could hold at the
/// largest expansion its compression allows, or than this machine's memory (each pixel read
/// as three `f64`s besides the samples). A file whose header cannot be read is left to the
/// reader, whose message says why.
pub fn check_size(path: &Path) -> Result<(), String> {
    let Ok(file) = std::fs::metadata(path) else {
        return Ok(());
    };
    let Ok(meta) = exr::meta::MetaData::read_from_file(path, false) else {
        return Ok(());
    };
    for header in &meta.headers {
        let (w, h) = (header.layer_size.width(), header.layer_size.height());
        let pixels = (w as u64).saturating_mul(h as u64);
        let per_pixel: u64 = header
            .channels
            .list
            .iter()
            .map(|c| c.sample_type.bytes_per_sample() as u64)
            .sum();
        let samples = pixels.saturating_mul(per_pixel);
        let holds = file
            .len()
            .saturating_mul(largest_expansion(header.compression))
            .saturating_add(SLACK);
        if samples > holds {
            return Err(format!(
                "{}: its header claims {w} x {h} pixels of {} channels ({samples} bytes), more \
                 than a file of {} bytes can hold: the file is damaged or not an image",
                path.display(),
                header.channels.list.len(),
                file.len()
            ));
        }
        let needed = samples.saturating_add(pixels.saturating_mul(24));
        if let Some(left) = super::memory::short_of(needed) {
            return Err(format!(
                "{}: {w} x {h} pixels would take {:.1} GB to read, more than {left}",
                path.display(),
                needed as f64 / 1e9,
            ));
        }
    }
    Ok(())
}
