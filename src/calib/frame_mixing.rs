//! The camera's colour mixing estimated from a scanned frame itself, for rigs whose
//! white-card frames (what [`super::estimate_crosstalk`] needs) were never taken:
//! third-party captures, or a page where the guided measurement was skipped.
//!
//! # Method
//!
//! Where a scan has identified the stripes, the projector's colour at a camera pixel is
//! known: the product over the families of the identified stripes' palette colours
//! (`pattern`'s combination), in the projector's linear light `p`. The camera sees
//! `o = M diag(a) p + b`: `a` the surface's reflectance of each primary's light, `b`
//! ambient light and the projector's black level, both unknown but nearly constant
//! over a small tile of the frame. Within a tile, each camera channel is therefore a
//! linear function of `p`, and the slopes form the matrix `M diag(a)`: column `k` is
//! column `k` of `M` times `a_k`, so scaling each column to sum to 1 removes the
//! surface. Each tile whose pixels show enough different projector colours gives one
//! estimate of the columns of the primaries it varies (a primary that barely varies
//! over the tile is held constant, its light part of the offset `b`), on any surface
//! colour; the estimate kept is the median
//! over the tiles, weighted by how much of the primary's light came back, which
//! outvotes the few tiles where a wrong identity or an edge of the surface's texture
//! skewed the fit.
//!
//! **The scale of the columns.** From a frame of unknown surfaces the strength of a
//! primary cannot be told from a surface that reflects it more, so the columns are
//! scaled to sum to 1 (not the rows, as [`super::estimate_crosstalk`] scales its
//! card's). Decoding does not need the columns' scale: the scanner undoes `M`, and a
//! column scaled by `y_k` leaves the primary `k` scaled by `1 / y_k` in every pixel,
//! which is a change of surface colour that the decoder discounts. The rows' scale
//! (the camera channels' gains at the time of the frame) is what it needs, and what a
//! frame gives. Where `M` is symmetric, as the simulator's is, both scalings agree.
//!
//! Only pixels well inside a stripe of every family are used (a quarter of a stripe
//! from its boundaries), so blur, half-resolution chroma and an imprecise boundary do
//! not mix two stripes' colours; a clipped channel is left out of its own fit (its
//! slope is cut), not out of the others'.
//! The estimate does not depend on the mixing the scan was decoded with, only on which
//! stripes it identified, so a scan decoded with the identity gives it, and a second
//! scan with the estimate identifies more.

use super::Crosstalk;
use crate::error::{Error, Result};
use crate::pattern::PatternSpec;
use glam::{DMat3, DVec3};

/// How far inside a stripe (as a fraction of its width, from either boundary) a pixel
/// must lie to be used: a quarter leaves the middle half, at least 1.6 camera pixels
/// from each boundary on the demo rig's 6.5-pixel stripes.
const INTERIOR: f32 = 0.25;

/// Least pixels in a tile for its fit.
const TILE_MIN_PIXELS: usize = 24;

/// Least spread of the projector's linear light in a tile, per primary (standard
/// deviation, full light = 1): below it the tile shows too few colours for that
/// primary's column.
const TILE_MIN_SPREAD: f64 = 0.08;

/// Least determinant of the tile's correlation matrix of the three primaries: near 0
/// two primaries move together in the tile (a pattern of a few colours seen over a
/// few stripes), and the fit cannot tell their columns apart.
const TILE_MIN_INDEPENDENCE: f64 = 0.05;

/// Least share of each camera channel's variance in a tile that the fit explains:
/// below it the tile holds more than one surface colour, or wrong identities.
const TILE_MIN_EXPLAINED: f64 = 0.8;

/// A tile's column is kept when no entry is below this fraction of the column's sum
/// (negative slopes are noise or a skewed fit).
const COLUMN_MIN_ENTRY: f64 = -0.1;

/// Least tiles that must give each column.
///
/// Under 25-pixel stripes (`eval --hard`'s `wide` rows) crumpled paper, the textured
/// scene and paper in 1 % dyes give 9, 3 and 1 tiles and no estimate: a tile of a few
/// stripes of the default pattern often shows its primaries moving together (its
/// sequence pairs each colour with its complement, grey with white), and a larger tile
/// holds more than one surface colour. Tried on 2026-12-08 and not kept: tiles
/// overlapping by half, four times as many, gave estimates there, but 0.06 (paper)
/// and 0.13 (textured) off the card's matrix, where the rows with an estimate are
/// within 0.08; and columns read from pairs of neighbouring stripes whose colours
/// differ in one primary alone (no tile fit, the surface the same on both sides)
/// found none, since every boundary of the default pattern changes two or three
/// channels.
const MIN_TILES: usize = 16;

/// What [`estimate_crosstalk_from_stripes`] found.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameMixing {
    /// The colour mixing (row = camera channel, as `scan --crosstalk` takes it),
    /// columns scaled to sum to 1.
    pub crosstalk: Crosstalk,
    /// Tiles that gave each primary's column.
    pub tiles: [usize; 3],
    /// Pixels used.
    pub pixels: usize,
}

/// One camera channel's sums over a tile: the projector's light `p`, the channel's
/// light `o`, their products, over the tile's pixels where the channel is not clipped.
#[derive(Clone, Copy, Default)]
struct ChannelSums {
    n: usize,
    p: [f64; 3],
    pp: [[f64; 3]; 3],
    po: [f64; 3],
    o: f64,
    oo: f64,
}

impl ChannelSums {
    fn add(&mut self, p: &[f64; 3], o: f64) {
        self.n += 1;
        self.o += o;
        self.oo += o * o;
        for k in 0..3 {
            self.p[k] += p[k];
            self.po[k] += p[k] * o;
            for m in 0..3 {
                self.pp[k][m] += p[k] * p[m];
            }
        }
    }

    /// The channel's slope against each primary the tile shows enough of (`None` for
    /// the others), where the tile has enough pixels, shows those primaries apart, and
    /// the straight line explains the channel's light (see the constants). A primary
    /// that barely varies over the tile is held constant: its light goes into the
    /// line's offset with the ambient light, so a tile of one primary's stripes and
    /// black still reads that primary's column.
    fn slopes(&self) -> Option<[Option<f64>; 3]> {
        if self.n < TILE_MIN_PIXELS {
            return None;
        }
        let count = self.n as f64;
        let mean_p = DVec3::from_array(self.p) / count;
        let mut cov = DMat3::from_cols_array_2d(&self.pp) * (1.0 / count) - outer(mean_p, mean_p);
        let spread = DVec3::new(cov.x_axis.x, cov.y_axis.y, cov.z_axis.z);
        let shown: [bool; 3] = std::array::from_fn(|k| spread[k] >= TILE_MIN_SPREAD * TILE_MIN_SPREAD);
        if !shown.iter().any(|&s| s) {
            return None;
        }
        let mean_o = self.o / count;
        let mut cross = DVec3::from_array(self.po) / count - mean_p * mean_o;
        // The primaries held constant leave the fit: their rows and columns of the
        // covariance become the identity's, their covariance with the channel 0.
        for k in (0..3).filter(|&k| !shown[k]) {
            for m in 0..3 {
                let v = if m == k { 1.0 } else { 0.0 };
                cov.col_mut(k)[m] = v;
                cov.col_mut(m)[k] = v;
            }
            cross[k] = 0.0;
        }
        let sd = |k: usize| if shown[k] { spread[k].sqrt() } else { 1.0 };
        let scale = DMat3::from_diagonal(DVec3::new(1.0 / sd(0), 1.0 / sd(1), 1.0 / sd(2)));
        if (scale * cov * scale).determinant() < TILE_MIN_INDEPENDENCE {
            return None;
        }
        let slope = cov.inverse() * cross;
        let variance = self.oo / count - mean_o * mean_o;
        (slope.dot(cross) >= TILE_MIN_EXPLAINED * variance && slope.is_finite()).then(|| std::array::from_fn(|k| shown[k].then_some(slope[k])))
    }
}

/// Estimate the colour mixing from one scanned frame.
///
/// `frame` is the 8-bit frame (half-resolution chroma already interpolated), `width`
/// pixels a row; `linear` the camera's light per code (its response or power law);
/// `stripe_coords` each family's stripe coordinate per pixel as the scan gave it
/// (boundary j at j, NaN where none); `depth` the scan's merged depth (NaN where the
/// scan kept no point: only pixels it kept are used); `tile` the side of a tile in
/// pixels (a few stripe periods, so that a tile shows several colours).
pub fn estimate_crosstalk_from_stripes(
    spec: &PatternSpec,
    frame: &[[u8; 3]],
    width: usize,
    linear: &[f32; 256],
    stripe_coords: &[Vec<f32>],
    depth: &[f32],
    tile: usize,
) -> Result<FrameMixing> {
    let fail = Error::FrameMixing;
    let n = frame.len();
    if width == 0 || n % width != 0 || depth.len() != n || stripe_coords.len() != spec.families.len() || stripe_coords.iter().any(|c| c.len() != n) {
        return Err(Error::Internal(format!("frame of {n} pixels, depth of {}, stripe coordinates of other sizes", depth.len())));
    }
    let tile = tile.max(4);
    let height = n / width;
    let (tiles_x, tiles_y) = (width.div_ceil(tile), height.div_ceil(tile));
    let mut sums = vec![[ChannelSums::default(); 3]; tiles_x * tiles_y];
    let mut pixels = 0usize;
    for (i, (&code, &z)) in frame.iter().zip(depth).enumerate() {
        if z.is_nan() || code.iter().all(|&c| c >= crate::raster::SATURATED) {
            continue;
        }
        let mut p = [1f64; 3];
        let mut inside = true;
        for (family, coords) in stripe_coords.iter().enumerate() {
            let q = coords[i];
            let fraction = q - q.floor();
            if !(INTERIOR..=1.0 - INTERIOR).contains(&fraction) {
                inside = false;
                break;
            }
            let colour = spec.stripe_color(family, q.floor() as i64);
            for k in 0..3 {
                p[k] *= colour[k];
            }
        }
        if !inside {
            continue;
        }
        // A clipped channel is left out of its own fit only: the others still read
        // how much of each primary they see (the leak from a primary bright enough
        // to clip its own channel is read there).
        let tile_sums = &mut sums[(i / width / tile) * tiles_x + (i % width) / tile];
        for (c, channel) in tile_sums.iter_mut().enumerate() {
            if code[c] < crate::raster::SATURATED {
                channel.add(&p, linear[code[c] as usize] as f64);
            }
        }
        pixels += 1;
    }
    // Per primary, each usable tile's column (scaled to sum 1) and its weight.
    let mut columns: [Vec<([f64; 3], f64)>; 3] = Default::default();
    for tile_sums in &sums {
        // slopes[c][k]: camera channel c's slope against primary k, where the tile varies k.
        let (Some(r), Some(g), Some(b)) = (tile_sums[0].slopes(), tile_sums[1].slopes(), tile_sums[2].slopes()) else {
            continue;
        };
        let count = tile_sums.iter().map(|c| c.n).min().unwrap_or(0) as f64;
        for (k, columns) in columns.iter_mut().enumerate() {
            let (Some(r), Some(g), Some(b)) = (r[k], g[k], b[k]) else { continue };
            let column = DVec3::new(r, g, b);
            let sum = column.element_sum();
            if !(sum > 0.0 && sum.is_finite()) || column.min_element() < COLUMN_MIN_ENTRY * sum {
                continue;
            }
            columns.push(((column / sum).to_array(), sum * count));
        }
    }
    let tiles = [columns[0].len(), columns[1].len(), columns[2].len()];
    if let Some(k) = (0..3).find(|&k| tiles[k] < MIN_TILES) {
        return Err(fail(format!(
            "only {} regions of identified stripes show enough of the projector's colours to read primary {k} \
             ({pixels} pixels inside stripes; at least {MIN_TILES} regions needed): decode more of the frame first",
            tiles[k]
        )));
    }
    let mut crosstalk = [[0f32; 3]; 3];
    for (k, columns) in columns.iter_mut().enumerate() {
        let column: [f64; 3] = std::array::from_fn(|c| weighted_median(columns, |t| t.0[c]).max(0.0));
        let sum: f64 = column.iter().sum();
        if !(sum > 0.0) {
            return Err(fail(format!("no camera channel saw primary {k}")));
        }
        for c in 0..3 {
            crosstalk[c][k] = (column[c] / sum) as f32;
        }
    }
    super::crosstalk_inverse(&crosstalk).map_err(|_| fail(format!("the estimate {crosstalk:?} cannot be inverted")))?;
    Ok(FrameMixing { crosstalk, tiles, pixels })
}

/// `a bᵀ`.
fn outer(a: DVec3, b: DVec3) -> DMat3 {
    DMat3::from_cols(a * b.x, a * b.y, a * b.z)
}

/// The weighted median of `key` over `items` (weight in `.1`); sorts `items` by it.
fn weighted_median(items: &mut [([f64; 3], f64)], key: impl Fn(&([f64; 3], f64)) -> f64) -> f64 {
    items.sort_by(|a, b| key(a).total_cmp(&key(b)));
    let total: f64 = items.iter().map(|r| r.1).sum();
    let mut acc = 0.0;
    for item in items.iter() {
        acc += item.1;
        if acc >= total / 2.0 {
            return key(item);
        }
    }
    items.last().map_or(0.0, key)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A tile whose stripes vary only the red primary's light (a pattern of one
    /// primary's stripes and black, as some third-party ones are): red's column is read,
    /// the others are not guessed, and a tile that varies none reads nothing.
    #[test]
    fn a_tile_of_one_primary_reads_that_primarys_column() {
        // Camera channel c sees 0.6, 0.3, 0.1 of the red primary, on a surface
        // reflecting 0.5 of it, over ambient light of 0.05.
        let column = [0.6, 0.3, 0.1];
        let mut sums = [ChannelSums::default(); 3];
        for i in 0..40 {
            let red = if i % 3 == 0 { 0.2 } else { 1.0 };
            let p = [red, 0.35, 0.35];
            for (c, channel) in sums.iter_mut().enumerate() {
                channel.add(&p, 0.5 * column[c] * red + 0.05 + 0.1 * (c as f64) * 0.35);
            }
        }
        for (c, channel) in sums.iter().enumerate() {
            let slopes = channel.slopes().expect("a tile of red stripes gave no fit");
            let red = slopes[0].expect("no slope against red");
            assert!((red - 0.5 * column[c]).abs() < 1e-9, "channel {c}: {red}");
            assert_eq!((slopes[1], slopes[2]), (None, None), "channel {c}");
        }
        let mut flat = ChannelSums::default();
        for _ in 0..40 {
            flat.add(&[1.0, 0.35, 0.35], 0.4);
        }
        assert_eq!(flat.slopes(), None);
    }
}
