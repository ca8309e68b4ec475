//! Segmentation of one family's restored image into stripes: stripe boundaries along
//! scan lines across the stripes, located to sub-pixel accuracy, each with the colour
//! transition it shows.
//!
//! The paper segments by hue thresholding of restored colours normalized by the
//! neighbouring colours. Here the normalization is done on the boundary: the plateau
//! colours of the two stripes either side are compared per channel in the log domain
//! (a ratio, so the surface's own colour cancels where it is the same on both sides),
//! and each channel's change is classified as up, down or unchanged *relative to the
//! largest change at that boundary* (all changing channels of the palette change by
//! the same ratio). A boundary whose largest change is too small, or with a channel
//! whose change is neither clearly large nor clearly small, gets no code: it is left
//! for the decoder to skip rather than guessed.
//!
//! Scan lines run along image rows when the family's stripes are closer to vertical
//! and along columns otherwise, so a stripe crosses every scan line at no more than 45
//! degrees from square. Pixels that are too dark (shadow, no projector light) or
//! saturated in any channel break a scan line.

use crate::filter::Restored;
use crate::raster::SATURATED;

/// A code in {-1, 0, +1}³ packed as a base-3 number, `(r+1)·9 + (g+1)·3 + (b+1)`.
/// [`NO_CODE`] marks a boundary whose transition could not be read.
pub type Code = u8;

/// The code of a boundary that could not be classified.
pub const NO_CODE: Code = 255;

/// Marks, during classification, a candidate that is no boundary at all.
const NOT_A_BOUNDARY: Code = 254;

/// Smallest edge strength (sum over channels of the squared central difference of the
/// log signal) for a boundary candidate. A palette step of ln(1/0.45) = 0.8 (the
/// weakest, three-family palette) blurred over two pixels gives about 0.16 per
/// changing channel; 0.02 keeps boundaries seen at a third of that contrast.
pub const MIN_EDGE_STRENGTH: f32 = 0.02;

/// Smallest largest-channel log change across a boundary (ratio 1.3).
pub const MIN_STEP: f32 = 0.26;

/// A channel changing by less than this fraction of the largest change counts as
/// unchanged; by more than [`CHANGED_FRACTION`], as changed; in between, the boundary
/// is ambiguous and gets [`NO_CODE`].
pub const UNCHANGED_FRACTION: f32 = 0.33;
/// See [`UNCHANGED_FRACTION`].
pub const CHANGED_FRACTION: f32 = 0.6;

/// Linear brightness (largest channel) below which a pixel counts as unlit: about
/// 8-bit code 20 through gamma 2.2.
pub const DARK_LEVEL: f32 = 0.0035;


/// Pack a transition.
pub fn pack(t: [i8; 3]) -> Code {
    ((t[0] + 1) * 9 + (t[1] + 1) * 3 + (t[2] + 1)) as Code
}

/// The transition of the reverse boundary (the same boundary crossed the other way).
pub fn reverse(code: Code) -> Code {
    if code == NO_CODE {
        return NO_CODE;
    }
    let (r, g, b) = (code / 9, code / 3 % 3, code % 3);
    (2 - r) * 9 + (2 - g) * 3 + (2 - b)
}

/// One stripe boundary on a scan line.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Edge {
    /// Sub-pixel position along the scan line (pixel centres at integers).
    pub pos: f32,
    /// The transition seen crossing it in the direction of increasing position.
    pub code: Code,
    /// Index of the run of usable pixels the edge lies in; consecutive edges of the
    /// same run have only usable pixels between them.
    pub run: u32,
    /// The identity given by the decoder: the pattern boundary index `j` (the boundary
    /// between stripes `j - 1` and `j`), or -1.
    pub id: i32,
}

/// Which image axis the scan lines follow.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ScanAxis {
    /// Lines are rows; position is u.
    Rows,
    /// Lines are columns; position is v.
    Columns,
}

impl ScanAxis {
    /// Rows when the normal angle is within 45 degrees of the u axis.
    pub fn for_normal(angle: f32) -> Self {
        if angle.cos().abs() >= angle.sin().abs() {
            ScanAxis::Rows
        } else {
            ScanAxis::Columns
        }
    }

    /// (number of lines, length of a line) for a `w` x `h` image.
    pub fn lines(self, w: usize, h: usize) -> (usize, usize) {
        match self {
            ScanAxis::Rows => (h, w),
            ScanAxis::Columns => (w, h),
        }
    }

    /// Pixel index of position `s` on line `line`.
    #[inline]
    pub fn index(self, line: usize, s: usize, w: usize) -> usize {
        match self {
            ScanAxis::Rows => line * w + s,
            ScanAxis::Columns => s * w + line,
        }
    }
}

/// Per-pixel usability: lit enough and not saturated. Written once per frame and
/// shared by all families.
pub fn usable_mask_into(frame: &[[u8; 3]], linear: &[[f32; 3]], mask: &mut [bool]) -> usize {
    let mut count = 0;
    for ((m, p8), p) in mask.iter_mut().zip(frame).zip(linear) {
        let bright = p[0].max(p[1]).max(p[2]) >= DARK_LEVEL;
        let saturated = p8.iter().any(|&c| c >= SATURATED);
        *m = bright && !saturated;
        count += *m as usize;
    }
    count
}

/// Reusable buffers of one scan line.
#[derive(Default)]
pub struct LineScratch {
    signal: [Vec<f32>; 3],
    strength: Vec<f32>,
    ok: Vec<bool>,
}

/// The boundaries of every scan line of one family.
#[derive(Default)]
pub struct Segmentation {
    /// The axis the lines follow.
    pub axis: Option<ScanAxis>,
    /// Boundaries per line, in increasing position.
    pub lines: Vec<Vec<Edge>>,
    scratch: LineScratch,
}

impl Segmentation {
    /// Find the boundaries of `restored` along `axis`, skipping pixels not in `usable`;
    /// `period` is the expected stripe period in pixels.
    pub fn run(&mut self, restored: &Restored, usable: &[bool], axis: ScanAxis, period: f32) {
        let (w, h) = (restored.width, restored.height);
        let (nlines, len) = axis.lines(w, h);
        self.axis = Some(axis);
        self.lines.resize_with(nlines, Vec::new);
        let sc = &mut self.scratch;
        for s in sc.signal.iter_mut() {
            s.resize(len, 0.0);
        }
        sc.strength.resize(len, 0.0);
        sc.ok.resize(len, false);
        let mut run_id = 0u32;
        for line in 0..nlines {
            let edges = &mut self.lines[line];
            edges.clear();
            for s in 0..len {
                let i = axis.index(line, s, w);
                sc.ok[s] = usable[i];
                for ch in 0..3 {
                    sc.signal[ch][s] = restored.log[ch][i];
                }
            }
            // Edge strength: squared central differences, summed over channels; only
            // where the three pixels involved are usable.
            sc.strength[0] = 0.0;
            sc.strength[len - 1] = 0.0;
            for s in 1..len - 1 {
                sc.strength[s] = if sc.ok[s - 1] && sc.ok[s] && sc.ok[s + 1] {
                    (0..3).map(|ch| (0.5 * (sc.signal[ch][s + 1] - sc.signal[ch][s - 1])).powi(2)).sum()
                } else {
                    0.0
                };
            }
            // Local maxima (strict on the right so plateaus give one edge), then
            // parabolic sub-pixel refinement.
            let mut s = 1;
            while s + 1 < len {
                if !sc.ok[s] {
                    run_id += 1;
                    // Skip the unusable stretch.
                    while s + 1 < len && !sc.ok[s] {
                        s += 1;
                    }
                    continue;
                }
                let (a, b, c) = (sc.strength[s - 1], sc.strength[s], sc.strength[s + 1]);
                let wider = |k: isize| {
                    let t = s as isize + k;
                    t < 0 || t >= len as isize || sc.strength[t as usize] <= b
                };
                if b >= MIN_EDGE_STRENGTH && b >= a && b > c && wider(-2) && wider(2) {
                    // Sub-pixel position from the linear-light gradient: camera blur
                    // acts on linear light, so a blurred step's linear gradient peaks
                    // at the step while its log gradient leans to the darker side.
                    let lin = |t: usize| -> f32 {
                        if t == 0 || t + 1 >= len {
                            return 0.0;
                        }
                        (0..3).map(|ch| (0.5 * (sc.signal[ch][t + 1].exp() - sc.signal[ch][t - 1].exp())).powi(2)).sum()
                    };
                    let (a, b, c) = (lin(s - 1), lin(s), lin(s + 1));
                    let den = a - 2.0 * b + c;
                    let offset = if den < 0.0 { (0.5 * (a - c) / den).clamp(-0.5, 0.5) } else { 0.0 };
                    edges.push(Edge { pos: s as f32 + offset, code: NO_CODE, run: run_id, id: -1 });
                }
                s += 1;
            }
            run_id += 1;
            classify(edges, &sc.signal, &sc.ok, period);
            edges.retain(|e| e.code != NOT_A_BOUNDARY);
        }
    }
}

/// Mean of `signal` over the usable pixels strictly between positions `a` and `b`,
/// keeping a margin of a pixel from each end (the blurred transition); `None` when
/// nothing is left.
fn plateau(signal: &[f32], ok: &[bool], a: f32, b: f32) -> Option<f32> {
    let lo = (a + 1.0).ceil().max(0.0) as usize;
    let hi = (b - 1.0).floor();
    if hi < lo as f32 {
        // A narrow stripe: the sample halfway.
        let mid = ((a + b) * 0.5).round();
        if mid < 0.0 || mid as usize >= signal.len() || !ok[mid as usize] {
            return None;
        }
        return Some(signal[mid as usize]);
    }
    let hi = (hi as usize).min(signal.len() - 1);
    let (mut sum, mut n) = (0.0, 0);
    for s in lo..=hi {
        if !ok[s] {
            return None;
        }
        sum += signal[s];
        n += 1;
    }
    (n > 0).then(|| sum / n as f32)
}

/// Give each edge its transition code from the plateaus either side (bounded by the
/// neighbouring edges, or a typical stripe width at the ends of a run).
fn classify(edges: &mut [Edge], signal: &[Vec<f32>; 3], ok: &[bool], period: f32) {
    let n = edges.len();
    for i in 0..n {
        let here = edges[i];
        let prev = if i > 0 && edges[i - 1].run == here.run { edges[i - 1].pos } else { here.pos - period };
        let next = if i + 1 < n && edges[i + 1].run == here.run { edges[i + 1].pos } else { here.pos + period };
        let mut delta = [0f32; 3];
        let mut readable = true;
        for ch in 0..3 {
            match (plateau(&signal[ch], ok, prev, here.pos), plateau(&signal[ch], ok, here.pos, next)) {
                (Some(l), Some(r)) => delta[ch] = r - l,
                _ => readable = false,
            }
        }
        if !readable {
            continue;
        }
        let largest = delta.iter().fold(0f32, |m, d| m.max(d.abs()));
        if largest < MIN_STEP {
            // Too little change for a boundary of this family: noise, shading, or
            // another family's boundary leaking through the restoration. Not kept, so
            // that it does not split a window of real boundaries.
            edges[i].code = NOT_A_BOUNDARY;
            continue;
        }
        let mut t = [0i8; 3];
        let mut ambiguous = false;
        for ch in 0..3 {
            let f = delta[ch].abs() / largest;
            if f >= CHANGED_FRACTION {
                t[ch] = delta[ch].signum() as i8;
            } else if f > UNCHANGED_FRACTION {
                ambiguous = true;
            }
        }
        if !ambiguous {
            edges[i].code = pack(t);
        }
    }
}
