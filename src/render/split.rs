//! Splitting an image for several processes: `--tile I/N` renders band `I` (0-based) of `N`
//! horizontal bands made of whole rows of [`TILE_SIZE`] x [`TILE_SIZE`] render tiles.
//!
//! The image's `R = ceil(height / TILE_SIZE)` rows of render tiles are dealt out as
//! `floor(I R / N) .. floor((I + 1) R / N)`: bands differ by at most one tile row, together they
//! cover the image exactly once, and each is a rectangle the full width of the image. Bands are
//! whole render tiles because each render tile draws its random numbers from one stream
//! seeded by the run's seed and the tile's first pixel: a band renders exactly the tiles, hence
//! the bits, that a render of the whole image does there.

use super::image::TILE_SIZE;
use std::fmt;
use std::str::FromStr;

/// A rectangle of pixels `[x0, x1) x [y0, y1)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Window {
    /// First column.
    pub x0: u32,
    /// First row.
    pub y0: u32,
    /// One past the last column.
    pub x1: u32,
    /// One past the last row.
    pub y1: u32,
}

impl Window {
    /// The whole of a `width` x `height` image.
    pub fn full(width: u32, height: u32) -> Self {
        Window {
            x0: 0,
            y0: 0,
            x1: width,
            y1: height,
        }
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.x1 - self.x0
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.y1 - self.y0
    }

    /// Whether the two windows share a pixel.
    pub fn overlaps(&self, other: &Window) -> bool {
        self.x0 < other.x1 && other.x0 < self.x1 && self.y0 < other.y1 && other.y0 < self.y1
    }

    /// Checks that the window lies in a `width` x `height` image and is made of whole render
    /// tiles (its edges on the tile grid or on the image's edges).
    pub fn check(&self, width: u32, height: u32) -> Result<(), String> {
        let on_grid = |v: u32, edge: u32| v.is_multiple_of(TILE_SIZE) || v == edge;
        if self.x0 >= self.x1 || self.y0 >= self.y1 || self.x1 > width || self.y1 > height {
            return Err(format!(
                "window {self} is not inside the {width} x {height} image"
            ));
        }
        if !(on_grid(self.x0, width)
            && on_grid(self.y0, height)
            && on_grid(self.x1, width)
            && on_grid(self.y1, height))
        {
            return Err(format!(
                "window {self} does not follow the {TILE_SIZE}-pixel render tiles"
            ));
        }
        Ok(())
    }
}

impl fmt::Display for Window {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "x {}..{}, y {}..{}", self.x0, self.x1, self.y0, self.y1)
    }
}

/// Tile `index` (0-based) of `count`, as given by `--tile I/N`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TileSplit {
    /// Which band, `0..count`.
    pub index: u32,
    /// Number of bands.
    pub count: u32,
}

impl FromStr for TileSplit {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        let bad = || format!("expected I/N with 0 <= I < N (I counts from 0), got {s:?}");
        let (i, n) = s.split_once('/').ok_or_else(bad)?;
        // Read wide, so that a number past u32 is told as too large, not as malformed.
        let number = |t: &str| -> Result<u32, String> {
            let wide: u64 = t.trim().parse().map_err(|_| bad())?;
            u32::try_from(wide).map_err(|_| format!("{s:?}: I and N must be at most {}", u32::MAX))
        };
        let (index, count) = (number(i)?, number(n)?);
        if count == 0 {
            return Err(format!("{s:?}: the number of tiles N must be at least 1"));
        }
        if index >= count {
            return Err(format!(
                "{s:?}: tile I must be below N = {count} (tiles count from 0)"
            ));
        }
        Ok(TileSplit { index, count })
    }
}

impl fmt::Display for TileSplit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

impl TileSplit {
    /// The band's window in a `width` x `height` image; an error when the image has fewer rows
    /// of render tiles than bands.
    pub fn window(&self, width: u32, height: u32) -> Result<Window, String> {
        let rows = height.div_ceil(TILE_SIZE);
        if self.count > rows {
            return Err(format!(
                "--tile {self}: the {height}-pixel-high image has only {rows} rows of \
                 {TILE_SIZE}-pixel tiles; use at most {rows} tiles"
            ));
        }
        let row = |i: u32| (i as u64 * rows as u64 / self.count as u64) as u32;
        Ok(Window {
            x0: 0,
            x1: width,
            y0: row(self.index) * TILE_SIZE,
            y1: (row(self.index + 1) * TILE_SIZE).min(height),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bands_cover_the_image_exactly_once() {
        for (w, h) in [(640u32, 480u32), (100, 113), (17, 16), (5, 200)] {
            for n in 1..=h.div_ceil(TILE_SIZE) {
                let windows: Vec<Window> = (0..n)
                    .map(|i| TileSplit { index: i, count: n }.window(w, h).unwrap())
                    .collect();
                assert_eq!(windows[0].y0, 0);
                assert_eq!(windows.last().unwrap().y1, h);
                for pair in windows.windows(2) {
                    assert_eq!(pair[0].y1, pair[1].y0);
                    assert!(!pair[0].overlaps(&pair[1]));
                }
                for win in &windows {
                    win.check(w, h).unwrap();
                    assert_eq!((win.x0, win.x1), (0, w));
                }
                let heights: Vec<u32> = windows.iter().map(|w| w.height().div_ceil(16)).collect();
                let (lo, hi) = (heights.iter().min().unwrap(), heights.iter().max().unwrap());
                assert!(hi - lo <= 1, "{heights:?}");
            }
        }
    }

    #[test]
    fn bad_splits_are_errors() {
        assert_eq!(
            "0/0".parse::<TileSplit>().unwrap_err(),
            "\"0/0\": the number of tiles N must be at least 1"
        );
        assert_eq!(
            "5/4".parse::<TileSplit>().unwrap_err(),
            "\"5/4\": tile I must be below N = 4 (tiles count from 0)"
        );
        assert_eq!(
            "4/4".parse::<TileSplit>().unwrap_err(),
            "\"4/4\": tile I must be below N = 4 (tiles count from 0)"
        );
        assert_eq!(
            "0/18446744073709551615".parse::<TileSplit>().unwrap_err(),
            "\"0/18446744073709551615\": I and N must be at most 4294967295"
        );
        for bad in ["a/4", "3", "0/99999999999999999999"] {
            assert_eq!(
                bad.parse::<TileSplit>().unwrap_err(),
                format!("expected I/N with 0 <= I < N (I counts from 0), got {bad:?}")
            );
        }
        assert_eq!(
            TileSplit { index: 0, count: 4 }.window(64, 48).unwrap_err(),
            "--tile 0/4: the 48-pixel-high image has only 3 rows of 16-pixel tiles; use at most 3 tiles"
        );
    }

    #[test]
    fn windows_off_the_tile_grid_are_refused() {
        assert_eq!(
            Window {
                x0: 8,
                y0: 0,
                x1: 64,
                y1: 32
            }
            .check(64, 48)
            .unwrap_err(),
            "window x 8..64, y 0..32 does not follow the 16-pixel render tiles"
        );
        assert_eq!(
            Window {
                x0: 0,
                y0: 0,
                x1: 64,
                y1: 48
            }
            .check(64, 40)
            .unwrap_err(),
            "window x 0..64, y 0..48 is not inside the 64 x 40 image"
        );
        Window {
            x0: 16,
            y0: 32,
            x1: 50,
            y1: 40,
        }
        .check(50, 40)
        .unwrap();
    }
}
