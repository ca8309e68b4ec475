//! The camera's response: which linear light each 8-bit code stands for.
//!
//! The scanner reads a frame's codes as linear light through a power law (`camera
//! gamma`). Many cameras' tone curves leave the power law near the top of the range:
//! a highlight shoulder squeezes the brightest light into the last codes, so a step onto
//! it reads smaller than it is, and a blurred edge beside it is placed off (the
//! simulator's `shoulder` condition, docs/accuracy.md). [`estimate_response`] measures
//! the codes above [`TRUSTED_CODE`] from three frames of a white card, and the scanner
//! then reads codes through the measured table ([`crate::scan::ScanConfig::response`]).
//!
//! How: with the projector's black frame subtracted, the light a pixel of the card
//! receives from a grey level `G` is `(G / 255)^projector_gamma` times what full white
//! gives it (the projector's black level and the room's light are in both and cancel).
//! Where the grey frame's code is below [`TRUSTED_CODE`], its light is read through the
//! power law; scaled up, it is the light behind the white frame's code at the same
//! pixel. Each code above [`TRUSTED_CODE`] takes the median over the pixels (and
//! channels) that show it.

use crate::error::{Error, Result};
use crate::raster::Image;
use serde::{Deserialize, Serialize};

/// Codes up to this one follow the power law; above it the table is measured. 200 of
/// 255 is 78 % of the range: the shoulders of tone curves start about there or above
/// (the simulator's `shoulder` condition at 204).
pub const TRUSTED_CODE: u8 = 200;

/// The projector's grey level the white card is photographed under for
/// [`estimate_response`] unless told otherwise: 128 gives a fifth of full white's
/// light, which stays below [`TRUSTED_CODE`] while the white frame reaches the top of
/// the range with a shoulder holding up to 1.5 times the power law's light.
pub const DEFAULT_GREY_LEVEL: u8 = 128;

/// Least number of pixel channels a code needs for its own measurement; codes with
/// fewer are interpolated between their measured neighbours.
const MIN_SAMPLES: usize = 20;

/// Least light (linear, full scale 1) the grey frame must add to the black frame at a
/// pixel for the pixel to be used: below it the code's rounding is a large part of it.
const MIN_GREY_LIGHT: f64 = 0.01;

/// How far, as a factor either way, the grey frame's share of the white frame's light
/// (both less the black frame's, where both are trusted codes) may be from what the
/// grey level and the projector's gamma give: further, the frames were swapped or
/// another grey was shown, and the table would be scaled wrong.
const GREY_SHARE_FACTOR: f64 = 1.5;

/// Least light (linear) the white frame must add to the black frame at a pixel for the
/// grey frame's share there to count ([`GREY_SHARE_FACTOR`]): clearly in the
/// projector's light, not beside its edge or in the room's light alone.
const MIN_WHITE_LIGHT: f64 = 0.1;

/// How far (a share of each code's light) a measured response may stray from the power
/// law and still be read as the power law: the measurement's own noise on a camera
/// without a shoulder. The evaluation and the page keep the power law within it, so
/// that a camera without a shoulder is not moved by its measurement's noise.
pub const POWER_LAW_TOLERANCE: f32 = 0.02;

/// Linear light per 8-bit camera code, non-decreasing, the same for the three channels.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraResponse {
    linear: Box<[f32; 256]>,
}

/// The file form: `{"linear": [256 numbers]}`.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ResponseFile {
    linear: Vec<f32>,
}

impl CameraResponse {
    /// The power law: code `c` stands for `(c / 255)^gamma`.
    pub fn power_law(gamma: f32) -> Self {
        CameraResponse { linear: Box::new(crate::raster::gamma_lut(gamma)) }
    }

    /// The table, code by code.
    pub fn linear(&self) -> &[f32; 256] {
        &self.linear
    }

    /// The table in double precision (for [`crate::calib::estimate_crosstalk_through`]).
    pub fn linear_f64(&self) -> [f64; 256] {
        std::array::from_fn(|c| self.linear[c] as f64)
    }

    /// A response from its table: 256 finite values, non-negative, non-decreasing,
    /// the last above 0; refused with a message naming what is wrong.
    pub fn from_table(table: &[f32]) -> Result<Self> {
        let bad = |problem: String| Error::Setting { name: "camera response", problem };
        if table.len() != 256 {
            return Err(bad(format!("needs 256 values, one per 8-bit code, got {}", table.len())));
        }
        if let Some(c) = table.iter().position(|v| !v.is_finite() || *v < 0.0) {
            return Err(bad(format!("code {c}'s value {} is not a non-negative number", table[c])));
        }
        if let Some(c) = (1..256).find(|&c| table[c] < table[c - 1]) {
            return Err(bad(format!("code {c}'s value {} is below code {}'s {}", table[c], c - 1, table[c - 1])));
        }
        if !(table[255] > 0.0) {
            return Err(bad("the top code stands for no light".into()));
        }
        let mut linear = Box::new([0f32; 256]);
        linear.copy_from_slice(table);
        Ok(CameraResponse { linear })
    }

    /// Parse the JSON form (`{"linear": [256 numbers]}`).
    pub fn from_json(text: &str) -> Result<Self> {
        let de = &mut serde_json::Deserializer::from_str(text);
        let file: ResponseFile = serde_path_to_error::deserialize(de)
            .map_err(|e| Error::Setting { name: "camera response", problem: format!("{} at {}", e.inner(), e.path()) })?;
        Self::from_table(&file.linear)
    }

    /// The JSON form.
    pub fn to_json(&self) -> String {
        serde_json::to_string(&ResponseFile { linear: self.linear.to_vec() }).unwrap_or_default()
    }

    /// Whether the table is the power law of `gamma` to within a fraction `tolerance`
    /// of each code's light.
    pub fn is_power_law(&self, gamma: f32, tolerance: f32) -> bool {
        self.departure(gamma) <= tolerance
    }

    /// The largest difference from the power law of `gamma`, as a share of the power
    /// law's light at the code (infinite where the power law has none and the table
    /// some).
    pub fn departure(&self, gamma: f32) -> f32 {
        let plain = crate::raster::gamma_lut(gamma);
        self.linear.iter().zip(&plain).fold(0.0f32, |worst, (&m, &p)| {
            let d = (m - p).abs();
            if d == 0.0 {
                worst
            } else if p > 0.0 {
                worst.max(d / p)
            } else {
                f32::INFINITY
            }
        })
    }
}

/// The camera's response measured from three frames of a white card lit by the
/// projector, taken with the exposure the scans will use: under full white (`white`),
/// under the grey level `grey_level` (`grey`) and under black (`black`). Codes up to
/// [`TRUSTED_CODE`] follow the power law of `camera_gamma`; each code above is the
/// light the grey frame shows at the same pixels, scaled by `(255 / grey_level)^
/// projector_gamma` (see the module's doc). The white frame should reach the top of the
/// range over part of the card (where it does not, the codes above the brightest it
/// reaches keep the ratio to the power law of the brightest measured one), and the
/// grey frame should stay below [`TRUSTED_CODE`].
pub fn estimate_response(
    white: &Image<[u8; 3]>,
    grey: &Image<[u8; 3]>,
    black: &Image<[u8; 3]>,
    grey_level: u8,
    camera_gamma: f32,
    projector_gamma: f32,
) -> Result<CameraResponse> {
    let (w, h) = black.size();
    white.expect_size(w, h)?;
    grey.expect_size(w, h)?;
    if !(1..255).contains(&grey_level) {
        return Err(Error::Setting { name: "grey level", problem: format!("must be in 1..=254, got {grey_level}") });
    }
    for (name, g) in [("camera gamma", camera_gamma), ("projector gamma", projector_gamma)] {
        if !(g.is_finite() && (0.2..=5.0).contains(&g)) {
            return Err(Error::Setting { name, problem: format!("must be in 0.2..=5, got {g}") });
        }
    }
    let plain = crate::raster::gamma_lut(camera_gamma);
    let lin = |c: u8| plain[c as usize] as f64;
    let scale = (255.0 / grey_level as f64).powf(projector_gamma as f64);
    // Per code above the trusted ones, the light each pixel channel showing it implies.
    let mut samples: Vec<Vec<f32>> = vec![Vec::new(); 256];
    let mut trusted_grey = 0usize;
    // Where the white frame's code is trusted too: the grey frame's share of its light.
    let mut shares: Vec<f64> = Vec::new();
    for ((wp, gp), kp) in white.pixels().iter().zip(grey.pixels()).zip(black.pixels()) {
        for c in 0..3 {
            let (wc, gc, kc) = (wp[c], gp[c], kp[c]);
            if gc > TRUSTED_CODE || gc <= kc {
                continue;
            }
            let added = lin(gc) - lin(kc);
            if added < MIN_GREY_LIGHT {
                continue;
            }
            trusted_grey += 1;
            if wc <= TRUSTED_CODE && lin(wc) - lin(kc) >= MIN_WHITE_LIGHT {
                shares.push(added / (lin(wc) - lin(kc)));
            }
            // The top code is a bound (clipped), not a measurement.
            if wc > TRUSTED_CODE && wc < 255 {
                samples[wc as usize].push((lin(kc) + added * scale) as f32);
            }
        }
    }
    if trusted_grey == 0 {
        return Err(Error::ColourFrames(format!(
            "the grey frame shows no pixel lit clearly above the black frame and below code {TRUSTED_CODE}: \
             point the camera at a white card lit by the projector, with the grey frame not too bright"
        )));
    }
    if shares.len() >= MIN_SAMPLES {
        let mid = shares.len() / 2;
        let (_, &mut share, _) = shares.select_nth_unstable_by(mid, f64::total_cmp);
        let expected = 1.0 / scale;
        if !(share <= expected * GREY_SHARE_FACTOR && share >= expected / GREY_SHARE_FACTOR) {
            return Err(Error::ColourFrames(format!(
                "the grey frame holds {share:.2} of the white frame's light where the card is not bright, but grey \
                 {grey_level} should give about {expected:.2}: were the frames swapped, or another grey shown \
                 (give its level)?"
            )));
        }
    }
    let mut table = plain;
    let top = TRUSTED_CODE as usize;
    // Measured codes: the median of their samples.
    let mut measured: Vec<(usize, f32)> = Vec::new();
    for (code, s) in samples.iter_mut().enumerate() {
        if s.len() >= MIN_SAMPLES {
            let mid = s.len() / 2;
            let (_, &mut m, _) = s.select_nth_unstable_by(mid, f32::total_cmp);
            measured.push((code, m));
        }
    }
    // From the trusted top code on: each measured code's value, codes between two
    // measured ones interpolated, codes past the last measured one kept at its ratio to
    // the power law; never below the code before.
    let mut anchor = (top, table[top]);
    for &(c, m) in &measured {
        for code in anchor.0 + 1..=c {
            let t = (code - anchor.0) as f32 / (c - anchor.0) as f32;
            let value = if code == c { m } else { anchor.1 + t * (m - anchor.1) };
            table[code] = value.max(table[code - 1]);
        }
        anchor = (c, table[c]);
    }
    let ratio_past = measured.last().map_or(1.0, |&(c, m)| m / plain[c]);
    for code in anchor.0 + 1..256 {
        table[code] = (plain[code] * ratio_past).max(table[code - 1]);
    }
    CameraResponse::from_table(&table)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_file_form_round_trips_and_bad_tables_are_refused_by_name() {
        let plain = CameraResponse::power_law(2.2);
        assert_eq!(CameraResponse::from_json(&plain.to_json()).unwrap(), plain);
        let refused = |text: &str, needle: &str| {
            let e = CameraResponse::from_json(text).unwrap_err().to_string();
            assert!(e.contains("camera response") && e.contains(needle), "{text}: {e}");
        };
        let table = |f: &dyn Fn(usize) -> String| format!("{{\"linear\": [{}]}}", (0..256).map(f).collect::<Vec<_>>().join(","));
        refused("{\"linear\": [0, 1]}", "256 values");
        refused("{\"linear\": 1}", "linear");
        refused("{\"gamma\": 2.2}", "gamma");
        refused(&table(&|c| if c == 100 { "-1".into() } else { format!("{}", c) }), "code 100");
        refused(&table(&|c| if c == 100 { "0".into() } else { format!("{}", c) }), "code 100");
        refused(&table(&|_| "0".into()), "no light");
    }

    #[test]
    fn frames_that_cannot_give_a_response_are_refused() {
        let card = |v: u8| Image::new(8, 6, [v; 3]);
        let e = estimate_response(&card(250), &card(120), &Image::new(8, 5, [0u8; 3]), 128, 2.2, 2.2).unwrap_err();
        assert!(e.to_string().contains("8x6"), "{e}");
        let e = estimate_response(&card(250), &card(120), &card(10), 0, 2.2, 2.2).unwrap_err();
        assert!(e.to_string().contains("grey level"), "{e}");
        // A grey frame no brighter than the black one, and one too bright to trust.
        for grey in [10, 230] {
            let e = estimate_response(&card(250), &card(grey), &card(10), 128, 2.2, 2.2).unwrap_err();
            assert!(e.to_string().contains("grey frame"), "{e}");
        }
        // The white frame given as the grey one, and a grey frame of another level.
        for (grey, level) in [(180, 128), (60, 200)] {
            let e = estimate_response(&card(180), &card(grey), &card(10), level, 2.2, 2.2).unwrap_err();
            assert!(e.to_string().contains("swapped"), "{e}");
        }
        // A card whose white stays below the trusted codes measures nothing above
        // them: the power law.
        let r = estimate_response(&card(180), &card(90), &card(10), 128, 2.2, 2.2).unwrap();
        assert!(r.is_power_law(2.2, 0.0));
    }
}
