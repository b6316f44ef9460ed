//! EXR images with any channels, as `compare` reads them: the first layer, every channel, in
//! the file's (alphabetical) channel order, as double-precision planes.

use crate::render::film::Film;
use std::path::Path;

/// An image of named channels, each a row-major plane; pixel `(0, 0)` is the top-left.
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelImage {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Channel names, as stored (EXR sorts them alphabetically).
    pub names: Vec<String>,
    /// One plane of `width * height` values per channel, in the order of `names`.
    pub planes: Vec<Vec<f64>>,
}

impl ChannelImage {
    /// The R, G and B channels of a film (alphabetical order, as an EXR stores them).
    pub fn from_film(film: &Film) -> Self {
        let plane = |c: usize| film.pixels.iter().map(|p| p[c]).collect();
        ChannelImage {
            width: film.width as usize,
            height: film.height as usize,
            names: vec!["B".into(), "G".into(), "R".into()],
            planes: vec![plane(2), plane(1), plane(0)],
        }
    }

    /// Reads the first layer of an EXR file with all its channels. Errors are one line naming
    /// the file.
    pub fn read(path: &Path) -> Result<Self, String> {
        let name = path.display();
        std::fs::metadata(path).map_err(|e| format!("{name}: cannot open: {e}"))?;
        crate::util::exr_input::check_size(path)?;
        let image = exr::prelude::read_first_flat_layer_from_file(path)
            .map_err(|e| format!("{name}: cannot read EXR: {}", one_line(&e.to_string())))?;
        let layer = image.layer_data;
        let (width, height) = (layer.size.width(), layer.size.height());
        let mut names = Vec::new();
        let mut planes = Vec::new();
        for channel in &layer.channel_data.list {
            let channel_name = channel.name.to_string();
            let plane: Vec<f64> = channel
                .sample_data
                .values_as_f32()
                .map(|v| v as f64)
                .collect();
            if plane.len() != width * height {
                return Err(format!(
                    "{name}: channel {channel_name} is subsampled (not supported)"
                ));
            }
            names.push(channel_name);
            planes.push(plane);
        }
        Ok(ChannelImage {
            width,
            height,
            names,
            planes,
        })
    }

    /// Refuses `image` and `other` unless they start at the same pixel of their images: two
    /// tiles of one size from other places are not the same pixels (`report` compared such a
    /// pair, `compare` refused it; a mask was never checked).
    pub fn check_same_origin(image: &Path, other: &Path) -> Result<(), String> {
        let (a, b) = (Self::origin(image)?, Self::origin(other)?);
        if a != b {
            return Err(format!(
                "{} starts at pixel ({}, {}) of its image but {} at ({}, {}): not the same pixels",
                image.display(),
                a.0,
                a.1,
                other.display(),
                b.0,
                b.1
            ));
        }
        Ok(())
    }

    /// Where the first layer's pixels lie in its image (the data window's corner): `(0, 0)`
    /// for a whole image, the tile's corner for a tile of one (`render --tile`).
    pub fn origin(path: &Path) -> Result<(i32, i32), String> {
        let header = first_header(path)?.ok_or_else(|| format!("{}: no layer", path.display()))?;
        let p = header.own_attributes.layer_position;
        Ok((p.x(), p.y()))
    }

    /// A text attribute of the file's first layer (or of the file), read from the header
    /// alone; `None` where it has none.
    pub fn text_attribute(path: &Path, key: &str) -> Result<Option<String>, String> {
        use exr::meta::attribute::AttributeValue;
        let Some(header) = first_header(path)? else {
            return Ok(None);
        };
        let found = header
            .own_attributes
            .other
            .iter()
            .chain(header.shared_attributes.other.iter())
            .find(|(name, _)| *name == key);
        Ok(match found {
            Some((_, AttributeValue::Text(text))) => Some(text.to_string()),
            _ => None,
        })
    }

    /// Where `image` and `other` both name the scene they were made of
    /// (`photondiff/scene_hash`, which `render` and `reference` write) and the two differ, a
    /// sentence saying so: the figures then compare two scenes (a reference of an edited
    /// scene, another resolution's copy of the scene file), which may be meant (an instanced
    /// scene against its flattened twin) but is more often a mistake that no figure shows.
    pub fn other_scene(image: &Path, other: &Path) -> Result<Option<String>, String> {
        const KEY: &str = "photondiff/scene_hash";
        let (a, b) = (
            Self::text_attribute(image, KEY)?,
            Self::text_attribute(other, KEY)?,
        );
        Ok(match (a, b) {
            (Some(a), Some(b)) if a != b => Some(format!(
                "{} and {} are of different scenes ({KEY} {a} and {b}): the figures compare \
                 two scenes",
                image.display(),
                other.display()
            )),
            _ => None,
        })
    }

    /// Writes the image as a 32-bit float EXR (tests and masks).
    pub fn write_exr(&self, path: &Path) -> Result<(), String> {
        use exr::prelude::*;
        let channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = self
            .names
            .iter()
            .zip(&self.planes)
            .map(|(n, p)| {
                AnyChannel::new(
                    n.as_str(),
                    FlatSamples::F32(p.iter().map(|&v| v as f32).collect()),
                )
            })
            .collect();
        let layer = Layer::new(
            (self.width, self.height),
            LayerAttributes::default(),
            Encoding::FAST_LOSSLESS,
            AnyChannels::sort(channels),
        );
        Image::from_layer(layer)
            .write()
            .to_file(path)
            .map_err(|e| format!("{}: cannot write EXR: {e}", path.display()))
    }

    /// The first non-finite value, as an error naming the file, pixel and channel.
    pub fn check_finite(&self, name: &Path) -> Result<(), String> {
        for (c, plane) in self.planes.iter().enumerate() {
            if let Some(i) = plane.iter().position(|v| !v.is_finite()) {
                return Err(format!(
                    "{}: channel {} of pixel ({}, {}) is not finite ({})",
                    name.display(),
                    self.names[c],
                    i % self.width,
                    i / self.width,
                    plane[i]
                ));
            }
        }
        Ok(())
    }

    /// The channels `compare` measures: all but alpha (`A`), which is coverage, not radiance.
    pub fn measured_channels(&self) -> Vec<usize> {
        let colour: Vec<usize> = (0..self.names.len())
            .filter(|&c| self.names[c] != "A" && !self.names[c].ends_with(".A"))
            .collect();
        if colour.is_empty() {
            (0..self.names.len()).collect()
        } else {
            colour
        }
    }

    /// The plane of channel `name`, if present.
    pub fn plane(&self, name: &str) -> Option<&[f64]> {
        let c = self.names.iter().position(|n| n == name)?;
        Some(&self.planes[c])
    }

    /// Pixels where any channel is above zero: a mask.
    pub fn mask(&self) -> Vec<bool> {
        (0..self.width * self.height)
            .map(|i| self.planes.iter().any(|p| p[i] > 0.0))
            .collect()
    }
}

/// The header of the file's first layer, read alone (`None`: the file has no layer).
fn first_header(path: &Path) -> Result<Option<exr::meta::header::Header>, String> {
    let meta = exr::meta::MetaData::read_from_file(path, false).map_err(|e| {
        format!(
            "{}: cannot read EXR: {}",
            path.display(),
            one_line(&e.to_string())
        )
    })?;
    Ok(meta.headers.into_iter().next())
}

/// Library errors can span lines; the command line prints one.
fn one_line(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}
