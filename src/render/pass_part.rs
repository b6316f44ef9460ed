//! Parts of a progressive render split by passes (`render --pass-range A..B`): beside the mean
//! of its passes (RGB, for viewing), a part carries its [`PassSum`] exactly, as extra 32-bit
//! unsigned EXR channels, so that `photondiff merge` adds the parts' sums as one process would
//! have summed the passes (fixed point, associative) and divides once: bit for bit the image of
//! one process.
//!
//! Channels, per pixel, `c` in `R`, `G`, `B` and words little-endian first:
//! `pd.fixed.c.0..3` (the i128 fixed-point sum), `pd.float.c.0..1` and `pd.square.c.0..1`
//! (the f64 bits of the floating-point sum and of the sum of squares), and `pd.flags`
//! (bit 0: every value fitted the fixed point; bit 1: the caustic estimate reached the pixel).

use super::checksum;
use super::pass_sum::PassSum;
use exr::prelude::*;
use std::path::Path;

const RGB: [&str; 3] = ["R", "G", "B"];

/// Writes `sum` (the passes of the part whose window starts at `origin` in a `display`-sized
/// image) with its mean as RGB and `metadata` as attributes, atomically.
pub fn write_pass_part(
    path: &Path,
    sum: &PassSum,
    metadata: &[(String, String)],
    origin: (u32, u32),
    display: (u32, u32),
) -> std::result::Result<(), String> {
    let mean = sum.mean();
    let n = mean.pixels.len();
    let mut channels: Vec<AnyChannel<FlatSamples>> = Vec::new();
    let mut u32s = |name: String, f: &dyn Fn(usize) -> u32| {
        channels.push(AnyChannel::new(
            name.as_str(),
            FlatSamples::U32((0..n).map(f).collect()),
        ));
    };
    for (c, name) in RGB.iter().enumerate() {
        for w in 0..4 {
            u32s(format!("pd.fixed.{name}.{w}"), &|i| {
                (sum.fixed[i][c] as u128 >> (32 * w)) as u32
            });
        }
        for w in 0..2 {
            u32s(format!("pd.float.{name}.{w}"), &|i| {
                (sum.float[i][c].to_bits() >> (32 * w)) as u32
            });
            u32s(format!("pd.square.{name}.{w}"), &|i| {
                (sum.squares[i][c].to_bits() >> (32 * w)) as u32
            });
        }
    }
    u32s("pd.flags".into(), &|i| {
        sum.exact[i] as u32 | (sum.reach[i] as u32) << 1 | (sum.lights[i] as u32) << 2
    });
    let sums = checksum::words(channels.iter().map(|c| match &c.sample_data {
        FlatSamples::U32(v) => v.as_slice(),
        _ => unreachable!("the sums are 32-bit words"),
    }));
    for (c, name) in RGB.iter().enumerate() {
        let values = mean.pixels.iter().map(|p| p[c] as f32).collect();
        channels.push(AnyChannel::new(*name, FlatSamples::F32(values)));
    }
    let rgb = checksum::rgb(&mean);
    let checksums = [
        (checksum::RGB_KEY.to_string(), rgb),
        (checksum::SUMS_KEY.to_string(), sums),
    ];
    let mut attributes = LayerAttributes::named("photondiff");
    attributes.layer_position = Vec2(origin.0 as i32, origin.1 as i32);
    for (key, value) in metadata.iter().chain(&checksums) {
        if let (Some(k), Some(v)) = (Text::new_or_none(key), Text::new_or_none(value)) {
            attributes.other.insert(k, AttributeValue::Text(v));
        }
    }
    let layer = Layer::new(
        (mean.width as usize, mean.height as usize),
        attributes,
        Encoding::FAST_LOSSLESS,
        AnyChannels::sort(SmallVec::from_vec(channels)),
    );
    let bounds = IntegerBounds::from_dimensions((display.0 as usize, display.1 as usize));
    let image = Image::new(ImageAttributes::new(bounds), layer);
    let mut bytes = std::io::Cursor::new(Vec::new());
    image
        .write()
        .to_buffered(&mut bytes)
        .map_err(|e| format!("{}: cannot write EXR: {e}", path.display()))?;
    crate::util::atomic::write_bytes(path, bytes.get_ref())
}

/// Reads the pass sum of a part written by [`write_pass_part`] summing `passes` passes.
pub fn read_pass_sum(path: &Path, passes: u64) -> std::result::Result<PassSum, String> {
    let name = path.display();
    crate::util::exr_input::check_size(path)?;
    let image = read_first_flat_layer_from_file(path)
        .map_err(|e| format!("{name}: cannot read EXR: {e}"))?;
    let layer = &image.layer_data;
    let (width, height) = (layer.size.width() as u32, layer.size.height() as u32);
    let channel = |c: &str| -> std::result::Result<&Vec<u32>, String> {
        let found = layer
            .channel_data
            .list
            .iter()
            .find(|ch| ch.name.to_string() == c);
        match found.map(|ch| &ch.sample_data) {
            Some(FlatSamples::U32(v)) => Ok(v),
            _ => Err(format!(
                "{name}: no pass sums (channel {c} missing): not written by render --pass-range"
            )),
        }
    };
    // The channels in the order they were written, for the checksum.
    let mut written: Vec<&[u32]> = Vec::new();
    for cname in RGB {
        for w in 0..4 {
            written.push(channel(&format!("pd.fixed.{cname}.{w}"))?);
        }
        for w in 0..2 {
            written.push(channel(&format!("pd.float.{cname}.{w}"))?);
            written.push(channel(&format!("pd.square.{cname}.{w}"))?);
        }
    }
    written.push(channel("pd.flags")?);
    let metadata = image
        .attributes
        .other
        .iter()
        .chain(layer.attributes.other.iter())
        .filter_map(|(k, v)| match v {
            AttributeValue::Text(t) => Some((k.to_string(), t.to_string())),
            _ => None,
        })
        .collect();
    checksum::check(path, &metadata, checksum::SUMS_KEY, || {
        checksum::words(written.iter().copied())
    })?;
    let mut sum = PassSum::new(width, height);
    let n = sum.fixed.len();
    for (c, cname) in RGB.iter().enumerate() {
        let words = |kind: &str, count: usize| -> std::result::Result<Vec<&Vec<u32>>, String> {
            (0..count)
                .map(|w| channel(&format!("pd.{kind}.{cname}.{w}")))
                .collect()
        };
        let (fixed, float, square) = (words("fixed", 4)?, words("float", 2)?, words("square", 2)?);
        for i in 0..n {
            let u = (0..4).fold(0u128, |u, w| u | (fixed[w][i] as u128) << (32 * w));
            sum.fixed[i][c] = u as i128;
            let f = |v: &Vec<&Vec<u32>>| f64::from_bits(v[0][i] as u64 | (v[1][i] as u64) << 32);
            sum.float[i][c] = f(&float);
            sum.squares[i][c] = f(&square);
        }
    }
    let flags = channel("pd.flags")?;
    for (i, &f) in flags.iter().enumerate().take(n) {
        sum.exact[i] = f & 1 != 0;
        sum.reach[i] = f & 2 != 0;
        sum.lights[i] = f & 4 != 0;
    }
    sum.passes = passes;
    Ok(sum)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::film::Film;
    use crate::render::image::RenderedImage;
    use glam::DVec3;

    #[test]
    fn sums_round_trip_exactly() {
        let mut sum = PassSum::new(3, 2);
        for k in 0..3 {
            let mut film = Film::new(3, 2);
            for (i, p) in film.pixels.iter_mut().enumerate() {
                *p = DVec3::new(
                    0.1 * k as f64 + i as f64 / 7.0,
                    if i == 4 { 1e10 } else { 0.0 },
                    -1.5,
                );
            }
            let reach = (0..6).map(|i| i % 2 == k % 2).collect();
            let lights = (0..6).map(|i| i % 3 == k).collect();
            sum.add(&RenderedImage {
                film,
                reach,
                lights,
            });
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.exr");
        write_pass_part(&path, &sum, &[], (0, 16), (3, 40)).unwrap();
        let back = read_pass_sum(&path, 3).unwrap();
        assert_eq!(back, sum);
        assert!(
            !back.exact[4],
            "1e10 is beyond the fixed point: the float sum stands"
        );
        let part = crate::render::part::read_part(&path).unwrap();
        assert_eq!(part.film.pixels[1].x, sum.mean().pixels[1].x as f32 as f64);
    }
}
