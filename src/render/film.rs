//! The film: linear RGB radiance per pixel, written as a float EXR and an sRGB PNG preview.

use crate::util::memory;
use glam::DVec3;
use std::path::Path;

/// What a render holds per pixel at its peak (the running sums, the film, the pass's image and
/// its EXR and PNG). Measured as the growth of the peak from 2000 x 2000 to 4000 x 4000
/// pixels (stop 57): 167 bytes a pixel resident with `--estimator direct`, 163 with the
/// default, 168 of address space (what `ulimit -v` limits). Stop 50 measured 1.27 GB at
/// 3000 x 3000 and set 150, under which a tile needing 3.2 GB passed the check under a
/// 3.07 GB limit and aborted. `tests/memory.rs` checks a render against it.
pub const PEAK_BYTES_PER_PIXEL: u64 = 175;

/// Refuses, before anything is allocated, an image (or the part of it that `what` names) of
/// `pixels` pixels whose render needs more than the memory this process may still take
/// ([`memory::available_bytes`]: what it may use less what it holds already): at 2^27
/// pixels a render under a 6 GB limit aborted ("memory allocation of 6442186800 bytes
/// failed"). `bytes_per_pixel` is what the run holds a pixel ([`PEAK_BYTES_PER_PIXEL`] for a
/// whole render); `doing` says what the memory is for ("to render").
pub fn check_image_memory(
    what: &str,
    doing: &str,
    pixels: u64,
    bytes_per_pixel: u64,
) -> Result<(), String> {
    let need = pixels.saturating_mul(bytes_per_pixel);
    match memory::short_of(need) {
        Some(left) => Err(format!(
            "{what} need about {} {doing} (about {bytes_per_pixel} bytes each), more than \
             {left}",
            memory::gigabytes(need)
        )),
        None => Ok(()),
    }
}

/// An image of linear RGB radiance; pixel `(0, 0)` is the top-left.
#[derive(Debug, Clone, PartialEq)]
pub struct Film {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Row-major pixels.
    pub pixels: Vec<DVec3>,
}

impl Film {
    /// The pixels with some light in any channel (what "over its lit pixels" means in the
    /// statistics' noise estimates).
    pub fn lit_pixels(&self) -> Vec<usize> {
        (0..self.pixels.len())
            .filter(|&i| self.pixels[i].max_element() > 0.0)
            .collect()
    }

    /// A black film.
    pub fn new(width: u32, height: u32) -> Self {
        Film {
            width,
            height,
            pixels: vec![DVec3::ZERO; width as usize * height as usize],
        }
    }

    /// The pixel at column `x`, row `y`.
    pub fn pixel(&self, x: u32, y: u32) -> DVec3 {
        self.pixels[(y * self.width + x) as usize]
    }

    /// Writes a linear float (32-bit) RGB EXR with `metadata` as string attributes, atomically
    /// (see [`crate::util::atomic`]).
    pub fn write_exr(&self, path: &Path, metadata: &[(String, String)]) -> Result<(), String> {
        self.write_exr_window(path, metadata, (0, 0), (self.width, self.height))
    }

    /// Writes the film as the part of a larger image of `display` pixels whose top-left pixel is
    /// `origin`: the EXR's data window is the film, its display window the whole image.
    pub fn write_exr_window(
        &self,
        path: &Path,
        metadata: &[(String, String)],
        origin: (u32, u32),
        display: (u32, u32),
    ) -> Result<(), String> {
        use exr::prelude::*;
        let width = self.width as usize;
        let channels = SpecificChannels::rgb(|pos: Vec2<usize>| {
            let p = self.pixels[pos.y() * width + pos.x()];
            (p.x as f32, p.y as f32, p.z as f32)
        });
        let mut attributes = LayerAttributes::named("photondiff");
        attributes.layer_position = Vec2(origin.0 as i32, origin.1 as i32);
        let checksum = [(
            super::checksum::RGB_KEY.to_string(),
            super::checksum::rgb(self),
        )];
        for (key, value) in metadata.iter().chain(&checksum) {
            if let (Some(k), Some(v)) = (Text::new_or_none(key), Text::new_or_none(value)) {
                attributes.other.insert(k, AttributeValue::Text(v));
            }
        }
        let layer = Layer::new(
            (self.width as usize, self.height as usize),
            attributes,
            Encoding::FAST_LOSSLESS,
            channels,
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

    /// Reads the first RGB(A) layer of an EXR file.
    pub fn read_exr(path: &Path) -> Result<Film, String> {
        crate::util::exr_input::check_size(path)?;
        let image = exr::prelude::read_first_rgba_layer_from_file(
            path,
            |size, _| Film::new(size.width() as u32, size.height() as u32),
            |film: &mut Film, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
                let i = pos.y() * film.width as usize + pos.x();
                film.pixels[i] = DVec3::new(r as f64, g as f64, b as f64);
            },
        )
        .map_err(|e| format!("{}: cannot read EXR: {e}", path.display()))?;
        Ok(image.layer_data.channel_data.pixels)
    }

    /// Writes an 8-bit sRGB PNG preview (radiance clamped to [0, 1], no tone mapping beyond
    /// that), atomically. From the values as the EXR holds them (single precision): from the
    /// film's own, a pixel a hair's breadth from a level's edge (71.9999999 of 255) could round
    /// the other way than the EXR's, and a merged image's preview (read back from its parts'
    /// EXRs) differed from the one-process render's in 8 rows of 4096 x 3072.
    pub fn write_png(&self, path: &Path) -> Result<(), String> {
        let bytes: Vec<u8> = self
            .pixels
            .iter()
            .flat_map(|p| p.to_array())
            .map(preview_byte)
            .collect();
        crate::util::atomic::write_png(path, &bytes, self.width, self.height)
    }
}

/// A linear value's 8-bit sRGB level in the PNG preview, from the value as the EXR holds it.
pub fn preview_byte(c: f64) -> u8 {
    (linear_to_srgb(f64::from(c as f32)) * 255.0 + 0.5) as u8
}

/// The sRGB transfer function, clamping to [0, 1] (NaN maps to 0).
pub fn linear_to_srgb(c: f64) -> f64 {
    let c = if c.is_nan() { 0.0 } else { c.clamp(0.0, 1.0) };
    if c <= 0.0031308 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

#[cfg(test)]
mod tests {
    /// The preview's level is the EXR value's: 0.063902974 (single precision) is level
    /// 72.0000007, and a film value a hair below it, which the EXR rounds to it, is 72 too (71
    /// when the film's own value was rounded, so a merged preview differed from the whole's).
    #[test]
    fn the_preview_rounds_the_exr_value() {
        let exr = 0.063902974f32;
        let below = f64::from(exr) - 1.5e-9;
        assert_eq!(below as f32, exr);
        assert!(super::linear_to_srgb(below) * 255.0 + 0.5 < 72.0);
        assert_eq!(super::preview_byte(below), 72);
        assert_eq!(super::preview_byte(f64::from(exr)), 72);
    }

    use super::*;

    #[test]
    fn exr_round_trips_pixels() {
        let mut film = Film::new(3, 2);
        film.pixels[4] = DVec3::new(0.25, 1.5, 7.0);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.exr");
        film.write_exr(&path, &[("k".into(), "v".into())]).unwrap();
        let image = exr::prelude::read_first_rgba_layer_from_file(
            &path,
            |size, _| vec![[0f32; 3]; size.width() * size.height()],
            |px: &mut Vec<[f32; 3]>, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
                px[pos.y() * 3 + pos.x()] = [r, g, b]
            },
        )
        .unwrap();
        assert_eq!(image.layer_data.channel_data.pixels[4], [0.25, 1.5, 7.0]);
        assert_eq!(image.layer_data.channel_data.pixels[0], [0.0; 3]);
        assert_eq!(Film::read_exr(&path).unwrap(), film);
    }

    #[test]
    fn srgb_endpoints() {
        assert_eq!(linear_to_srgb(0.0), 0.0);
        assert!((linear_to_srgb(1.0) - 1.0).abs() < 1e-12);
        assert_eq!(linear_to_srgb(f64::NAN), 0.0);
    }
}
