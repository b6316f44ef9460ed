//! `--resolution WxH` (`render`, `reference`): the image size instead of the scene file's, as
//! a production renderer lets a preview or a test run at a fraction of the final size without
//! an edited copy of the scene (whose content hash would then differ from the final image's).

use photondiff::scene::file::{MAX_IMAGE_SIDE, MAX_PIXELS};
use photondiff::scene::Scene;

/// An image size given on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Resolution {
    /// Pixels across.
    pub width: u32,
    /// Pixels down.
    pub height: u32,
}

/// Parses `WIDTHxHEIGHT` (`320x240`), each side in `1..=MAX_IMAGE_SIDE` and the two together at
/// most [`MAX_PIXELS`], the limits of a scene file's `[camera]`.
pub fn parse(text: &str) -> Result<Resolution, String> {
    let expected = || format!("expected WIDTHxHEIGHT in pixels, such as 320x240, got {text:?}");
    let (w, h) = text.split_once(['x', 'X']).ok_or_else(expected)?;
    let side = |s: &str| -> Result<u32, String> {
        let n: u64 = s.trim().parse().map_err(|_| expected())?;
        if n == 0 || n > u64::from(MAX_IMAGE_SIDE) {
            return Err(format!(
                "each side must be in 1..={MAX_IMAGE_SIDE} pixels, got {text:?}"
            ));
        }
        Ok(n as u32)
    };
    let (width, height) = (side(w)?, side(h)?);
    let pixels = u64::from(width) * u64::from(height);
    if pixels > MAX_PIXELS {
        return Err(format!(
            "width x height must be at most {MAX_PIXELS} pixels (20 GB to render), got \
             {width} x {height} = {pixels}"
        ));
    }
    Ok(Resolution { width, height })
}

/// `scene` with its camera rendering `resolution` (the scene file's own size without one):
/// the same eye, view and vertical field of view, so a size of another aspect ratio widens
/// or narrows the view across.
pub fn apply(scene: &mut Scene, resolution: Option<Resolution>) {
    if let Some(r) = resolution {
        scene.camera = scene.camera.with_resolution(r.width, r.height);
    }
}

/// The image's size as a memory refusal names it: the `--resolution` given, or the scene
/// file's camera.
pub fn describe(
    scene: &std::path::Path,
    resolution: Option<Resolution>,
    camera: (u32, u32),
) -> String {
    match resolution {
        Some(r) => format!(
            "--resolution {}x{}: {} pixels",
            r.width,
            r.height,
            u64::from(r.width) * u64::from(r.height)
        ),
        None => format!(
            "{}: camera: {} x {} pixels",
            scene.display(),
            camera.0,
            camera.1
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_and_bad_ones_say_what_is_expected() {
        assert_eq!(
            parse("320x240"),
            Ok(Resolution {
                width: 320,
                height: 240
            })
        );
        assert_eq!(parse("8X6").map(|r| (r.width, r.height)), Ok((8, 6)));
        assert_eq!(
            parse("320").unwrap_err(),
            "expected WIDTHxHEIGHT in pixels, such as 320x240, got \"320\""
        );
        assert_eq!(
            parse("0x240").unwrap_err(),
            "each side must be in 1..=32768 pixels, got \"0x240\""
        );
        assert_eq!(
            parse("32768x32768").unwrap_err(),
            "width x height must be at most 134217728 pixels (20 GB to render), got 32768 x \
             32768 = 1073741824"
        );
        assert!(parse("-3x2").is_err() && parse("3x2x1").is_err());
    }
}
