//! Surface albedo textures, laid out in a shape's surface coordinates (mm).
//!
//! Albedos are linear diffuse reflectances per channel in 0..=1 (1 reflects all the
//! light of that channel). Saturated colours are kept above zero in their weak
//! channels, as printed and dyed surfaces are: a few percent for the original scenes,
//! down to 1 % for the hard ones ([`super::pigments`]).

use crate::raster::Rgb;
use glam::DVec2;

/// How much light a surface reflects, as a function of its surface coordinates.
#[derive(Clone, Debug, PartialEq)]
pub enum Texture {
    /// One albedo everywhere.
    Plain(Rgb),
    /// Square cells `cell` mm wide; cell (i, j) has colour `colours[(i + stride·j) mod n]`
    /// (two colours with stride 1 make a checkerboard; a stride coprime to n that is
    /// not ±1 mod n keeps every cell different from its four neighbours).
    Checker {
        /// The colours, used cyclically.
        colours: Vec<Rgb>,
        /// Cell size, mm of surface coordinate.
        cell: f64,
        /// Colour-index step from one row of cells to the next.
        stride: usize,
    },
    /// Four quadrants around the surface-coordinate origin, clockwise from the
    /// top-left one (s < 0, t < 0): top-left, top-right, bottom-right, bottom-left.
    Quadrants([Rgb; 4]),
    /// Smooth multi-hue blotches with dark patches, like dyed or printed leather:
    /// two octaves of value noise set the hue (which wanders over the whole colour
    /// circle), a second noise field darkens about a fifth of the surface to
    /// `dark_level` of its brightness with soft edges. Colours are HSV in linear
    /// light: the weakest channel is `value · (1 − saturation)`.
    Blotchy {
        /// Size of the blotches, mm.
        scale: f64,
        /// Seed of the noise lattice.
        seed: u64,
        /// HSV saturation of the colours (`BLOTCH_SATURATION` for the textured
        /// scene).
        saturation: f64,
        /// HSV value away from the dark patches (`BLOTCH_VALUE`).
        value: f64,
        /// Brightness left in the dark patches, as a fraction (`BLOTCH_DARK_LEVEL`).
        dark_level: f64,
    },
    /// A chart of square patches (a ColorChecker): `colours` row by row, `columns` to
    /// a row, each `patch` mm wide with `gap` mm between them, the whole grid centred
    /// on the surface-coordinate origin (s to the right, t down); everything else
    /// (the gaps, the border) is `background`.
    Chart {
        /// Patch colours, row by row.
        colours: Vec<Rgb>,
        /// Patches per row.
        columns: usize,
        /// Side of a patch, mm.
        patch: f64,
        /// Gap between patches, mm.
        gap: f64,
        /// The card around the patches.
        background: Rgb,
    },
    /// One colour whose brightness varies by up to ±`amplitude` (a fraction) in soft
    /// blotches of about `scale` mm (two octaves of value noise): skin, plaster.
    Mottled {
        /// The mean colour.
        base: Rgb,
        /// Largest relative change of brightness.
        amplitude: f64,
        /// Size of the blotches, mm.
        scale: f64,
        /// Seed of the noise lattice.
        seed: u64,
    },
    /// Wood grain: bands of `early` and `late` wood running along s, one growth ring
    /// every `ring` mm across (along t), the bands wandering by about a ring's width.
    /// About a third of each ring is late wood, with soft edges.
    Wood {
        /// The light wood of each ring.
        early: Rgb,
        /// The dark wood of each ring.
        late: Rgb,
        /// Width of a growth ring, mm.
        ring: f64,
        /// Seed of the noise lattice.
        seed: u64,
    },
}

/// Saturation of the textured scene's blotchy colours.
pub const BLOTCH_SATURATION: f64 = 0.7;
/// Brightness (HSV value) of the textured scene's blotches away from their dark patches.
pub const BLOTCH_VALUE: f64 = 0.72;
/// Noise level above which the blotchy texture turns dark, and the width of the soft edge.
const BLOTCH_DARK_FROM: f64 = 0.58;
const BLOTCH_DARK_EDGE: f64 = 0.07;
/// Brightness left in the textured scene's dark patches.
pub const BLOTCH_DARK_LEVEL: f64 = 0.16;

impl Texture {
    /// The albedo at surface coordinates `st` (mm).
    pub fn albedo(&self, st: DVec2) -> Rgb {
        match self {
            Texture::Plain(c) => *c,
            Texture::Checker { colours, cell, stride } => {
                let n = colours.len() as i64;
                if n == 0 || !(*cell > 0.0) {
                    return [0.0; 3];
                }
                let i = floor_i64(st.x / cell);
                let j = floor_i64(st.y / cell);
                let k = (i + *stride as i64 % n * j).rem_euclid(n);
                colours[k as usize]
            }
            Texture::Quadrants(c) => match (st.x >= 0.0, st.y >= 0.0) {
                (false, false) => c[0],
                (true, false) => c[1],
                (true, true) => c[2],
                (false, true) => c[3],
            },
            Texture::Blotchy { scale, seed, saturation, value, dark_level } => {
                let p = st / scale.max(1e-9);
                // Each octave on its own rotated, shifted lattice so that no lattice
                // direction shows in the blotches' outlines.
                let octave = |p: DVec2, turn: f64, shift: DVec2, seed: u64| {
                    let (s, c) = turn.sin_cos();
                    value_noise(DVec2::new(c * p.x - s * p.y, s * p.x + c * p.y) + shift, seed)
                };
                let hue_noise = 0.65 * octave(p, 0.0, DVec2::ZERO, *seed)
                    + 0.35 * octave(p * 2.1, 0.9, DVec2::new(17.3, 5.1), seed ^ 1);
                let dark_noise = 0.6 * octave(p * 0.8, 0.5, DVec2::new(-41.7, 23.9), seed.wrapping_add(0x5EED))
                    + 0.4 * octave(p * 1.7, 1.3, DVec2::new(8.2, -61.4), seed.wrapping_add(0x5EEE));
                let dark = smoothstep(BLOTCH_DARK_FROM, BLOTCH_DARK_FROM + BLOTCH_DARK_EDGE, dark_noise);
                let brightness = value * (1.0 - (1.0 - dark_level) * dark);
                // Value noise clusters around 0.5; two turns of the colour circle over
                // its range make every hue common.
                let hue = (2.0 * hue_noise + 0.15).fract();
                hsv_to_rgb(hue, *saturation, brightness)
            }
            Texture::Chart { colours, columns, patch, gap, background } => {
                let n = colours.len();
                if n == 0 || *columns == 0 || !(*patch > 0.0) || !(*gap >= 0.0) {
                    return *background;
                }
                let rows = n.div_ceil(*columns);
                let pitch = patch + gap;
                // Grid origin at the top-left corner of the first patch.
                let x = st.x + (*columns as f64 * pitch - gap) / 2.0;
                let y = st.y + (rows as f64 * pitch - gap) / 2.0;
                let (i, j) = (floor_i64(x / pitch), floor_i64(y / pitch));
                let inside = i >= 0
                    && j >= 0
                    && (i as usize) < *columns
                    && (j as usize) < rows
                    && x - i as f64 * pitch < *patch
                    && y - j as f64 * pitch < *patch;
                match inside.then(|| j as usize * columns + i as usize) {
                    Some(k) if k < n => colours[k],
                    _ => *background,
                }
            }
            Texture::Mottled { base, amplitude, scale, seed } => {
                let p = st / scale.max(1e-9);
                let noise = 0.65 * value_noise(p, *seed) + 0.35 * value_noise(p * 2.3 + DVec2::new(7.1, -3.3), seed ^ 1);
                let factor = (1.0 + amplitude * (2.0 * noise - 1.0)) as f32;
                base.map(|c| (c * factor).clamp(0.0, 1.0))
            }
            Texture::Wood { early, late, ring, seed } => {
                let ring = ring.max(1e-9);
                // The bands wander across by up to about a ring over 150 mm along them.
                let warp = 1.6 * ring * (value_noise(DVec2::new(st.x / 150.0, st.y / (8.0 * ring)), *seed) - 0.5);
                let phase = (st.y + warp) / ring;
                let r = phase - floor_i64(phase) as f64;
                let f = (smoothstep(0.55, 0.68, r) * (1.0 - smoothstep(0.9, 1.0, r))) as f32;
                std::array::from_fn(|k| early[k] + (late[k] - early[k]) * f)
            }
        }
    }
}

/// ⌊x⌋ without a library call (`f64::floor` is one on baseline x86-64); saturates
/// far outside the i64 range, which texture coordinates never reach.
#[inline]
fn floor_i64(x: f64) -> i64 {
    let i = x as i64;
    i - ((i as f64) > x) as i64
}

/// Hermite smoothstep from 0 at `a` to 1 at `b`.
fn smoothstep(a: f64, b: f64, x: f64) -> f64 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// A hash of a lattice point to 0..1.
fn lattice(i: i64, j: i64, seed: u64) -> f64 {
    let mut z = seed
        ^ (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
        ^ (j as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 53) as f64
}

/// Value noise in 0..1: random values on the integer lattice, blended with a quintic
/// fade so the result has continuous first and second derivatives.
fn value_noise(p: DVec2, seed: u64) -> f64 {
    let (i, j) = (floor_i64(p.x), floor_i64(p.y));
    let (fi, fj) = (i as f64, j as f64);
    let fade = |t: f64| t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
    let (u, v) = (fade(p.x - fi), fade(p.y - fj));
    let top = lattice(i, j, seed) + (lattice(i + 1, j, seed) - lattice(i, j, seed)) * u;
    let bottom = lattice(i, j + 1, seed) + (lattice(i + 1, j + 1, seed) - lattice(i, j + 1, seed)) * u;
    top + (bottom - top) * v
}

/// HSV (hue in turns) to RGB.
fn hsv_to_rgb(h: f64, s: f64, v: f64) -> Rgb {
    let h6 = h.rem_euclid(1.0) * 6.0;
    let sector = (h6.floor() as i64).rem_euclid(6);
    let f = h6 - h6.floor();
    let (p, q, t) = (v * (1.0 - s), v * (1.0 - s * f), v * (1.0 - s * (1.0 - f)));
    let (r, g, b) = match sector {
        0 => (v, t, p),
        1 => (q, v, p),
        2 => (p, v, t),
        3 => (p, q, v),
        4 => (t, p, v),
        _ => (v, p, q),
    };
    [r as f32, g as f32, b as f32]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checker_neighbours_differ() {
        let tex = Texture::Checker {
            colours: (0..7).map(|k| [k as f32, 0.0, 0.0]).collect(),
            cell: 10.0,
            stride: 3,
        };
        for i in -5..5 {
            for j in -5..5 {
                let at = |i: i32, j: i32| tex.albedo(DVec2::new(i as f64 * 10.0 + 5.0, j as f64 * 10.0 + 5.0));
                assert_ne!(at(i, j), at(i + 1, j));
                assert_ne!(at(i, j), at(i, j + 1));
            }
        }
    }

    #[test]
    fn blotches_cover_many_hues_and_have_dark_patches() {
        let tex = Texture::Blotchy {
            scale: 40.0,
            seed: 7,
            saturation: BLOTCH_SATURATION,
            value: BLOTCH_VALUE,
            dark_level: BLOTCH_DARK_LEVEL,
        };
        let mut dark = 0;
        let mut dominant = [0usize; 3];
        let n = 100;
        for i in 0..n {
            for j in 0..n {
                let c = tex.albedo(DVec2::new(i as f64 * 7.0, j as f64 * 7.0));
                assert!(c.iter().all(|x| (0.0..=1.0).contains(x)));
                if c.iter().fold(0f32, |m, &x| m.max(x)) < 0.2 {
                    dark += 1;
                } else {
                    let k = (0..3).fold(0, |b, k| if c[k] > c[b] { k } else { b });
                    dominant[k] += 1;
                }
            }
        }
        let frac = dark as f64 / (n * n) as f64;
        assert!((0.05..0.45).contains(&frac), "dark fraction {frac}");
        assert!(dominant.iter().all(|&d| d > n * n / 10), "{dominant:?}");
    }
}
