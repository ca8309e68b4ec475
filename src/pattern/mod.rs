//! Colour-stripe patterns with spatially windowed uniqueness, in one, two or three
//! directions, and the JSON spec that describes one completely.
//!
//! # Design
//!
//! **Palette.** Generated patterns use eight colours, one per corner of the RGB cube:
//! each channel of a stripe is either *high* (1.0) or *low* (`low`, never 0), in linear
//! light. A spec may hold any palette of 2 to 8 colours, levels of 0 included (black
//! stripes, or the 3-colour RGB patterns common elsewhere): the projector's black
//! level is the floor the camera sees, and a channel at 0 on both sides of a boundary
//! is *unchanged*. The decoder never
//! needs absolute colour: log-gradient restoration (paper eq. 6) loses each channel's
//! mean level, so what survives, robustly and independently of the surface colour, is
//! the *transition* at a stripe boundary: per channel up, down or unchanged. A transition
//! code is therefore a vector in {-1, 0, +1}³ with at least one non-zero entry; from any
//! colour exactly 7 transitions are possible.
//!
//! **Sequence.** The stripes follow a sequence in which adjacent colours always differ
//! and every window of `window` consecutive stripes is unique *by its transitions*
//! (which implies unique by colours). This is a de Bruijn-style construction over
//! transitions rather than the paper's permutation pattern (its reference 12): with 8 colours a
//! 3-stripe window (two transitions) already allows 290 distinct windows, enough for
//! 1024 / 4 stripes, so a stripe is identified from itself and its two neighbours:
//! half the window of the paper's 7-stripe permutation pattern, which is what matters
//! near occluding boundaries. The sequence is built by depth-first search with
//! backtracking, trying first the transitions that change the most channels (they are
//! the easiest to see through crosstalk and noise). When a pattern needs more stripes
//! than a window allows, the window grows.
//!
//! **Directions.** A family of stripes has a normal angle θ in projector pixel
//! coordinates (v down): its *coordinate* is
//! `s = (u - (W-1)/2) cos θ + (v - (H-1)/2) sin θ` and stripe `j` covers
//! `origin + j·w <= s < origin + (j+1)·w`. One direction is θ = 0 (vertical stripes);
//! two are 0 and 90 degrees; three are 60 degrees apart at -15, 45 and 105 degrees, so
//! that a diagonal baseline (the demo rig's) is at most 60 degrees from every normal and
//! each family triangulates with at least half the baseline.
//!
//! **Combination.** The families are multiplied per channel in linear light:
//! `L = L1 ⊙ L2 (⊙ L3)`. In the log domain this is a sum, `ln L = ln L1 + ln L2`, so a
//! derivative across family 1 sees family 1's edges at full strength and family 2's
//! only through the cosine of the angle between the normals (0 for perpendicular
//! families, 0.5 for 60 degrees; the restoration filter weights by the cosine squared,
//! 0.25). Because `low > 0`, no channel is ever driven to zero by the product (the
//! darkest cell is `low^N`), so every family's transitions stay visible in every cell.
//! `low` grows with the number of families (0.25, 0.35, 0.45) to keep `low^N` above the
//! projector's black level.
//!
//! **Margins.** A family's stripes need not cover the projector: outside them the
//! projector shows the spec's `background` (black unless given). The boundaries
//! between the background and the first and last stripes are identified like any
//! other when they lie on the projector image (boundary 0 and boundary `count`).
//!
//! **Pixels.** The pattern image stores `255 · L^(1/encoding_gamma)` so that a projector
//! with that gamma emits `L`. Stripe edges are antialiased by 4x4 supersampling of each
//! family before the product (which keeps the product separable).

pub mod import;

use crate::error::{Error, Result};
use crate::raster::{Image, Rgb};
use serde::{Deserialize, Serialize};

/// The `format` field of every spec file.
pub const SPEC_FORMAT: &str = "stripelight-pattern";
/// The spec version this crate reads and writes.
pub const SPEC_VERSION: u32 = 1;

/// Default stripe width in projector pixels: on the demo rig a stripe spans about 6.5
/// camera pixels, enough for a 3x3 Sobel on rotated images and for 4:2:0 webcam chroma
/// (about 3 chroma samples per stripe).
pub const DEFAULT_STRIPE_WIDTH: f64 = 10.0;

/// Supersampling per axis when rendering stripe edges.
const SUPERSAMPLE: usize = 4;

/// One stripe family: a direction, a width and the stripes that cover the image.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Family {
    /// Angle of the stripes' normal in projector pixels, degrees (0 = vertical stripes).
    pub angle_deg: f64,
    /// Stripe width along the normal, projector pixels.
    pub stripe_width: f64,
    /// Coordinate `s` where stripe 0 begins.
    pub origin: f64,
    /// Number of stripes used (a prefix of the sequence).
    pub count: usize,
}

/// A complete description of a pattern: a decoder needs nothing else.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PatternSpec {
    /// Always [`SPEC_FORMAT`].
    pub format: String,
    /// Always [`SPEC_VERSION`].
    pub version: u32,
    /// Projector width in pixels.
    pub width: u32,
    /// Projector height in pixels.
    pub height: u32,
    /// Pixel value = 255 · linear^(1 / encoding_gamma).
    pub encoding_gamma: f64,
    /// Stripe colours, linear RGB in [0, 1]; 2 to 8 of them.
    pub palette: Vec<[f64; 3]>,
    /// What the projector shows outside a family's stripes, linear RGB in [0, 1]
    /// (black when absent). Only seen when the stripes leave margins.
    #[serde(default, skip_serializing_if = "is_black")]
    pub background: [f64; 3],
    /// Palette index of each stripe; shared by all families.
    pub sequence: Vec<u8>,
    /// Every window of this many consecutive stripes is unique by its transitions.
    pub window: usize,
    /// The stripe families, multiplied into one image.
    pub families: Vec<Family>,
}

/// Whether a colour is black (the default background, left out of spec files).
fn is_black(c: &[f64; 3]) -> bool {
    c.iter().all(|&x| x == 0.0)
}

/// Most palette colours a spec may hold.
pub const MAX_PALETTE: usize = 8;

/// A transition code: per channel -1 (down), 0 (unchanged) or +1 (up).
pub type Transition = [i8; 3];

/// Log-ratio below which a channel counts as unchanged between two palette colours.
const SAME_LEVEL_LOG: f64 = 0.1;

/// The transition from palette colour `a` to `b`. A channel at 0 on both sides is
/// unchanged; from 0 to any level it is up.
pub fn transition(a: [f64; 3], b: [f64; 3]) -> Transition {
    let mut t = [0i8; 3];
    for c in 0..3 {
        if a[c] == b[c] {
            continue;
        }
        let d = (b[c] / a[c]).ln();
        t[c] = if d > SAME_LEVEL_LOG {
            1
        } else if d < -SAME_LEVEL_LOG {
            -1
        } else {
            0
        };
    }
    t
}

/// Normal angles of the stripe families for a pattern of `directions` directions.
pub fn family_angles(directions: usize) -> Result<&'static [f64]> {
    match directions {
        1 => Ok(&[0.0]),
        2 => Ok(&[0.0, 90.0]),
        3 => Ok(&[-15.0, 45.0, 105.0]),
        n => Err(Error::Setting { name: "directions", problem: format!("must be 1, 2 or 3, got {n}") }),
    }
}

/// The eight-colour palette with the given low level.
pub fn binary_palette(low: f64) -> Vec<[f64; 3]> {
    (0..8u8)
        .map(|c| {
            let level = |bit: u8| if c >> bit & 1 == 1 { 1.0 } else { low };
            [level(2), level(1), level(0)]
        })
        .collect()
}

/// A sequence of `len` colours from a palette of 8 binary colours in which adjacent
/// colours differ and every window of `window` colours is unique by its transitions.
/// `None` when no such sequence exists within the search budget.
pub fn windowed_sequence(len: usize, window: usize) -> Option<Vec<u8>> {
    windowed_sequence_in(&binary_palette(0.5), len, window)
}

/// [`windowed_sequence`] over any palette of up to [`MAX_PALETTE`] colours: adjacent
/// colours differ in at least one channel and every window of `window` colours is
/// unique by its transitions. Depth-first search with backtracking, trying first the
/// colours that change the most channels.
pub fn windowed_sequence_in(palette: &[[f64; 3]], len: usize, window: usize) -> Option<Vec<u8>> {
    let k = palette.len();
    if k < 2 || k > MAX_PALETTE || window < 2 {
        return None;
    }
    let code = |a: u8, b: u8| -> u32 {
        let t = transition(palette[a as usize], palette[b as usize]);
        t.iter().fold(0, |acc, &x| acc * 3 + (x + 1) as u32)
    };
    let changed = |a: u8, b: u8| transition(palette[a as usize], palette[b as usize]).iter().filter(|&&x| x != 0).count();
    // Candidate next colours from each colour, most channels changed first, ties
    // broken by a rotation that spreads colours evenly.
    let order: Vec<Vec<u8>> = (0..k as u8)
        .map(|c| {
            let mut next: Vec<u8> = (0..k as u8).filter(|&n| changed(c, n) > 0).collect();
            next.sort_by_key(|&n| (std::cmp::Reverse(changed(c, n)), (n as usize + k - c as usize) % k));
            next
        })
        .collect();
    let key = |seq: &[u8]| -> u64 {
        seq.windows(2).fold(0u64, |acc, w| acc.wrapping_mul(27).wrapping_add(code(w[0], w[1]) as u64))
    };
    let mut seq = vec![0u8];
    let mut choice = vec![0usize];
    let mut used = std::collections::HashSet::new();
    let mut budget = 2_000_000usize;
    while seq.len() < len {
        budget = budget.checked_sub(1)?;
        let last = *seq.last()? as usize;
        let k = choice.last_mut()?;
        if *k >= order[last].len() {
            // Dead end: step back.
            choice.pop();
            let n = seq.len();
            if n >= window {
                used.remove(&key(&seq[n - window..]));
            }
            seq.pop();
            if seq.is_empty() {
                return None;
            }
            continue;
        }
        let next = order[last][*k];
        *k += 1;
        seq.push(next);
        let n = seq.len();
        if n >= window && !used.insert(key(&seq[n - window..])) {
            seq.pop();
            continue;
        }
        choice.push(0);
    }
    Some(seq)
}

impl Family {
    /// Coefficients (a, b, c) of the family's coordinate in *stripe units*,
    /// `q = a·u + b·v + c`, so that stripe `j` covers `j <= q < j + 1` and the boundary
    /// between stripes `j - 1` and `j` is `q = j`.
    pub fn stripe_coord(&self, width: u32, height: u32) -> (f64, f64, f64) {
        let (s, c) = self.angle_deg.to_radians().sin_cos();
        let (ou, ov) = ((width as f64 - 1.0) / 2.0, (height as f64 - 1.0) / 2.0);
        let w = self.stripe_width;
        (c / w, s / w, (-ou * c - ov * s - self.origin) / w)
    }

    /// Range of the family coordinate `s` over the projector image's pixel area.
    fn extent(angle_deg: f64, width: u32, height: u32) -> (f64, f64) {
        let (s, c) = angle_deg.to_radians().sin_cos();
        let (hu, hv) = (width as f64 / 2.0, height as f64 / 2.0);
        let r = hu * c.abs() + hv * s.abs();
        (-r, r)
    }
}

/// For a family of vertical (0 degrees) or horizontal (90 degrees) stripes a whole
/// number of pixels wide, the shift of `origin` (less than a pixel) that puts every
/// boundary on the edge between two projector pixels; `None` for other families. A
/// boundary inside a pixel is rendered as a blend of the two stripes' colours, which a
/// camera that resolves the projector's pixels sees as a band of a third colour (see
/// `scan::DecodeScale`).
fn edge_alignment(angle_deg: f64, width: u32, height: u32, origin: f64, stripe_width: f64) -> Option<f64> {
    if stripe_width.fract() != 0.0 {
        return None;
    }
    // The family coordinate is measured from the image's centre (`Family::stripe_coord`).
    let centre = match angle_deg {
        a if a == 0.0 => (width as f64 - 1.0) / 2.0,
        a if a == 90.0 => (height as f64 - 1.0) / 2.0,
        _ => return None,
    };
    // Boundary j lies at pixel coordinate centre + origin + j * stripe_width; pixel
    // edges are at half-integers.
    let at = centre + origin;
    Some((at - 0.5).round() + 0.5 - at)
}

impl PatternSpec {
    /// A pattern of `directions` stripe families for a `width` x `height` projector
    /// with stripes `stripe_width` projector pixels wide.
    ///
    /// ```
    /// let spec = stripelight::PatternSpec::generate(2, 1024, 768, 10.0).unwrap();
    /// assert_eq!(spec.families.len(), 2);
    /// spec.validate().unwrap();
    /// ```
    pub fn generate(directions: usize, width: u32, height: u32, stripe_width: f64) -> Result<Self> {
        let angles = family_angles(directions)?;
        if width == 0 || height == 0 || width > 16384 || height > 16384 {
            return Err(Error::Setting {
                name: "projector size",
                problem: format!("{width}x{height} is not in 1..=16384 on each side"),
            });
        }
        // Wider than the largest projector would be one stripe anywhere.
        if !(stripe_width.is_finite() && (2.0..=16384.0).contains(&stripe_width)) {
            return Err(Error::Setting {
                name: "stripe width",
                problem: format!("must be 2 to 16384 pixels, got {stripe_width}"),
            });
        }
        let mut families = Vec::new();
        for &angle in angles {
            let (lo, hi) = Family::extent(angle, width, height);
            // At least a window's worth of stripes (3, the smallest window), so that a
            // projector narrower than three stripes still gets a decodable pattern.
            let mut count = (((hi - lo) / stripe_width).ceil() as usize).max(3);
            // Centre the stripes on the image so both ends are cut alike.
            let mut origin = (lo + hi) / 2.0 - count as f64 * stripe_width / 2.0;
            if let Some(shift) = edge_alignment(angle, width, height, origin, stripe_width) {
                // Moved by up to half a pixel: one stripe more where the ends would
                // no longer be covered.
                if (origin + shift > lo) || (origin + shift + count as f64 * stripe_width < hi) {
                    count += 1;
                    origin = (lo + hi) / 2.0 - count as f64 * stripe_width / 2.0;
                }
                origin += edge_alignment(angle, width, height, origin, stripe_width).unwrap_or(0.0);
            }
            families.push(Family {
                angle_deg: angle,
                stripe_width,
                origin,
                count,
            });
        }
        let needed = families.iter().map(|f| f.count).max().unwrap_or(0);
        let (window, sequence) = (3..=8)
            .find_map(|w| windowed_sequence(needed, w).map(|s| (w, s)))
            .ok_or_else(|| Error::Setting {
                name: "stripe width",
                problem: format!("{needed} stripes are more than any window of up to 8 makes unique"),
            })?;
        let low = [0.25, 0.35, 0.45][directions - 1];
        // What is generated must read back; if not, the generator is wrong, not the input.
        Self::validated(width, height, binary_palette(low), [0.0; 3], sequence, window, families)
            .map_err(|e| Error::Internal(format!("the generated pattern is invalid: {e}")))
    }

    /// A validated spec of one stripe family on a `width` x `height` projector (a
    /// pattern from elsewhere): encoding gamma 2.2 unless changed afterwards.
    pub fn one_family(width: u32, height: u32, palette: Vec<[f64; 3]>, background: [f64; 3], sequence: Vec<u8>, window: usize, family: Family) -> Result<Self> {
        Self::validated(width, height, palette, background, sequence, window, vec![family])
    }

    /// A spec of the current format with encoding gamma 2.2, validated.
    fn validated(width: u32, height: u32, palette: Vec<[f64; 3]>, background: [f64; 3], sequence: Vec<u8>, window: usize, families: Vec<Family>) -> Result<Self> {
        let spec = PatternSpec {
            format: SPEC_FORMAT.into(),
            version: SPEC_VERSION,
            width,
            height,
            encoding_gamma: 2.2,
            palette,
            background,
            sequence,
            window,
            families,
        };
        spec.validate()?;
        Ok(spec)
    }

    /// Parse and validate a spec file. Errors name the offending field.
    pub fn from_json(text: &str) -> Result<Self> {
        let de = &mut serde_json::Deserializer::from_str(text);
        let spec: PatternSpec = serde_path_to_error::deserialize(de).map_err(|e| {
            let path = e.path().to_string();
            Error::Spec {
                field: if path == "." { "(file)".into() } else { path },
                problem: e.into_inner().to_string(),
            }
        })?;
        spec.validate()?;
        Ok(spec)
    }

    /// Pretty JSON.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).unwrap_or_default()
    }

    /// Check that the spec is complete, consistent and decodable.
    pub fn validate(&self) -> Result<()> {
        let err = |field: &str, problem: String| Error::Spec {
            field: field.into(),
            problem,
        };
        if self.format != SPEC_FORMAT {
            return Err(err("format", format!("must be {SPEC_FORMAT:?}, got {:?}", self.format)));
        }
        if self.version != SPEC_VERSION {
            return Err(err("version", format!("version {} is not supported (this build reads {SPEC_VERSION})", self.version)));
        }
        if self.width == 0 || self.height == 0 || self.width > 16384 || self.height > 16384 {
            return Err(err("width", format!("projector size {}x{} is not in 1..=16384", self.width, self.height)));
        }
        if !(self.encoding_gamma.is_finite() && (0.2..=5.0).contains(&self.encoding_gamma)) {
            return Err(err("encoding_gamma", format!("must be in 0.2..=5, got {}", self.encoding_gamma)));
        }
        if self.palette.len() < 2 || self.palette.len() > MAX_PALETTE {
            return Err(err("palette", format!("needs 2..={MAX_PALETTE} colours, got {}", self.palette.len())));
        }
        let in_range = |c: &[f64; 3]| c.iter().all(|x| x.is_finite() && (0.0..=1.0).contains(x));
        for (i, c) in self.palette.iter().enumerate() {
            if !in_range(c) {
                return Err(err(&format!("palette[{i}]"), format!("channels must be in [0, 1], got {c:?}")));
            }
        }
        if !in_range(&self.background) {
            return Err(err("background", format!("channels must be in [0, 1], got {:?}", self.background)));
        }
        if let Some(i) = self.sequence.iter().position(|&s| s as usize >= self.palette.len()) {
            return Err(err(&format!("sequence[{i}]"), format!("index {} is outside the palette of {}", self.sequence[i], self.palette.len())));
        }
        for (i, w) in self.sequence.windows(2).enumerate() {
            if transition(self.palette[w[0] as usize], self.palette[w[1] as usize]) == [0; 3] {
                return Err(err(&format!("sequence[{}]", i + 1), "adjacent stripes have the same colour".into()));
            }
        }
        if self.window < 2 || self.window > self.sequence.len().max(2) {
            return Err(err("window", format!("must be in 2..=sequence length, got {}", self.window)));
        }
        let mut seen = std::collections::HashMap::new();
        for (i, w) in self.sequence.windows(self.window).enumerate() {
            let key: Vec<Transition> = w.windows(2).map(|p| transition(self.palette[p[0] as usize], self.palette[p[1] as usize])).collect();
            if let Some(j) = seen.insert(key, i) {
                return Err(err("sequence", format!("windows at {j} and {i} have the same transitions, so stripes cannot be identified")));
            }
        }
        if self.families.is_empty() || self.families.len() > 3 {
            return Err(err("families", format!("needs 1..=3 families, got {}", self.families.len())));
        }
        for (i, f) in self.families.iter().enumerate() {
            let field = |n: &str| format!("families[{i}].{n}");
            if !f.angle_deg.is_finite() {
                return Err(err(&field("angle_deg"), "must be finite".into()));
            }
            // Wider than the largest projector is absurd, and `count · stripe_width` below
            // could overflow to infinity and pass any coverage check.
            if !(f.stripe_width.is_finite() && (2.0..=16384.0).contains(&f.stripe_width)) {
                return Err(err(&field("stripe_width"), format!("must be 2 to 16384 pixels, got {}", f.stripe_width)));
            }
            if !f.origin.is_finite() {
                return Err(err(&field("origin"), "must be finite".into()));
            }
            if f.count < 2 || f.count > self.sequence.len() {
                return Err(err(&field("count"), format!("must be in 2..={} (the sequence length), got {}", self.sequence.len(), f.count)));
            }
            // Margins are allowed, but the stripes must reach into the image.
            let (lo, hi) = Family::extent(f.angle_deg, self.width, self.height);
            let end = f.origin + f.count as f64 * f.stripe_width;
            if f.origin >= hi || end <= lo {
                return Err(err(&field("origin"), format!("stripes cover {:.1}..{end:.1}, outside the image's {lo:.1}..{hi:.1}", f.origin)));
            }
        }
        Ok(())
    }

    /// Linear colour of stripe `j`; the background outside the family's stripes.
    pub fn stripe_color(&self, family: usize, j: i64) -> [f64; 3] {
        let count = self.families[family].count as i64;
        match usize::try_from(j) {
            Ok(j) if (j as i64) < count => self.palette[self.sequence[j] as usize],
            _ => self.background,
        }
    }

    /// Per channel, whether some stripe of the sequence leaves it unlit (level 0).
    pub fn unlit_channels(&self) -> [bool; 3] {
        std::array::from_fn(|c| self.sequence.iter().any(|&i| self.palette.get(i as usize).is_some_and(|p| p[c] == 0.0)))
    }

    /// The transition from stripe `j - 1` to stripe `j` (boundary 0 and boundary
    /// `count` are the background's edges).
    pub fn boundary_transition(&self, family: usize, j: usize) -> Transition {
        transition(self.stripe_color(family, j as i64 - 1), self.stripe_color(family, j as i64))
    }

    /// Whether boundary `j` of a family (0..=count) lies on the projector image, so a
    /// camera can see it. Inner boundaries of a valid spec mostly do; the outer two
    /// only when the stripes leave a margin.
    pub fn boundary_on_image(&self, family: usize, j: usize) -> bool {
        let f = &self.families[family];
        let (lo, hi) = Family::extent(f.angle_deg, self.width, self.height);
        let s = f.origin + j as f64 * f.stripe_width;
        s > lo && s < hi
    }

    /// The family's linear colour averaged over the pixel at (u, v).
    fn family_pixel(&self, family: usize, u: usize, v: usize) -> [f64; 3] {
        let (a, b, c) = self.families[family].stripe_coord(self.width, self.height);
        let n = SUPERSAMPLE;
        let mut sum = [0.0; 3];
        for sy in 0..n {
            for sx in 0..n {
                let du = (sx as f64 + 0.5) / n as f64 - 0.5;
                let dv = (sy as f64 + 0.5) / n as f64 - 0.5;
                let q = a * (u as f64 + du) + b * (v as f64 + dv) + c;
                let col = self.stripe_color(family, q.floor() as i64);
                for k in 0..3 {
                    sum[k] += col[k];
                }
            }
        }
        sum.map(|x| x / (n * n) as f64)
    }

    /// One family's stripes alone, in linear light.
    pub fn render_family_linear(&self, family: usize) -> Image<Rgb> {
        let mut img = Image::new(self.width as usize, self.height as usize, [0f32; 3]);
        for v in 0..self.height as usize {
            for u in 0..self.width as usize {
                *img.get_mut(u, v) = self.family_pixel(family, u, v).map(|x| x as f32);
            }
        }
        img
    }

    /// The combined pattern (product of the families) in linear light.
    pub fn render_linear(&self) -> Image<Rgb> {
        let mut img = Image::new(self.width as usize, self.height as usize, [1f32; 3]);
        for f in 0..self.families.len() {
            let fam = self.render_family_linear(f);
            for (p, q) in img.pixels_mut().iter_mut().zip(fam.pixels()) {
                for k in 0..3 {
                    p[k] *= q[k];
                }
            }
        }
        img
    }

    /// The pattern as the 8-bit image to show on the projector.
    pub fn render_rgb8(&self) -> Image<[u8; 3]> {
        crate::raster::linear_to_rgb8(&self.render_linear(), self.encoding_gamma as f32)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Vertical and horizontal stripes a whole number of pixels wide have every
    /// boundary on a pixel edge, so every pixel of the rendered pattern is one palette
    /// colour (or the background), none a blend; on every projector size, odd or even.
    #[test]
    fn whole_pixel_stripes_render_without_blended_pixels() {
        for (w, h, stripe) in [(512, 384, 5.0), (341, 256, 5.0), (1024, 768, 10.0), (1365, 767, 7.0), (800, 600, 3.0), (1920, 1080, 9.0)] {
            let spec = PatternSpec::generate(2, w, h, stripe).unwrap();
            for f in 0..2 {
                let (lo, hi) = Family::extent(spec.families[f].angle_deg, w, h);
                let fam = &spec.families[f];
                assert!(fam.origin <= lo && fam.origin + fam.count as f64 * fam.stripe_width >= hi, "{w}x{h} family {f} does not cover the image");
                let img = spec.render_family_linear(f);
                for p in img.pixels() {
                    let pure = spec.palette.iter().chain([&spec.background]).any(|c| (0..3).all(|k| (p[k] as f64 - c[k]).abs() < 1e-6));
                    assert!(pure, "{w}x{h} stripes of {stripe}: a blended pixel {p:?}");
                }
            }
        }
        // A stripe width that is not a whole number keeps its blended boundaries.
        let spec = PatternSpec::generate(1, 1024, 768, 7.5).unwrap();
        assert!(spec.render_family_linear(0).pixels().iter().any(|p| !spec.palette.iter().any(|c| (0..3).all(|k| (p[k] as f64 - c[k]).abs() < 1e-6))));
    }

    #[test]
    fn generated_specs_validate_and_round_trip() {
        for n in 1..=3 {
            let spec = PatternSpec::generate(n, 1024, 768, DEFAULT_STRIPE_WIDTH).unwrap();
            spec.validate().unwrap();
            assert_eq!(PatternSpec::from_json(&spec.to_json()).unwrap(), spec);
        }
    }
}
