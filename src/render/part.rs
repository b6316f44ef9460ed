//! A part of an image as written by one process of a split render (`--tile`): the pixels of
//! its window, where the window lies in the whole image, and the render's settings, all read
//! back from the EXR file (data window, display window, `photondiff/...` attributes).

use super::film::Film;
use super::split::Window;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// An EXR written by `photondiff render`, whole or a part.
#[derive(Debug, Clone)]
pub struct Part {
    /// The file it came from (for messages).
    pub path: PathBuf,
    /// The pixels of its window (f32 in the file, exactly representable here).
    pub film: Film,
    /// Where the pixels lie in the whole image.
    pub window: Window,
    /// Size of the whole image (the display window).
    pub display: (u32, u32),
    /// Its string attributes (`photondiff/...`).
    pub metadata: BTreeMap<String, String>,
}

/// The whole image's pixels as part `path`'s header gives them (its display window), read
/// without its pixels; `None` where the header cannot be read (the reader then says why).
pub fn display_pixels(path: &Path) -> Option<u64> {
    let meta = exr::meta::MetaData::read_from_file(path, false).ok()?;
    let size = meta.headers.first()?.shared_attributes.display_window.size;
    Some(size.width() as u64 * size.height() as u64)
}

/// Reads an EXR written by `photondiff render` (or merged by `photondiff merge`).
pub fn read_part(path: &Path) -> Result<Part, String> {
    use exr::prelude::*;
    crate::util::exr_input::check_size(path)?;
    let image = read_first_rgba_layer_from_file(
        path,
        |size, _| Film::new(size.width() as u32, size.height() as u32),
        |film: &mut Film, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            let i = pos.y() * film.width as usize + pos.x();
            film.pixels[i] = glam::DVec3::new(r as f64, g as f64, b as f64);
        },
    )
    .map_err(|e| format!("{}: cannot read EXR: {e}", path.display()))?;
    let display = image.attributes.display_window;
    let layer = &image.layer_data;
    let position = layer.attributes.layer_position - display.position;
    let film = layer.channel_data.pixels.clone();
    if position.x() < 0 || position.y() < 0 {
        return Err(format!(
            "{}: the data window starts outside the display window",
            path.display()
        ));
    }
    let window = Window {
        x0: position.x() as u32,
        y0: position.y() as u32,
        x1: position.x() as u32 + film.width,
        y1: position.y() as u32 + film.height,
    };
    let display = (display.size.width() as u32, display.size.height() as u32);
    if window.x1 > display.0 || window.y1 > display.1 {
        return Err(format!(
            "{}: the data window ({window}) is not inside the display window",
            path.display()
        ));
    }
    let mut metadata = BTreeMap::new();
    for (key, value) in image
        .attributes
        .other
        .iter()
        .chain(layer.attributes.other.iter())
    {
        if let AttributeValue::Text(text) = value {
            metadata.insert(key.to_string(), text.to_string());
        }
    }
    super::checksum::check(path, &metadata, super::checksum::RGB_KEY, || {
        super::checksum::rgb(&film)
    })?;
    Ok(Part {
        path: path.to_path_buf(),
        film,
        window,
        display,
        metadata,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    #[test]
    fn a_window_round_trips_with_its_position_and_attributes() {
        let mut film = Film::new(5, 3);
        film.pixels[7] = DVec3::new(0.5, 2.0, 3.0 / 1024.0);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("part.exr");
        film.write_exr_window(
            &path,
            &[("photondiff/tile".into(), "1/3".into())],
            (16, 32),
            (21, 40),
        )
        .unwrap();
        let part = read_part(&path).unwrap();
        assert_eq!(part.film, film);
        assert_eq!(
            part.window,
            Window {
                x0: 16,
                y0: 32,
                x1: 21,
                y1: 35
            }
        );
        assert_eq!(part.display, (21, 40));
        assert_eq!(part.metadata["photondiff/tile"], "1/3");
    }
}
