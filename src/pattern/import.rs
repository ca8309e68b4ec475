//! Specs from other people's pattern images: `stripelight pattern import`.
//!
//! A colour-stripe pattern made elsewhere is usually kept as the image the projector
//! shows. Its stripes are read back from one line across them: runs of equal pixels,
//! one width for all (fitted between the first and the last full stripe), a margin at
//! either end where a run
//! is wider than a stripe and the same colour on both sides, colours in order of first
//! appearance. The smallest window that makes every run of stripes unique by its
//! transitions is the spec's window. Where the image sits on the projector (offset,
//! scale) and the projector's size come from the caller. The image must be crisp:
//! antialiased edges (pixels that blend two stripes) read as narrow stripes and are
//! refused as uneven widths.

use super::{transition, Family, PatternSpec, Transition, MAX_PALETTE};
use crate::error::{Error, Result};
use crate::raster::Image;

/// Largest window the import tries before it says the sequence is not unique.
pub const MAX_IMPORT_WINDOW: usize = 16;

/// Which way the stripes of an imported image run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StripeAxis {
    /// Vertical stripes: every row is the same (normal angle 0).
    Columns,
    /// Horizontal stripes: every column is the same (normal angle 90 degrees).
    Rows,
}

impl std::str::FromStr for StripeAxis {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "columns" => Ok(StripeAxis::Columns),
            "rows" => Ok(StripeAxis::Rows),
            _ => Err(Error::Setting { name: "axis", problem: format!("must be columns or rows, got {s:?}") }),
        }
    }
}

/// Where the image sits on the projector and how its pixel values map to light.
#[derive(Clone, Debug, PartialEq)]
pub struct Placement {
    /// Which way the stripes run.
    pub axis: StripeAxis,
    /// Projector size; the placed image's extent when `None`.
    pub projector: Option<(u32, u32)>,
    /// Projector pixel of the image's top-left pixel centre.
    pub offset: (f64, f64),
    /// Projector pixels per image pixel.
    pub scale: f64,
    /// Pixel value = 255 · linear^(1 / encoding_gamma).
    pub encoding_gamma: f64,
}

impl Default for Placement {
    fn default() -> Self {
        Placement { axis: StripeAxis::Columns, projector: None, offset: (0.0, 0.0), scale: 1.0, encoding_gamma: 2.2 }
    }
}

fn fail(field: &str, problem: String) -> Error {
    Error::PatternImport { field: field.into(), problem }
}

/// Read a pattern image into a spec, and say how it was read (one line).
pub fn import_image(image: &Image<[u8; 3]>, place: &Placement) -> Result<(PatternSpec, String)> {
    if !(place.scale.is_finite() && place.scale > 0.0 && place.scale <= 1024.0) {
        return Err(fail("scale", format!("must be in (0, 1024], got {}", place.scale)));
    }
    if !(place.offset.0.is_finite() && place.offset.1.is_finite()) {
        return Err(fail("offset", format!("must be finite, got {:?}", place.offset)));
    }
    if !(place.encoding_gamma.is_finite() && (0.2..=5.0).contains(&place.encoding_gamma)) {
        return Err(fail("encoding gamma", format!("must be in 0.2..=5, got {}", place.encoding_gamma)));
    }
    let (w, h) = (image.width(), image.height());
    if w == 0 || h == 0 {
        return Err(fail("image", "is empty".into()));
    }
    // The profile across the stripes, and a check that every line along them agrees.
    let columns = place.axis == StripeAxis::Columns;
    let (len, lines) = if columns { (w, h) } else { (h, w) };
    let at = |i: usize, line: usize| if columns { image.get(i, line) } else { image.get(line, i) };
    let profile: Vec<[u8; 3]> = (0..len).map(|i| at(i, 0)).collect();
    for line in 1..lines {
        if let Some(i) = (0..len).find(|&i| at(i, line) != profile[i]) {
            let (x, y) = if columns { (i, line) } else { (line, i) };
            let other = if columns { "rows" } else { "columns" };
            return Err(fail("image", format!("pixel ({x}, {y}) differs from the first line: the stripes do not run along the {} (try --axis {other})", if columns { "columns" } else { "rows" })));
        }
    }
    // Runs of equal pixels: (start, length, colour).
    let mut runs: Vec<(usize, usize, [u8; 3])> = Vec::new();
    for (i, &c) in profile.iter().enumerate() {
        match runs.last_mut() {
            Some(r) if r.2 == c => r.1 += 1,
            _ => runs.push((i, 1, c)),
        }
    }
    if runs.len() < 3 {
        return Err(fail("stripes", format!("found {} run(s) of one colour across the image: no stripes", runs.len())));
    }
    // The typical stripe: the median length of the inner runs (the end runs may be
    // margins or cut stripes).
    let mut inner: Vec<usize> = runs[1..runs.len() - 1].iter().map(|r| r.1).collect();
    inner.sort_unstable();
    let typical = inner[inner.len() / 2] as f64;
    let wide = |r: &(usize, usize, [u8; 3])| r.1 as f64 > 1.5 * typical + 1.0;
    let (first, last) = (runs[0], runs[runs.len() - 1]);
    let background = match (wide(&first), wide(&last)) {
        (true, true) if first.2 != last.2 => {
            return Err(fail("margins", format!("the margins have two colours, {:?} before the stripes and {:?} after", first.2, last.2)))
        }
        (true, _) => Some(first.2),
        (_, true) => Some(last.2),
        _ => None,
    };
    let lo = usize::from(wide(&first));
    let hi = runs.len() - usize::from(wide(&last));
    let stripes = &runs[lo..hi];
    if stripes.len() < 2 {
        return Err(fail("stripes", "fewer than two stripes between the margins".into()));
    }
    // One width: boundaries (pixel edges, image pixels) of the full stripes, fitted
    // between the first and the last; a cut stripe at an end without margin is a
    // stripe of the full width that begins or ends off the image.
    let full_from = usize::from(lo == 0 && (stripes[0].1 as f64) < typical - 1.0);
    let full_to = stripes.len() - usize::from(hi == runs.len() && (stripes[stripes.len() - 1].1 as f64) < typical - 1.0);
    if full_to <= full_from {
        return Err(fail("stripes", "no stripe of the full width".into()));
    }
    let edge = |k: usize| stripes[k].0 as f64 - 0.5;
    let n_full = full_to - full_from;
    let width = (edge(full_to - 1) + stripes[full_to - 1].1 as f64 - edge(full_from)) / n_full as f64;
    for (k, r) in stripes.iter().enumerate().take(full_to).skip(full_from) {
        let expected = edge(full_from) + (k - full_from) as f64 * width;
        if (edge(k) - expected).abs() > 1.0 || (r.1 as f64 - width).abs() > 1.0 + 1e-9 {
            let unit = if columns { "column" } else { "row" };
            return Err(fail("stripes", format!("not of one width: the stripe at {unit} {} is {} pixels where the stripes average {width:.2}", r.0, r.1)));
        }
    }
    if width * place.scale < 2.0 {
        return Err(fail("stripes", format!("are {:.2} projector pixels wide; at least 2 are needed", width * place.scale)));
    }
    // Colours: linear light, in order of first appearance.
    let linear = |c: [u8; 3]| c.map(|v| (v as f64 / 255.0).powf(place.encoding_gamma));
    let mut colours: Vec<[u8; 3]> = Vec::new();
    let mut sequence = Vec::with_capacity(stripes.len());
    for r in stripes {
        let index = match colours.iter().position(|&c| c == r.2) {
            Some(i) => i,
            None => {
                colours.push(r.2);
                colours.len() - 1
            }
        };
        if colours.len() > MAX_PALETTE {
            return Err(fail("palette", format!("more than {MAX_PALETTE} stripe colours (the ninth is {:?})", r.2)));
        }
        sequence.push(index as u8);
    }
    if colours.len() < 2 {
        return Err(fail("palette", "one stripe colour only".into()));
    }
    let palette: Vec<[f64; 3]> = colours.iter().map(|&c| linear(c)).collect();
    for (k, p) in sequence.windows(2).enumerate() {
        if transition(palette[p[0] as usize], palette[p[1] as usize]) == [0; 3] {
            return Err(fail("palette", format!("stripes {k} and {} are too alike to tell apart ({:?} and {:?})", k + 1, colours[p[0] as usize], colours[p[1] as usize])));
        }
    }
    let window = smallest_window(&palette, &sequence)?;
    // Placement: image pixel i covers projector [offset + S·i - 0.5, offset + S·(i+1) - 0.5].
    let (image_w, image_h) = (w as f64 * place.scale, h as f64 * place.scale);
    let (pw, ph) = match place.projector {
        Some(size) => size,
        None => ((place.offset.0 + image_w).ceil().max(1.0) as u32, (place.offset.1 + image_h).ceil().max(1.0) as u32),
    };
    let (offset, centre) = if columns { (place.offset.0, (pw as f64 - 1.0) / 2.0) } else { (place.offset.1, (ph as f64 - 1.0) / 2.0) };
    let first_start = offset + place.scale * edge(full_from) - (full_from as f64) * width * place.scale;
    let family = Family {
        angle_deg: if columns { 0.0 } else { 90.0 },
        stripe_width: width * place.scale,
        origin: first_start - centre,
        count: stripes.len(),
    };
    let mut spec = PatternSpec::one_family(pw, ph, palette, background.map(linear).unwrap_or([0.0; 3]), sequence, window, family)
        .map_err(|e| fail("spec", format!("the pattern read from the image is not a valid spec: {e}")))?;
    spec.encoding_gamma = place.encoding_gamma;
    let margins = match background {
        Some(c) => format!("margins of {c:?}"),
        None => "no margins".into(),
    };
    let report = format!(
        "{} stripes of {:.3} projector pixels along the {}, {} colours, {margins}; every window of {window} stripes is unique",
        spec.families[0].count,
        spec.families[0].stripe_width,
        if columns { "columns" } else { "rows" },
        spec.palette.len()
    );
    Ok((spec, report))
}

/// The smallest window (2 to [`MAX_IMPORT_WINDOW`]) in which every run of stripes is
/// unique by its transitions.
fn smallest_window(palette: &[[f64; 3]], sequence: &[u8]) -> Result<usize> {
    let transitions: Vec<Transition> = sequence.windows(2).map(|p| transition(palette[p[0] as usize], palette[p[1] as usize])).collect();
    let mut repeat = None;
    for window in 2..=MAX_IMPORT_WINDOW.min(sequence.len()) {
        let mut seen = std::collections::HashMap::new();
        repeat = transitions.windows(window - 1).enumerate().find_map(|(i, t)| seen.insert(t, i).map(|j| (j, i)));
        if repeat.is_none() {
            return Ok(window);
        }
    }
    let detail = match repeat {
        Some((j, i)) => format!("; stripes {j} and {i} begin the same run of transitions"),
        None => String::new(),
    };
    Err(fail("sequence", format!("no window of up to {MAX_IMPORT_WINDOW} stripes makes the {} stripes unique{detail}", sequence.len())))
}
