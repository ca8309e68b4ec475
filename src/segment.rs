//! Segmentation of one family's restored image into stripes: stripe boundaries along
//! scan lines across the stripes, located to sub-pixel accuracy, each with the colour
//! transitions it is compatible with.
//!
//! The paper segments by hue thresholding of restored colours normalized by the
//! neighbouring colours. Here the normalization is done on the boundary: the plateau
//! colours of the two stripes either side are compared per channel in the log domain
//! (a ratio, so the surface's own colour cancels where it is the same on both sides),
//! and each channel's change is compared with the largest reliable change at that
//! boundary (all changing channels of the palette change by the same ratio). Where the
//! surface's colour drifts (a dye's hue changing across a blotch), the two plateaus
//! differ by the drift too, as much as a stripe's own step over a few pixels: where the
//! slopes inside the plateaus agree on such a drift, clearly above the noise, and each
//! plateau fits a line (a stripe that is not flat, such as a lobe, has a slope of its
//! own), it is taken out of the step (`surface_change`).
//!
//! **Soft evidence.** Real surfaces and cameras do not give three clean channels: a
//! saturated dye reflects 1 % of the other primaries, so those channels sit in the
//! sensor's noise; bright stripes clip. So each channel of a boundary says which of
//! *down*, *unchanged* and *up* it is compatible with, given its measured step, the
//! noise at its light level ([`NOISE_LINEAR`]) and clipping:
//! - a clean channel allows the value(s) its step is close to (both when it is halfway);
//! - a channel clipped on one side gives a bound: clipped on the brighter side it can
//!   still say "not down" (the true step is at least what is seen);
//! - a channel too dark on a side to read, or clipped on both, is a wildcard (clipped
//!   on both, it is unchanged where the pattern leaves it unlit in some stripes:
//!   [`Segmentation::for_pattern`]).
//!
//! The boundary's evidence is the set of transition codes compatible with every
//! channel: a bit mask over the 27 codes ([`CodeMask`]). The decoder matches masks
//! against the pattern; where the evidence is loose it needs more neighbours to be
//! sure (see [`crate::decode`]).
//!
//! Scan lines run along image rows when the family's stripes are closer to vertical
//! and along columns otherwise, so a stripe crosses every scan line at no more than 45
//! degrees from square. Only unlit pixels (every channel dark: shadow, or no projector
//! light) break a scan line; a pixel clipped in every channel is lit, and its channels
//! are bounds.

use crate::filter::Restored;
use crate::num::max_f32;
use crate::raster::{luma, ChromaPairs, Rgb, SATURATED};

/// A code in {-1, 0, +1}³ packed as a base-3 number, `(r+1)·9 + (g+1)·3 + (b+1)`.
/// [`NO_CODE`] marks a boundary whose transition is not known exactly.
pub type Code = u8;

/// The code of a boundary whose transition is not known exactly.
pub const NO_CODE: Code = 255;

/// A set of codes: bit `c` set when code `c` is compatible with what was measured.
pub type CodeMask = u32;

/// The code of "no change in any channel", which is never a stripe boundary.
pub const SAME_CODE: Code = 13;

/// Every code that is a boundary (all but [`SAME_CODE`]).
pub const ANY_BOUNDARY: CodeMask = ((1 << 27) - 1) & !(1 << SAME_CODE);

/// Smallest edge strength (sum over channels of the squared central difference of the
/// log signal) for a boundary candidate. A palette step of ln(1/0.45) = 0.8 (the
/// weakest, three-family palette) blurred over two pixels gives about 0.16 per
/// changing channel; 0.02 keeps boundaries seen at a third of that contrast.
pub const MIN_EDGE_STRENGTH: f32 = 0.02;

/// Smallest largest-channel log change across a boundary (ratio 1.3).
pub const MIN_STEP: f32 = 0.26;

/// How far (as a fraction of the largest change) a channel's change may be from a
/// value (0 or ±largest) and still be read as that value, before noise is added. At
/// 0.42, a clean channel reads "unchanged" below 42 % of the largest change and
/// "changed" above 58 %; in between it allows both.
pub const VALUE_TOLERANCE: f32 = 0.42;

/// [`VALUE_TOLERANCE`] where a stripe's steps come smeared: in a frame whose colour came
/// at half resolution (4:2:0 or 4:2:2, as from most webcams, with JPEG's coarser
/// quantization of the chroma), and on a broad line (`PeakShape` not sharp: a
/// projector out of focus, whose blur lifts a narrow dark stripe by its neighbours and
/// reads its step at about half of a wide one's).
/// With a tolerance `t`, a channel whose step `d` lies between the values allows both
/// over a band around half the largest change `L`: from `(1 - t) L - n` to `t L + n`
/// (`n` the noise term) where `t` is over a half; below a half, by the fallback to
/// both, from `t L + n` to `(1 - t) L - n`. So at 0.42 the band is 0.42 to 0.58 of `L`
/// on a clean channel and narrows as the noise grows, to nothing where `n` reaches
/// 0.08 `L`; at 0.55 it is 0.45 to 0.55 and widens with the noise. In a subsampled
/// frame a channel's step that the luma does not carry is read from the smeared
/// chroma, and on a dark channel (wood's blue) it strays far from 0 or `L`: there the
/// band must grow with the noise. Measured on the 24 `webcam` and `world` rows of
/// `eval --hard` (mean coverage / outliers / RMSE): 0.42, 91.59 % / 0.196 % / 0.519
/// mm; 0.5, 91.72 % / 0.193 % / 0.521 mm; 0.55, 91.92 % / 0.195 % / 0.524 mm
/// (bag/webcam 57.7 -> 60.0 %, sphere-dye/world 82.9 -> 84.0 %, wood/webcam 93.6 ->
/// 93.9 % with 0.34 -> 0.29 % outliers); 0.58, 91.97 % / 0.196 % / 0.526 mm; 0.6,
/// 91.98 % / 0.202 % (bag/world 0.16 -> 0.43 % outliers); 0.66, 92.15 % / 0.207 %
/// (occluders/world 0.53 -> 0.65 %). On every line of frames with full-resolution
/// colour it did not pay clearly: on the 48 `default`, `wide`, `soft` and `clipped`
/// rows, 0.58 (the same band as 0.42 on a clean channel) gave 89.68 % / 0.364 % -> 89.74 % / 0.337 %, but
/// occluders/wide 0.45 -> 0.65 % outliers (its goal lost) and wood/default 0.461 ->
/// 0.502 mm; 0.55, 89.71 % / 0.340 % with wood/default 0.496 mm. On broad lines alone
/// in such frames (the 24 `soft` and `wide` rows): 85.52 % / 0.617 % / 0.620 mm at
/// 0.42; 0.55, 85.57 % / 0.594 % / 0.617 mm, outliers down on 10 of the 12 `soft` rows
/// (wood/soft 0.78 -> 0.66 %, occluders/soft 0.81 -> 0.74 %, textured/soft 88.3 ->
/// 89.3 %), occluders/wide 0.45 -> 0.49 %, paper-dye/soft 69.3 -> 68.1 %; 0.58, 85.60 %
/// / 0.590 % / 0.618 mm. The 60 `default`, `clipped`, `narrow`, `shoulder` and
/// `partial` rows have few broad lines: 93.715 % / 0.1087 % -> 93.718 % / 0.1092 %
/// (occluders/default 0.15 -> 0.18 %). Tried and not kept: the band on every line of
/// the `narrow` rows (3-pixel stripes, which the lens blurs into each other): 93.50 %
/// / 0.076 % -> 93.69 % / 0.088 % (bag/narrow 71.8 -> 74.4 %, but wood/narrow 0.453 ->
/// 0.506 mm); on the `wide` rows' lines (25-pixel stripes): 86.34 % / 0.662 % ->
/// 86.20 % / 0.634 %, skin/wide 0.496 -> 0.503 mm.
pub const SMEARED_VALUE_TOLERANCE: f32 = 0.55;

/// Standard deviation of a camera's linear signal noise, full scale = 1: about 1.3
/// 8-bit codes at mid grey, a webcam at moderate gain (and the simulator's default).
/// Divided by the light level it gives the noise of the log signal.
pub const NOISE_LINEAR: f32 = 0.005;

/// Noise multiples a step must exceed to be evidence.
pub const NOISE_SIGMAS: f32 = 2.5;

/// Linear level below which a channel counts as dark (too close to the sensor's noise
/// floor to read a ratio): about 8-bit code 20 through gamma 2.2. A pixel with every
/// channel dark is unlit.
pub const DARK_LEVEL: f32 = 0.0035;

/// Smallest change of the camera's linear signal across a boundary, largest channel,
/// in the log (ratio 1.14): half of [`MIN_STEP`], since blur and a neighbouring
/// boundary take some of a narrow stripe's contrast before it is measured.
pub const MIN_SEEN_STEP: f32 = 0.5 * MIN_STEP;

/// Linear level at which a channel's share of the edge strength is halved: six noise
/// standard deviations ([`NOISE_LINEAR`]). A channel whose brighter side is at the
/// projector's black level on a mid-grey surface (about 0.01) counts a seventh; one
/// at the default palette's low level (0.25 of full, 0.1 on a dark surface) nine
/// tenths.
pub const STRENGTH_NOISE_LEVEL: f32 = 6.0 * NOISE_LINEAR;

/// How much a channel whose brighter side is at linear level `m` counts in an edge's
/// strength and place: `m² / (m² + STRENGTH_NOISE_LEVEL²)` ([`STRENGTH_NOISE_LEVEL`]).
#[inline(always)]
fn lit_weight(m: f32) -> f32 {
    m * m / (m * m + STRENGTH_NOISE_LEVEL * STRENGTH_NOISE_LEVEL)
}

/// Smallest expected stripe period, camera pixels, at which an edge's strength must
/// also top the strength two pixels either side. A boundary's central-difference
/// strength is high on the two pixels beside it, so in stripes of 3-4 pixels the next
/// boundary's peak lies two pixels from this one's, and the test dropped whichever of
/// the two was weaker: with 3-pixel stripes (eval --hard, narrow) a third of the lit
/// pixels stayed empty and 2-3 % of the decoded ones were wrong.
///
/// Tried on 2026-12-06 and not kept: the test out to a quarter of the period (at
/// least two pixels). A real 8-megapixel capture's boundaries (tingck's wall, stripes
/// of about 18 pixels, clipped, JPEG) often show two peaks 2-3 pixels apart, each
/// channel's step where its own clipping and chroma put it; the wider test took that
/// wall from 28.2 to 31.9 % of the object (`scripts/real-data.sh`), its hand from 4.2
/// to 3.7 %, and on the simulator's 25-pixel stripes it dropped real boundaries for
/// texture edges beside them (`eval --hard --conditions wide`: colorchecker 0.52 ->
/// 1.49 % outliers, paper-dye 3.57 -> 4.16 %, occluders 0.45 -> 0.58 %).
pub const SHOULDER_MIN_PERIOD: f32 = 5.0;

/// How far, in expected stripe periods, the dark side's other boundary may be for a
/// half-dark channel to be read (see `classify`).
pub const HALF_DARK_STRIPE: f32 = 1.6;

/// Most root-mean-square departure (log units) of a plateau's restored signal from its
/// fitted line for the line's slope to count as the surface's (see `surface_change`),
/// or [`SLOPE_FIT_SIGMAS`] times the pixels' noise where that is more. A stripe that is
/// not flat (another system's bell-shaped lobes, a defocused projector) bends inside
/// its plateau, and its slope there is the pattern's, not the surface's: on the real
/// captures of `scripts/real-data.sh` the slopes taken without this test left Zion's
/// lobed sphere empty (26.5 % of it decoded before).
pub const SLOPE_FIT: f32 = 0.05;

/// See [`SLOPE_FIT`].
pub const SLOPE_FIT_SIGMAS: f32 = 3.0;

/// Farthest from an edge, camera pixels, that the plateaus either side are read for its
/// transition (see `classify`). A plateau ran to the next edge, 20 pixels and more in
/// wide stripes, and its mean was the surface's colour far from the boundary: a
/// texture or a dye that drifts across the stripe changed it as much as the pattern,
/// and with 25-pixel stripes on the `textured` scene 27 % of the true boundaries' codes
/// contradicted their transition (18 % with 7-pixel stripes). Measured on
/// `eval --hard` rows (coverage / outliers, reach unlimited -> 4 / 6 / 8 / 10 pixels):
/// textured/wide 76.8 % / 0.79 % -> 84.9 / 82.5 / 81.2 / 80.4 % with 0.67 / 0.62 /
/// 0.69 / 0.71 % outliers; bag 59.7 % -> 63.5 / 61.9 / 60.0 / 59.6 %; colorchecker
/// 86.3 % -> 84.7 / 86.3 % (4 / 6); skin/8mp 90.8 % -> 87.9 / 89.9 / 90.5 % (4 / 6 /
/// 8): its 25-pixel stripes are blurred over more pixels, which a short plateau
/// leaves in. Only on lines whose edges are sharp (`PeakShape::Sharp`): on the real
/// capture of Zion1123 (`scripts/real-data.sh`), whose stripes are bell-shaped lobes,
/// six pixels from an edge hold half a lobe, which fits a line where the whole lobe
/// does not, and its slope was taken for the surface's ([`SLOPE_FIT`]): nothing of
/// the sphere decoded (25.8 % with the whole plateau; 25.4 % at 8 pixels). Reading
/// the levels near the edge but the slope from the whole plateau kept Zion (24.9 %)
/// and lost the gains above (textured/wide 72.0 %, the bag 58.8 %): they come from
/// the slope near the edge.
pub const PLATEAU_REACH: f32 = 6.0;

/// How many times [`DARK_LEVEL`] the other side of a boundary must be for a channel
/// dark on one side to read as a step: four times is a ratio of 1.4 in the log, well
/// above [`MIN_STEP`], and about 8-bit code 38 through gamma 2.2.
pub const LIT_BESIDE_DARK: f32 = 4.0;

/// Per-pixel flags: bit `c` (0..3) channel c is clipped, bit `3 + c` channel c is dark,
/// [`UNUSABLE`] the pixel cannot take part in decoding.
pub type PixelFlags = u8;

/// The bits of [`PixelFlags`] that say a channel is clipped.
const CLIPPED_BITS: PixelFlags = 0x07;

/// Flag of a pixel that is unlit (every channel dark): it cannot take part in decoding.
///
/// A pixel clipped in every channel is usable: it is lit, more brightly than the camera
/// measures, and each of its channels is a bound ("at least this bright") to the
/// boundaries beside it, as a pixel clipped in one channel is. An overexposed white
/// surface under a pattern shows white stripes clipped in all three channels between
/// paler ones clipped in one or two; taken as unusable, they split every scan line
/// across it into runs of a stripe or two, and their boundaries' sides were not read
/// at all. Measured on the `clipped` and `world` rows of the hard evaluation (`eval
/// --hard --conditions clipped,world`, the 26 rows; coverage / outliers):
/// colorchecker/clipped, whose white patch read 255 in every channel on most pixels,
/// 93.3 % / 0.30 % -> 94.2 % / 0.31 % (its goal, 95 % of the Gray code's 99.1 %, is
/// 94.16 %); colorchecker/world 91.4 % / 0.17 % -> 91.5 % / 0.20 %; sphere/clipped
/// 95.5 -> 95.7 %, sphere/world 90.8 -> 91.0 %, occluders/clipped 97.3 -> 97.4 %; the
/// others within 0.1 point of coverage and 0.02 points of outliers; no row of the
/// `default` conditions has such pixels.
pub const UNUSABLE: PixelFlags = 0x80;

/// How far above its clip level a clipped camera channel is taken to be, as a fraction
/// of that level, for the light it hides from the colour unmixing (see [`clip_leak`]).
///
/// Undoing the camera's colour mixing subtracts a share of every channel from the
/// others. Where a channel clips, the camera's value is lower than its light, too
/// little is subtracted, and the other channels read too bright: by the inverse
/// mixing's off-diagonal entry (about 0.09 for the simulated camera) times the hidden
/// excess. On a surface that reflects little of a channel (a yellow patch's blue, a
/// 1 % dye's off-channels) that leak is larger than the channel's own light, so the
/// channel follows the clipped one's stripes and reads transitions the pattern does
/// not make. Measured on the `clipped` and `world` rows of colorchecker, wood, skin,
/// bag, sphere and paper-dye (`stripelight eval --hard --conditions clipped,world
/// --scenes colorchecker,wood,skin,bag,sphere,paper-dye`; mean coverage / outliers of
/// the 12 rows, 85.07 % / 0.231 % without the rule): 0.3, 86.37 % / 0.210 %; 0.5,
/// 87.27 % / 0.205 % (paper-dye/world 77.6 -> 92.4 %, paper-dye/clipped 87.0 -> 94.3 %,
/// bag/clipped 57.5 -> 59.8 %, colorchecker/world 91.5 -> 92.0 %, its yellow patch; the
/// others within 0.1 point); 0.75, 87.56 % / 0.210 % (bag/clipped 61.5 %, but
/// sphere/clipped 95.8 -> 95.4 % and wood/clipped 95.2 -> 95.0 %: a channel that is
/// really dim is left unread too). Taken instead as a fraction of the pixel's
/// brightest clipped channel, 0.1 of it (about this at 1.1) took wood/clipped and
/// colorchecker/clipped below their goals (94.4 %, 94.1 %).
pub const CLIP_EXCESS: f32 = 0.5;

/// Per channel read `d` and clipped channel `c`, the most the colour unmixing `unmix`
/// (linear camera RGB to linear light, column-major as `glam` keeps it) is taken to
/// overstate `d` by when `c` is clipped: its subtracted share of `c`,
/// `-unmix[d][c]` where positive, times [`CLIP_EXCESS`]. A channel whose unmixed value is
/// below the sum of these over its pixel's clipped channels cannot be told from that
/// leak, and [`pixel_flags_into`] marks it dark (unreadable).
pub fn clip_leak(unmix: &glam::Mat3) -> [[f32; 3]; 3] {
    std::array::from_fn(|d| std::array::from_fn(|c| if c == d { 0.0 } else { CLIP_EXCESS * max_f32(-unmix.col(c)[d], 0.0) }))
}

/// The 8-bit level from which a channel of a frame with half-resolution chroma is taken
/// as clipped in the camera for the unmixing's leak ([`CLIP_EXCESS`]); a frame with
/// full-resolution colour uses [`SATURATED`]. Subsampling averages a clipped
/// channel's colour over its block of 2x2 (or 2x1) pixels and JPEG rings around it,
/// so a pixel clipped in the camera's sensor can read well under 250 after
/// decoding, and its neighbours share its unmixing's shortfall. It counts only for the
/// leak: such a channel's own value is still read, not taken as a bound (taking the
/// bound from 240 or 230 lost coverage on the pigments: sphere/world 91.1 -> 90.9 /
/// 90.2 %, wood/world 93.7 -> 93.0 / 92.1 %). Measured on the 12 `world` rows
/// (`stripelight eval --hard --conditions world`; mean coverage / outliers 89.76 % /
/// 0.221 % at 250): 240, 90.18 % / 0.222 %; 225, 90.54 % / 0.219 % (sphere-dye 76.3 ->
/// 81.2 %, paper-dye 92.4 -> 94.6 %, bag 46.8 -> 48.8 % with 0.14 -> 0.22 % outliers,
/// colorchecker 92.0 -> 92.3 %; no row lost coverage); 205, 90.67 % / 0.223 % (bag
/// 49.6 % with 0.22 %, sphere 91.1 -> 91.0 %). On the `webcam` rows, which do not
/// clip, 225 moves coverage by at most 0.1 point.
pub const SUBSAMPLED_CLIP_LEVEL: u8 = 225;

/// Flags of every pixel, from the 8-bit frame (clipping) and its linear values
/// (darkness). `leak`, when the frame is unmixed: the colour unmixing's leak from
/// clipped channels ([`clip_leak`]) and the 8-bit level from which a channel counts
/// as clipped for it ([`SATURATED`], or [`SUBSAMPLED_CLIP_LEVEL`] in a frame with
/// half-resolution chroma). Written once per frame and shared by all families; returns
/// the number of usable pixels.
pub fn pixel_flags_into(frame: &[[u8; 3]], linear: &[Rgb], leak: Option<(&[[f32; 3]; 3], u8)>, flags: &mut [PixelFlags]) -> usize {
    let mut count = 0;
    for ((f, p8), p) in flags.iter_mut().zip(frame).zip(linear) {
        let mut bits = 0u8;
        for c in 0..3 {
            if p8[c] >= SATURATED {
                bits |= 1 << c;
            }
            if p[c] < DARK_LEVEL {
                bits |= 1 << (3 + c);
            }
        }
        if let Some((leak, level)) = leak {
            // The channels that may hide light from the unmixing.
            let hot: [bool; 3] = std::array::from_fn(|c| p8[c] >= level);
            if hot.contains(&true) {
                for d in 0..3 {
                    let bound: f32 = (0..3).filter(|&c| hot[c]).map(|c| leak[d][c]).sum();
                    if bits & (1 << d) == 0 && p[d] < bound {
                        bits |= 1 << (3 + d);
                    }
                }
            }
        }
        if bits & 0x38 == 0x38 {
            bits |= UNUSABLE;
        } else {
            count += 1;
        }
        *f = bits;
    }
    count
}

/// Pack a transition.
pub fn pack(t: [i8; 3]) -> Code {
    ((t[0] + 1) * 9 + (t[1] + 1) * 3 + (t[2] + 1)) as Code
}

/// The transition a code packs (the inverse of [`pack`] on the 27 codes).
pub const fn unpack(code: Code) -> [i8; 3] {
    [(code / 9) as i8 - 1, (code / 3 % 3) as i8 - 1, (code % 3) as i8 - 1]
}

/// The transition of the reverse boundary (the same boundary crossed the other way).
pub fn reverse(code: Code) -> Code {
    if code == NO_CODE {
        return NO_CODE;
    }
    pack(unpack(code).map(|v| -v))
}

/// One stripe boundary on a scan line.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Edge {
    /// Sub-pixel position along the scan line (pixel centres at integers).
    pub pos: f32,
    /// The transition seen crossing it in the direction of increasing position, when
    /// the evidence names exactly one; [`NO_CODE`] otherwise.
    pub code: Code,
    /// Every transition compatible with the evidence (the decoder matches this).
    pub mask: CodeMask,
    /// Index of the run of usable pixels the edge lies in; consecutive edges of the
    /// same run have only usable pixels between them.
    pub run: u32,
    /// The identity given by the decoder: the pattern boundary index `j` (the boundary
    /// between stripes `j - 1` and `j`), or -1.
    pub id: i32,
    /// What the alignment of the edge's own line made of it, taken or not.
    pub tentative: Tentative,
}

/// The alignment's reading of one edge on its own line (see [`crate::align`]): the
/// identity of the best labelling of the whole run, the runner-up's, and how far
/// ahead the best is. The decoder takes the identity at once where the margins are
/// wide enough; where they are not, the boundary's chain across lines may still
/// decide it (see [`crate::decode`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tentative {
    /// The best identity, -1 for none (no label of the edge within the beam).
    pub id: i32,
    /// The second best identity, -1 for none.
    pub alt: i32,
    /// Bits of the best over the second best (infinite without one).
    pub margin: f32,
    /// Bits of the best over the edge's being spurious.
    pub spurious_margin: f32,
}

impl Tentative {
    /// No reading: the edge was not aligned.
    pub const NONE: Tentative = Tentative { id: -1, alt: -1, margin: 0.0, spurious_margin: f32::NEG_INFINITY };
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

/// Reusable buffers of one scan line.
#[derive(Default)]
pub struct LineScratch {
    signal: [Vec<f32>; 3],
    /// The exponential of `signal` (the restored linear light), for [`subpixel_peak`].
    light: [Vec<f32>; 3],
    level: [Vec<f32>; 3],
    flags: Vec<PixelFlags>,
    /// Each channel's share of the edge strength, dark or not (see `segment_line`).
    share: [Vec<f32>; 3],
    strength: Vec<f32>,
    /// Per edge found, the sample where its log strength peaks and its peak's
    /// variance ([`subpixel_peak`]); the variances again, for their median.
    peaks: Vec<(usize, f32)>,
    widths: Vec<f32>,
    /// How the last line's peaks were read ([`PeakShape::of`]): the next line's are
    /// placed the same way first.
    shape: PeakShape,
}

/// How a line's gradient peaks are read ([`subpixel_peak`]): the central difference
/// through three samples (sharp), the 5-tap smoothed derivative (broad) or the 7-tap
/// one (soft), both with [`broad_fit`].
#[derive(Clone, Copy, PartialEq, Eq, Debug, Default)]
enum PeakShape {
    #[default]
    Sharp,
    Broad,
    Soft,
}

impl PeakShape {
    /// The shape of a line whose peaks' median variance is `median`
    /// ([`median_peak_var`]): sharp unless the stripes are wide enough
    /// ([`SHOULDER_MIN_PERIOD`]) and the median is over [`BROAD_PEAK_VAR`], soft over
    /// [`SOFT_PEAK_VAR`].
    fn of(wide_stripes: bool, median: f32) -> Self {
        if !wide_stripes || median <= BROAD_PEAK_VAR {
            PeakShape::Sharp
        } else if median <= SOFT_PEAK_VAR {
            PeakShape::Broad
        } else {
            PeakShape::Soft
        }
    }

    /// How far the linear-light gradient's peak is sought from the log strength's:
    /// [`SOFT_PEAK_REACH`] on a soft line, [`PEAK_REACH`] otherwise.
    fn climb(self) -> usize {
        if self == PeakShape::Soft {
            SOFT_PEAK_REACH
        } else {
            PEAK_REACH
        }
    }

    /// Samples either side of a gradient sample that its derivative reads: 1, 2 or 3.
    fn stencil(self) -> usize {
        match self {
            PeakShape::Sharp => 1,
            PeakShape::Broad => 2,
            PeakShape::Soft => 3,
        }
    }

    /// The shape a peak found at sample `s` of a line of `len` samples is read with:
    /// this one, or a narrower one where this one's derivative would leave the line
    /// anywhere the peak can be climbed to and fitted. Left as it was, the gradient
    /// is 0 past the stencil's reach, and the fit of a boundary within a few pixels of
    /// the frame's edge leaned inwards (a soft line's boundary 2.2 pixels from the
    /// edge was placed at 3.3, a fifth of a stripe).
    fn within(self, s: usize, len: usize) -> Self {
        let mut shape = self;
        while shape != PeakShape::Sharp {
            let need = shape.climb() + BROAD_FIT_HALF + shape.stencil();
            if s >= need && s + need < len {
                break;
            }
            shape = if shape == PeakShape::Soft { PeakShape::Broad } else { PeakShape::Sharp };
        }
        shape
    }

    /// What the derivative's smoothing adds to a peak's variance (pixels²): the
    /// 5-tap derivative is the central difference after (1, 2, 1) / 4, the 7-tap one
    /// the central difference after (6, 4, 8, 4, 6) / 28.
    fn smoothing_var(self) -> f32 {
        match self {
            PeakShape::Sharp => 0.0,
            PeakShape::Broad => 0.5,
            PeakShape::Soft => 2.0,
        }
    }
}

/// The boundaries of every scan line of one family.
#[derive(Default)]
pub struct Segmentation {
    /// The axis the lines follow.
    pub axis: Option<ScanAxis>,
    /// Boundaries per line, in increasing position.
    pub lines: Vec<Vec<Edge>>,
    /// Per channel, whether some stripe of the pattern leaves it unlit (see
    /// [`Segmentation::for_pattern`]).
    unlit: [bool; 3],
    scratch: Vec<LineScratch>,
}

impl Segmentation {
    /// A segmentation for a pattern whose stripes leave the channels `unlit` (per
    /// channel: some stripe's level is 0; [`crate::pattern::PatternSpec::unlit_channels`]).
    /// Such a channel clipped on both sides of a boundary is read as unchanged; with
    /// [`Segmentation::default`] it is a wildcard, as any channel clipped on both sides.
    ///
    /// Why: where a channel's stripes are either lit or unlit, a side that clips in it
    /// is a lit stripe, since an unlit one holds only the room's light and what the
    /// camera's colour mixing carries over from the other channels. Two clipped sides
    /// are then both lit: unchanged. As a wildcard the channel said nothing, and an
    /// overexposed frame of a binary pattern, where most bright channels clip, gave
    /// boundaries of 3 to 9 codes that the windows could not place. This assumes the
    /// mixing and the room's light do not clip an unlit channel on their own (on the
    /// overexposed real wall below they reach a third to two thirds of the clip level).
    /// A pattern with a lower level above 0 (this project's own, 0.25-0.45) keeps the
    /// wildcard: overexposed, its lower level clips too (colorchecker/clipped lost
    /// 0.7 point when its clipped sides were read as unchanged).
    ///
    /// Measured on the real captures (`scripts/real-data.sh`): tingck's wall (8 colours,
    /// black and white included, bright channels at 253-255) 15.84 % -> 25.75 % of the
    /// object with a point, its stripe coordinates against a smooth field 98.28 % ->
    /// 96.58 % within a quarter of a stripe and 0.02 % -> 0.06 % a stripe or more off
    /// (`examples/fit_sphere.rs --correspondence`); the hand 1.13 % -> 2.98 %. Zion's
    /// frame does not clip: the same.
    pub fn for_pattern(unlit: [bool; 3]) -> Self {
        Segmentation { unlit, ..Segmentation::default() }
    }

    /// Find the boundaries of `restored` along `axis`; `linear` is the frame in linear
    /// light (the noise of a ratio depends on the light level), `flags` its
    /// [`pixel_flags_into`], `period` the expected stripe period in pixels, `chroma`
    /// how the frame's colour was sampled ([`CLIPPED_WEIGHT`] applies only where it is
    /// at full resolution).
    pub fn run(&mut self, restored: &Restored, linear: &[Rgb], flags: &[PixelFlags], axis: ScanAxis, period: f32, chroma: ChromaPairs) {
        let (w, h) = (restored.width, restored.height);
        let (nlines, len) = axis.lines(w, h);
        self.axis = Some(axis);
        self.lines.resize_with(nlines, Vec::new);
        // Lines are independent: with threads, chunks of them run at once, each chunk with
        // its own scratch (made at the first frame).
        self.scratch.resize_with(LINE_CHUNKS, LineScratch::default);
        let clipped_give_way = chroma == ChromaPairs::default();
        let value_tolerance = if clipped_give_way { VALUE_TOLERANCE } else { SMEARED_VALUE_TOLERANCE };
        let input = LineInput { restored, linear, flags, axis, period, len, clipped_give_way, value_tolerance, unlit: self.unlit };
        for_line_chunks(&mut self.lines, &mut self.scratch, |first, lines, sc| {
            // Each chunk starts sharp (the same whatever ran before or at once).
            sc.shape = PeakShape::Sharp;
            for (k, edges) in lines.iter_mut().enumerate() {
                segment_line(&input, first + k, edges, sc);
            }
        });
    }
}

/// How many chunks of lines segmentation (and identification) split a family's lines
/// into: more than the cores, so that chunks of busy and empty lines even out.
pub const LINE_CHUNKS: usize = 8;

/// Split `lines` into as many chunks as there are `scratch` entries (at most; each
/// chunk gets one) and run `f(index of the chunk's first line, chunk, scratch)` on
/// each: at once with threads (natively, and in WebAssembly built with `threads`;
/// `cfg(parallel)`, build.rs), in order without.
pub fn for_line_chunks<T: Send, S: Send>(lines: &mut [T], scratch: &mut [S], f: impl Fn(usize, &mut [T], &mut S) + Sync + Send) {
    let chunk = lines.len().div_ceil(scratch.len().max(1)).max(1);
    let work = |(c, (lines, sc)): (usize, (&mut [T], &mut S))| f(c * chunk, lines, sc);
    #[cfg(parallel)]
    {
        use rayon::prelude::*;
        lines.par_chunks_mut(chunk).zip(scratch.par_iter_mut()).enumerate().for_each(work);
    }
    #[cfg(not(parallel))]
    lines.chunks_mut(chunk).zip(scratch.iter_mut()).enumerate().for_each(work);
}

/// What every line of one family's segmentation reads.
struct LineInput<'a> {
    restored: &'a Restored,
    linear: &'a [Rgb],
    flags: &'a [PixelFlags],
    axis: ScanAxis,
    period: f32,
    len: usize,
    /// Whether channels clipped at a boundary give way to an unclipped one in placing
    /// it ([`CLIPPED_WEIGHT`]).
    clipped_give_way: bool,
    /// How far a channel's change may be from a value and still read as it on a sharp
    /// line ([`VALUE_TOLERANCE`], or [`SMEARED_VALUE_TOLERANCE`] with half-resolution
    /// chroma; broad lines take the latter in any frame).
    value_tolerance: f32,
    /// See [`Segmentation::for_pattern`].
    unlit: [bool; 3],
}

/// The boundaries of line `line` into `edges`. Runs of usable pixels are numbered
/// along the line (an edge's `run` is only compared with its own line's).
fn segment_line(input: &LineInput, line: usize, edges: &mut Vec<Edge>, sc: &mut LineScratch) {
    let LineInput { restored, linear, flags, axis, period, len, clipped_give_way, value_tolerance, unlit } = *input;
    let w = restored.width;
    for ch in 0..3 {
        sc.signal[ch].resize(len, 0.0);
        sc.light[ch].resize(len, 0.0);
        sc.level[ch].resize(len, 0.0);
        sc.share[ch].resize(len, 0.0);
    }
    sc.flags.resize(len, 0);
    sc.strength.resize(len, 0.0);
    let mut run_id = 0u32;
    edges.clear();
    // The line's samples, copied into contiguous scratch: a row is a slice of each
    // plane, a column every `w`-th sample.
    match axis {
        ScanAxis::Rows => {
            let span = line * w..line * w + len;
            sc.flags.copy_from_slice(&flags[span.clone()]);
            for ch in 0..3 {
                sc.signal[ch].copy_from_slice(&restored.log[ch][span.clone()]);
            }
            let [l0, l1, l2] = &mut sc.level;
            for (((a, b), c), p) in l0.iter_mut().zip(l1.iter_mut()).zip(l2.iter_mut()).zip(&linear[span]) {
                (*a, *b, *c) = (p[0], p[1], p[2]);
            }
        }
        ScanAxis::Columns => {
            // `w` is at least 1: a column exists.
            for (f, &v) in sc.flags.iter_mut().zip(flags[line..].iter().step_by(w)) {
                *f = v;
            }
            for ch in 0..3 {
                for (sig, &v) in sc.signal[ch].iter_mut().zip(restored.log[ch][line..].iter().step_by(w)) {
                    *sig = v;
                }
            }
            let [l0, l1, l2] = &mut sc.level;
            for (((a, b), c), p) in l0.iter_mut().zip(l1.iter_mut()).zip(l2.iter_mut()).zip(linear[line..].iter().step_by(w)) {
                (*a, *b, *c) = (p[0], p[1], p[2]);
            }
        }
    }
    for ch in 0..3 {
        exp_into(&sc.signal[ch], &mut sc.light[ch]);
    }
    let ok = |f: PixelFlags| f & UNUSABLE == 0;
    // Edge strength: squared central differences, summed over the channels
    // that are not dark at the three pixels involved (a dark channel's log is
    // noise); only where the three pixels are usable.
    // Each channel weighted by how far its brighter side is above the noise: a
    // channel near the floor on both sides (a black stripe's channel) has a log that
    // is mostly noise. Each channel's share is computed everywhere first, in a pass
    // without branches over slices of the same length; then one pass adds the three
    // shares in order where the channel is not dark, only where the three pixels are
    // usable. Both vectorize (natively and with simd128).
    if len < 3 {
        sc.strength.iter_mut().for_each(|v| *v = 0.0);
    } else {
        let inner = len - 2;
        for ch in 0..3 {
            let (sig, lev) = (&sc.signal[ch][..len], &sc.level[ch][..len]);
            let (s0, s2, l0, l2) = (&sig[..inner], &sig[2..], &lev[..inner], &lev[2..]);
            let share = &mut sc.share[ch][..inner];
            for i in 0..inner {
                let m = max_f32(l0[i], l2[i]);
                let weight = lit_weight(m);
                let d = 0.5 * (s2[i] - s0[i]);
                share[i] = weight * (d * d);
            }
        }
        (sc.strength[0], sc.strength[len - 1]) = (0.0, 0.0);
        let f = &sc.flags[..len];
        let [a, b, c] = &sc.share;
        let (a, b, c) = (&a[..inner], &b[..inner], &c[..inner]);
        let out = &mut sc.strength[1..len - 1];
        for i in 0..inner {
            let near = f[i] | f[i + 1] | f[i + 2];
            // Loaded whatever the flags say: a load under a condition kept this pass
            // from vectorizing.
            let (a, b, c) = (a[i], b[i], c[i]);
            let mut v = 0.0;
            v += if near & 1 << 3 != 0 { 0.0 } else { a };
            v += if near & 1 << 4 != 0 { 0.0 } else { b };
            v += if near & 1 << 5 != 0 { 0.0 } else { c };
            out[i] = if near & UNUSABLE != 0 { 0.0 } else { v };
        }
    }
    // Local maxima (strict on the right so plateaus give one edge), then
    // sub-pixel refinement. Where stripes are wide enough, a maximum must
    // also top the strength two pixels out (a ripple on a stronger edge's flank is
    // no edge); narrower stripes put the next boundary's own peak there.
    let wide_stripes = period >= SHOULDER_MIN_PERIOD;
    // The edges are placed as the last line's were (broad or not), and placed again
    // the other way where this line's own edges say otherwise; never broad with
    // narrow stripes, whose neighbouring boundaries the smoothed derivative reaches.
    sc.peaks.clear();
    let shape = sc.shape;
    if shape == PeakShape::Soft && period >= SOFT_SMOOTH_MIN_PERIOD {
        smooth_strength(&mut sc.strength[..len]);
    }
    let clipped = clipped_give_way.then_some(&sc.flags[..]);
    let mut s = 1;
    while s + 1 < len {
        // Usable samples too weak for an edge, passed in a tight loop (most are).
        {
            let (strength, fl) = (&sc.strength[..len], &sc.flags[..len]);
            while s + 1 < len && ok(fl[s]) && !(strength[s] >= MIN_EDGE_STRENGTH) {
                s += 1;
            }
            if s + 1 >= len {
                break;
            }
        }
        if !ok(sc.flags[s]) {
            run_id += 1;
            // Skip the unusable stretch.
            while s + 1 < len && !ok(sc.flags[s]) {
                s += 1;
            }
            continue;
        }
        let (a, b, c) = (sc.strength[s - 1], sc.strength[s], sc.strength[s + 1]);
        let wider = |k: isize| {
            let t = s as isize + k;
            t < 0 || t >= len as isize || sc.strength[t as usize] <= b
        };
        if b >= MIN_EDGE_STRENGTH && b >= a && b > c && (!wide_stripes || (wider(-2) && wider(2))) {
            // Sub-pixel position from the linear-light gradient: blur acts on
            // linear light, so a blurred step's linear gradient peaks at the step
            // while its log gradient leans to the darker side (by 0.4 of the blur's
            // deviation for the patterns' steps of 0.35 to 1, a pixel for a soft
            // projector's). See [`subpixel_peak`].
            // None where its peak is at the end of the line: no place to read.
            if let Some((p, offset, var)) = subpixel_peak(&sc.light, &sc.level, clipped, s, len, shape) {
                edges.push(Edge { pos: p as f32 + offset, code: NO_CODE, mask: 0, run: run_id, id: -1, tentative: Tentative::NONE });
                sc.peaks.push((s, var));
            }
        }
        s += 1;
    }
    sc.shape = PeakShape::of(wide_stripes, median_peak_var(&sc.peaks, &mut sc.widths));
    let placed = sc.shape;
    if placed != shape {
        for (e, &(s, _)) in edges.iter_mut().zip(&sc.peaks) {
            if let Some((p, offset, _)) = subpixel_peak(&sc.light, &sc.level, clipped, s, len, placed) {
                e.pos = p as f32 + offset;
            }
        }
    }
    // A broad line's steps are smeared as half-resolution chroma's are.
    let value_tolerance = if placed == PeakShape::Sharp { value_tolerance } else { SMEARED_VALUE_TOLERANCE };
    classify(edges, sc, period, value_tolerance, unlit);
    edges.retain(|e| e.mask != 0);
}

/// The edge strength of a line smoothed once by (1, 2, 1) / 4, in place (see
/// [`SOFT_SMOOTH_MIN_PERIOD`]). A sample of strength 0 (unusable, or at either end)
/// stays 0, and a sample beside one takes its own value in its place, so that no edge
/// leaks into an unusable stretch or is pulled down beside one.
fn smooth_strength(strength: &mut [f32]) {
    let Some(&first) = strength.first() else { return };
    let mut before = first;
    for i in 1..strength.len().saturating_sub(1) {
        let here = strength[i];
        if here > 0.0 {
            let a = if before > 0.0 { before } else { here };
            let c = if strength[i + 1] > 0.0 { strength[i + 1] } else { here };
            strength[i] = 0.25 * a + 0.5 * here + 0.25 * c;
        }
        before = here;
    }
}

/// How far (pixels) the linear-light gradient's peak is sought from the log
/// strength's: 1. The log gradient's lean to the dark side is 0.4 of the blur's
/// deviation, so this reaches a blur of 2.5 camera pixels. A reach of 2 helped the
/// simulator's soft projector a little (the wall 97.9 % -> 98.1 % covered) and cost a
/// real capture's lobed stripes (Zion1123's sphere: 25.8 % -> 25.1 % covered, 0.75 %
/// -> 1.19 % of its points over 2 mm off), where the peak two pixels out is the next
/// lobe's flank.
pub const PEAK_REACH: usize = 1;

/// [`PEAK_REACH`] on a soft line (`PeakShape::Soft`): 2. A blur of several pixels
/// leans the log strength's peak further to the dark side than one pixel (the
/// lean is 0.4 of the blur's deviation). Measured on the 12 `soft` rows of `eval
/// --hard` (mean coverage / outliers): 84.26 % / 0.683 % with 1, 84.23 % / 0.647 % with
/// 2, the RMSE down on every row but the plane's (paper 1.061 -> 1.028 mm); with 3,
/// on six of them, no better than 2 (wood 0.84 -> 0.87 % outliers). On tingck's real
/// wall (`scripts/real-data.sh`; stripes of about 18 pixels whose steps spread over
/// 10-16) 28.2 -> 32.0 % of the object, the stripe coordinates 97.15 -> 98.06 % within
/// a quarter stripe; its hand 4.2 -> 5.3 %. It costs where lobes stand close
/// (Zion's sphere, [`PEAK_REACH`]): with `loggrad` 26.2 -> 26.1 % covered and 0.50 ->
/// 0.77 % of the points over 2 mm from the fitted sphere; with `direct` 28.2 -> 25.4 %
/// covered but 2.19 -> 0.89 % over 2 mm. The 8-megapixel rows, whose lines are soft
/// too, lost 0.1-0.4 point of coverage each (colorchecker/8mp 86.8 -> 86.4 %).
pub const SOFT_PEAK_REACH: usize = 2;

/// Least expected stripe period (pixels) at which a soft line's strength is smoothed
/// once by (1, 2, 1) / 4 before its local maxima are taken: 12. Where a step spreads
/// over many pixels, the central difference has a maximum wherever noise, JPEG or one
/// channel's clipping ripples its slope, and one boundary gave two to four edges a
/// few pixels apart (tingck's wall: white to cyan, red falling from 220 to 16 over 16
/// pixels, read as two edges 11 pixels apart). Each edge then read its sides from the
/// ripple between them. Not on narrower stripes: the simulator's soft projector's
/// 7-pixel stripes lost coverage when smoothed (paper-dye/soft 68.0 -> 52.6 %), the
/// next boundary's peak being within reach. Measured with [`SOFT_PEAK_REACH`] in
/// place: tingck's wall 32.0 -> 36.1 % of the object (98.07 % of its stripe
/// coordinates within a quarter stripe, none a stripe off), the hand 5.3 -> 6.3 %;
/// smoothed twice, 37.7 % and 5.4 %. The simulated rows whose soft lines have
/// stripes that wide are the 8-megapixel ones: colorchecker 86.4 -> 88.2 %, skin 93.4
/// -> 94.9 %, sphere-dye 90.4 -> 89.3 %, bag 70.5 -> 69.0 %, outliers the same; the
/// `wide` rows (25-pixel stripes, seldom soft) changed by 0.1 point at most.
pub const SOFT_SMOOTH_MIN_PERIOD: f32 = 12.0;

/// The median variance (pixels²) of a line's gradient peaks, as the central
/// difference sees them, above which the line's edges are placed with the smoothed
/// derivative (`PeakShape::of`): 1.1 (the blur's variance plus the pixels' and the
/// difference's own). On the white wall, the lines' medians are 0.80-0.92 with a
/// sharp projector and a focused camera (a blur of 0.6 pixels), 1.2-4.5 with the
/// projector blurred by 3 of its pixels (2 camera pixels); through 4:2:0 chroma most
/// lines measure about 1.5 (the colour comes at half resolution), and the smoothed
/// derivative takes their RMSE down by a tenth or more (skin under `webcam`: 0.708
/// -> 0.598 mm).
pub const BROAD_PEAK_VAR: f32 = 1.1;

/// The median variance (pixels², as the central difference sees them) of a broad
/// line's gradient peaks above which the line is soft (`PeakShape::Soft`): its
/// edges are placed with the 7-tap derivative, the least-squares slope through seven
/// samples, (1, 2, 3, 0, -3, -2, -1) / 28, instead of the 5-tap one.
///
/// Why: the soft projector's lines measure 1.2-4.5, and their boundaries' noise
/// comes from the derivative as much as from the fit ([`BROAD_FIT_HALF`]). Measured
/// on the 12 `soft` rows of the hard evaluation (`eval --hard --conditions soft`),
/// mean coverage / outliers / RMSE: 83.88 % / 0.757 % / 0.765 mm with the 5-tap
/// derivative; with the 7-tap one on every broad line 84.31 % / 0.674 % / 0.739 mm,
/// but then the 45 rows of `eval --hard --scenes sphere,occluders,textured,paper,wood,
/// colorchecker,bag,skin,paper-dye --conditions default,webcam,wide,clipped,world`
/// lost (occluders 0.17 % -> 0.20 % outliers; some of its lines measure 1.5-2, and
/// 4:2:0 chroma's about 1.5); above 1.5, occluders/default still went from 0.165 % to
/// 0.195 % outliers (measured on that row alone); above 2, 84.26 % / 0.683 % / 0.740
/// mm on the `soft` rows and the 45 rows unchanged within noise (mean coverage 88.94 %
/// -> 88.96 %, outliers 0.365 % -> 0.366 %). A 9-tap derivative did worse than the
/// 7-tap one on the soft wall (0.10 % against 0.06 % outliers): with 7-pixel stripes
/// it reaches the next boundary.
pub const SOFT_PEAK_VAR: f32 = 2.0;

/// The median of a line's peak variances in `peaks` ([`subpixel_peak`]; NaN where a
/// peak had no curvature, left out; 0 for none): a line is broad above
/// [`BROAD_PEAK_VAR`] and soft above [`SOFT_PEAK_VAR`]. `widths` is scratch. Decided
/// per line, not per edge: one peak's variance from three noisy samples is too loose
/// (on a soft projector's wall a tenth of them measure under 1.1).
fn median_peak_var(peaks: &[(usize, f32)], widths: &mut Vec<f32>) -> f32 {
    widths.clear();
    widths.extend(peaks.iter().map(|&(_, v)| v).filter(|v| !v.is_nan()));
    if widths.is_empty() {
        return 0.0;
    }
    let mid = widths.len() / 2;
    let (_, &mut median, _) = widths.select_nth_unstable_by(mid, f32::total_cmp);
    median
}

/// Share of its weight (`lit_weight`) that a channel clipped at either end of a
/// boundary (2 samples out) keeps in placing it (`subpixel_peak`), where a channel
/// clipped at neither end changes by over [`CLIPPED_CLEAN_STEP`] of its brighter side.
/// Clipping cuts the top off a blurred step, so the clipped channel's gradient peaks
/// towards its unclipped side (0.38 px off with its full weight where the clipped
/// side is three times over, in the unit test
/// `a_clipped_channel_leaves_the_boundary_to_an_unclipped_one`), and being the
/// brightest it outweighed the unclipped one.
///
/// Only where the frame's colour is at full resolution: under 4:2:0 chroma an
/// unclipped channel's own edge is no sharper than the clipped one's, and giving way
/// made the `world` rows worse (RMSE: plane 0.257 -> 0.264, paper 0.570 -> 0.587, skin
/// 0.498 -> 0.513, wood 0.655 -> 0.676 mm).
///
/// Measured on the 12 `clipped` rows of the hard evaluation (`eval --hard --conditions
/// clipped`; coverage / outliers / RMSE), full weight -> none -> a quarter:
/// colorchecker/clipped 94.18 % / 0.306 % / 0.421 mm -> 94.11 % / 0.295 % / 0.404 mm ->
/// 94.3 % / 0.30 % / 0.402 mm (its goal is 94.16 %; a [`CLIPPED_CLEAN_STEP`] of 0.15 or
/// 0.5 with no weight gave 94.03 % and 94.12 %). With a quarter, RMSE: sphere 0.367 ->
/// 0.344, textured 0.426 -> 0.402, occluders 0.376 -> 0.347, paper 0.503 -> 0.493,
/// wood 0.509 -> 0.500, skin 0.344 -> 0.332, wall 0.217 -> 0.209 mm, coverage the same
/// or up; paper-dye/clipped the same once [`CLIPPED_CLEAN_LEVEL`] was added.
pub const CLIPPED_WEIGHT: f32 = 0.25;

/// The change, as a share of the brighter side, of a channel clipped at neither end of
/// a boundary for the clipped channels to give way to it ([`CLIPPED_WEIGHT`]).
pub const CLIPPED_CLEAN_STEP: f32 = 0.3;

/// The linear level the brighter side of a channel clipped at neither end of a boundary
/// must top for the clipped channels to give way to it ([`CLIPPED_WEIGHT`]), about
/// 8-bit code 90 through gamma 2.2: a dimmer channel's gradient is too noisy to place
/// the boundary alone. Measured on the 12 `clipped` rows (`eval --hard --conditions
/// clipped`), paper-dye/clipped (coverage / outliers / RMSE), whose 1 % dyes leave the
/// unclipped channels dim: with no floor 86.7 % / 0.36 % / 0.697 mm, 0.014 (four times
/// [`DARK_LEVEL`]) 86.7 % / 0.35 % / 0.696 mm, 0.03 86.7 % / 0.34 % / 0.688 mm, 0.05,
/// 0.1 and 0.2 87.0 % / 0.32 % / 0.68 mm, as with the clipped channels' full weight;
/// the other rows kept their gains from 0.05 to 0.1 and lost some at 0.2 (sphere 0.344
/// -> 0.350 mm).
pub const CLIPPED_CLEAN_LEVEL: f32 = 0.1;

/// The sub-pixel place of the boundary whose log strength peaks at sample `s` of a
/// line of `len` samples with the restored linear `light` per channel (the
/// exponential of the restored log, taken once per line by `segment_line`; `level`
/// is the frame's linear light, which weighs the channels): the peak of the
/// linear-light gradient (the sum over channels of its squares), climbed to from `s`
/// at most [`PEAK_REACH`] samples ([`SOFT_PEAK_REACH`] on a soft line), then a
/// Gaussian through it and its neighbours (a
/// parabola through their logs; a blurred step's gradient is a Gaussian, so this is
/// exact for any blur, where a parabola through the values leans to the sample).
/// The derivative is the central difference for a [`PeakShape::Sharp`] line, the
/// 5-tap smoothed one, (1, 2, 0, -2, -1) / 8, for a broad one (and the 7-tap one for
/// a soft one, [`SOFT_PEAK_VAR`]): a soft projector's edges spread over several pixels,
/// and the noise of a peak through 3 samples grows with its width (on the white wall
/// under a projector blurred by 3 pixels, 27 % of the boundaries were more than a
/// quarter of a pixel off with the central difference and a parabola, 13 % with
/// this). Each channel counts as much as it is lit (see the strength in
/// `segment_line`): on the crumpled paper in 1 % dyes, with a sharp projector, that
/// took the boundaries more than a quarter of a pixel off from 14 % to 4 % in one
/// family and from 6 % to 5 % in the other. On a broad or soft line the Gaussian is
/// fitted to five samples, not three ([`broad_fit`]). Returns the
/// sample, the offset from it (within ±0.5) and the peak's variance (pixels², from
/// the second difference of the logs, or the fit's, as the central difference would
/// see it: less what the smoothed derivative adds; NaN where they have none). Within
/// a few samples of either end of the line a narrower derivative is taken
/// ([`PeakShape::within`]); a peak on the second or the last but one sample has no
/// place (None).
/// `clipped`, the line's pixel flags where the frame's colour is at full resolution,
/// lets channels clipped at the boundary give way to an unclipped one
/// ([`CLIPPED_WEIGHT`]).
fn subpixel_peak(light: &[Vec<f32>; 3], level: &[Vec<f32>; 3], clipped: Option<&[PixelFlags]>, s: usize, len: usize, shape: PeakShape) -> Option<(usize, f32, f32)> {
    // Each channel weighted as in the edge strength, by how far its brighter side
    // (2 samples out) is above the noise: a channel near the floor on both sides has
    // a restored signal that is mostly noise, and a soft edge's peak is low enough
    // for that noise to move it.
    let (before, after) = (s.saturating_sub(2), (s + 2).min(len - 1));
    let mut weight: [f32; 3] = std::array::from_fn(|ch| lit_weight(max_f32(level[ch][before], level[ch][after])));
    // A channel clipped at either end has had the top of its step cut off, so its
    // gradient peaks towards the unclipped side; where a channel clipped at neither
    // end changes too, that one places the boundary.
    let clipped = clipped.map_or(0, |f| (f[before] | f[after]) & CLIPPED_BITS);
    if clipped != 0 && clipped != CLIPPED_BITS {
        let changes = |ch: usize| {
            let (a, b) = (level[ch][before], level[ch][after]);
            let bright = max_f32(a, b);
            bright > CLIPPED_CLEAN_LEVEL && (a - b).abs() > CLIPPED_CLEAN_STEP * bright
        };
        if (0..3).any(|ch| clipped & (1 << ch) == 0 && changes(ch)) {
            for (ch, w) in weight.iter_mut().enumerate() {
                if clipped & (1 << ch) != 0 {
                    *w *= CLIPPED_WEIGHT;
                }
            }
        }
    }
    let shape = shape.within(s, len);
    let reach = shape.stencil();
    // The weighted squared gradient of the linear light at sample t (0 where its
    // stencil leaves the line), the channels added in order.
    let gradient = |t: usize| -> f32 {
        if t < reach || t + reach >= len {
            return 0.0;
        }
        let mut sum = 0.0;
        for (ch, x) in light.iter().enumerate() {
            let x = &x[t - reach..=t + reach];
            let d = match shape {
                PeakShape::Sharp => (x[2] - x[0]) * 0.5,
                PeakShape::Broad => (x[4] - x[0] + (x[3] - x[1]) * 2.0) * 0.125,
                PeakShape::Soft => (x[6] - x[0] + (x[5] - x[1]) * 2.0 + (x[4] - x[2]) * 3.0) * (1.0 / 28.0),
            };
            sum += weight[ch] * d * d;
        }
        sum
    };
    // Up the slope from `s`, each step to a strictly larger value (so it ends): the
    // log strength leans to the dark side, and it leaves out channels that are dark
    // on a side, which can move its peak a pixel towards the bright side (black
    // stripes).
    let (mut p, reach) = (s, shape.climb() as isize);
    let (mut a, mut b, mut c) = (gradient(p - 1), gradient(p), if p + 1 < len { gradient(p + 1) } else { 0.0 });
    loop {
        let d = p as isize - s as isize;
        if a > b && a >= c && p >= 2 && d > -reach {
            p -= 1;
            (b, c) = (a, b);
            a = gradient(p - 1);
        } else if c > b && p + 2 < len && d < reach {
            p += 1;
            (a, b) = (b, c);
            c = gradient(p + 1);
        } else {
            break;
        }
    }
    // A peak on the first or the last sample whose gradient can be taken (the
    // line's second or last but one) has its fit cut off by the end: half of the
    // peak may be past the frame's edge, and the boundary could be anywhere within a
    // pixel or two of it. No edge is placed there.
    if p < 2 || p + 2 >= len {
        return None;
    }
    if shape != PeakShape::Sharp && p >= BROAD_FIT_HALF && p + BROAD_FIT_HALF < len {
        let (before, after) = (gradient(p - BROAD_FIT_HALF), gradient(p + BROAD_FIT_HALF));
        if let Some(fit) = broad_fit([before, a, b, c, after]) {
            return Some((p, fit.0, fit.1 - shape.smoothing_var()));
        }
    }
    if a > 0.0 && b > 0.0 && c > 0.0 {
        let l = wide::f32x4::new([a, b, c, 1.0]).ln().to_array();
        let den = l[0] - 2.0 * l[1] + l[2];
        if den < 0.0 {
            // A Gaussian's log has second difference -2 / variance.
            return Some((p, (0.5 * (l[0] - l[2]) / den).clamp(-0.5, 0.5), -2.0 / den - shape.smoothing_var()));
        }
        return Some((p, 0.0, f32::NAN));
    }
    let den = a - 2.0 * b + c;
    Some((p, if den < 0.0 { (0.5 * (a - c) / den).clamp(-0.5, 0.5) } else { 0.0 }, f32::NAN))
}

/// `out[i] = exp(x[i])`, four samples at a time (the same four-lane exponential for
/// every sample, so a sample's value does not depend on its neighbours).
fn exp_into(x: &[f32], out: &mut [f32]) {
    use wide::f32x4;
    let n = x.len().min(out.len());
    let (x, out) = (&x[..n], &mut out[..n]);
    let mut chunks = out.chunks_exact_mut(4);
    let mut from = x.chunks_exact(4);
    for (o, v) in (&mut chunks).zip(&mut from) {
        o.copy_from_slice(&f32x4::new([v[0], v[1], v[2], v[3]]).exp().to_array());
    }
    let (rest, tail) = (chunks.into_remainder(), from.remainder());
    if !rest.is_empty() {
        let mut v = [0.0; 4];
        v[..tail.len()].copy_from_slice(tail);
        rest.copy_from_slice(&f32x4::new(v).exp().to_array()[..rest.len()]);
    }
}

/// Samples either side of a broad line's gradient peak to which `subpixel_peak`
/// fits its Gaussian (`broad_fit`): 2.
///
/// Why: a soft projector's edges spread over four to six pixels, so a Gaussian
/// through the peak and its two neighbours reads the top of a broad curve, where it
/// is flattest and the noise moves its vertex most. Measured against the ground
/// truth of the `soft` condition's wall, the identified boundaries lay 0.22 / 0.18
/// pixels RMS from their true places (the two families, the near part of the wall)
/// and 0.39 / 0.26 on its darker far part; fitted to five samples, 0.18 / 0.14 and
/// 0.33 / 0.19; to seven, 0.20 / 0.18 and 0.37 / 0.24 (the next boundary's flank
/// comes in). On the 12 `soft` rows of the hard evaluation (`eval --hard --conditions
/// soft`), mean coverage / outliers / RMSE 82.9 % / 1.05 % / 0.892 mm became 83.9 % /
/// 0.76 % / 0.765 mm; lines through 4:2:0 chroma are broad too, and the 45 rows of
/// `eval --hard --scenes sphere,occluders,textured,paper,wood,colorchecker,bag,skin,
/// paper-dye --conditions default,webcam,wide,clipped,world` went from 0.370 % /
/// 0.570 mm to 0.365 % / 0.552 mm (skin/world 0.564 -> 0.499 mm). Sharp lines keep
/// three samples: there the two outer ones are in the tails (the crumpled paper's
/// boundaries 0.10 -> 0.11 pixels RMS with five). The cost: two more samples'
/// exponentials and a four-lane logarithm per boundary of a broad line, 1.8 ms per
/// family on the textured webcam frame (`examples/bench_frame`, one thread, segment
/// 16.0 -> 17.9 and 16.8 -> 18.5 ms).
///
/// What is left on a soft line is the surface (measured on 2026-12-07 against the
/// ground truth of the `soft` rows, family 0): boundaries with a step of the surface's
/// own light within 4 pixels (over 0.2 in some channel's log in a frame of the scene
/// under plain white) lie 0.6-1.1 pixels RMS from their places on paper, textured and
/// wood, against 0.13-0.25 without one (0.04 on the plain wall); they are most of those
/// rows' outliers, 0.1-0.2 of a stripe off. Dividing out the light of the channels the
/// pattern leaves unchanged at the boundary (a scratch build, after identification)
/// made every row worse (plane/soft 0.08 -> 0.28 pixels RMS): under a blur of 2 pixels
/// the ramps of the boundaries either side, 3.5 pixels away, reach into those channels.
pub const BROAD_FIT_HALF: usize = 2;

/// The vertex of a Gaussian fitted by weighted least squares to five samples of a
/// gradient's strength (`g[2]` the peak sample, the others 1 and 2 samples either
/// side): a parabola through their logs, each weighted by its strength (the noise of
/// a log is about the inverse of the square root of its value). Returns the vertex's
/// offset from the peak sample (within ±0.5) and the gradient's variance as the
/// three-sample fit gives it (the inverse of minus the parabola's leading term);
/// `None` where a sample is not positive or the parabola does not open downwards.
fn broad_fit(g: [f32; 5]) -> Option<(f32, f32)> {
    let peak = g[2];
    if !g.iter().all(|&v| v > 0.0) {
        return None;
    }
    // Relative to the peak, so that the sums stay in range: its log is 0.
    let l = wide::f32x4::new([g[0] / peak, g[1] / peak, g[3] / peak, g[4] / peak]).ln().to_array();
    let (logs, w) = ([l[0], l[1], 0.0, l[2], l[3]], g.map(|v| v / peak));
    // Normal equations of log = c0 + c1 k + c2 k² over k = -2..=2.
    let (mut s, mut t) = ([0f32; 5], [0f32; 3]);
    for (i, (&wi, &li)) in w.iter().zip(&logs).enumerate() {
        let k = i as f32 - 2.0;
        let mut kp = wi;
        for sj in &mut s {
            *sj += kp;
            kp *= k;
        }
        t[0] += wi * li;
        t[1] += wi * li * k;
        t[2] += wi * li * k * k;
    }
    let m = [[s[0], s[1], s[2]], [s[1], s[2], s[3]], [s[2], s[3], s[4]]];
    let det = |m: &[[f32; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(&m);
    // Cramer's rule for c1 and c2: the matrix with column j replaced by `t`.
    let solve = |j: usize| {
        let mut mj = m;
        for (row, &tr) in mj.iter_mut().zip(&t) {
            row[j] = tr;
        }
        det(&mj) / d
    };
    // (A NaN determinant or leading term gives no fit either.)
    if d.is_nan() || d.abs() <= f32::EPSILON {
        return None;
    }
    let (c1, c2) = (solve(1), solve(2));
    if c2.is_nan() || c2 >= 0.0 {
        return None;
    }
    Some(((-c1 / (2.0 * c2)).clamp(-0.5, 0.5), -1.0 / c2))
}

/// What one side of a boundary shows in one channel.
#[derive(Clone, Copy, Debug, Default)]
struct Side {
    /// Mean restored log signal.
    log: f32,
    /// Mean linear level.
    level: f32,
    /// Pixels averaged.
    n: u32,
    /// Some pixel was clipped in this channel.
    clipped: bool,
    /// Some pixel was dark in this channel.
    dark: bool,
    /// Least-squares slope of the restored log signal along the plateau, per pixel;
    /// none on a plateau of under 3 pixels, or one that departs from its line by more
    /// than [`SLOPE_FIT`].
    slope: Option<f32>,
    /// Sum of the pixels' squared offsets from the centre: the slope's noise is the
    /// pixels' over its root.
    spread: f32,
    /// Position of the plateau's centre along the line.
    centre: f32,
}

/// The plateau strictly between positions `a` and `b`, every channel, keeping a margin
/// of a pixel from each end (the blurred transition); `None` when it holds an unusable
/// pixel or nothing.
fn plateau(sc: &LineScratch, a: f32, b: f32) -> Option<[Side; 3]> {
    let len = sc.flags.len();
    let lo = max_f32((a + 1.0).ceil(), 0.0) as usize;
    let hi = (b - 1.0).floor();
    let (lo, hi) = if hi < lo as f32 {
        // A narrow stripe: the sample halfway.
        let mid = ((a + b) * 0.5).round();
        if mid < 0.0 || mid as usize >= len {
            return None;
        }
        (mid as usize, mid as usize)
    } else {
        (lo, (hi as usize).min(len - 1))
    };
    let flags = &sc.flags[lo..=hi];
    let any = flags.iter().fold(0, |m, &f| m | f);
    if any & UNUSABLE != 0 {
        return None;
    }
    let n = flags.len() as u32;
    // The six sums in one walk, each in the order `Iterator::sum` takes (from -0.0,
    // which any first term replaces exactly), and in the same walk the moments and
    // squares of the restored signal about the plateau's centre, for its slope and its
    // departure from that line.
    let [s0, s1, s2] = &sc.signal;
    let [l0, l1, l2] = &sc.level;
    let (s0, s1, s2, l0, l1, l2) = (&s0[lo..=hi], &s1[lo..=hi], &s2[lo..=hi], &l0[lo..=hi], &l1[lo..=hi], &l2[lo..=hi]);
    let centre = 0.5 * (lo + hi) as f32;
    let mut sums = [-0.0f32; 6];
    let mut moments = [0f32; 3];
    let mut squares = [0f32; 3];
    let mut spread = 0f32;
    for k in 0..s0.len() {
        sums[0] += s0[k];
        sums[1] += s1[k];
        sums[2] += s2[k];
        sums[3] += l0[k];
        sums[4] += l1[k];
        sums[5] += l2[k];
        let x = lo as f32 + k as f32 - centre;
        moments[0] += x * s0[k];
        moments[1] += x * s1[k];
        moments[2] += x * s2[k];
        squares[0] += s0[k] * s0[k];
        squares[1] += s1[k] * s1[k];
        squares[2] += s2[k] * s2[k];
        spread += x * x;
    }
    let mut sides = [Side::default(); 3];
    for (ch, side) in sides.iter_mut().enumerate() {
        let (log, level) = (sums[ch] / n as f32, sums[3 + ch] / n as f32);
        let mut slope = None;
        if n >= 3 {
            let g = moments[ch] / spread;
            let residual = squares[ch] - n as f32 * log * log - g * g * spread;
            let limit = max_f32(SLOPE_FIT, SLOPE_FIT_SIGMAS * NOISE_LINEAR / max_f32(level, DARK_LEVEL));
            if residual <= n as f32 * limit * limit {
                slope = Some(g);
            }
        }
        *side = Side {
            log,
            level,
            n,
            clipped: any & (1 << ch) != 0,
            dark: any & (1 << (3 + ch)) != 0,
            slope,
            spread,
            centre,
        };
    }
    Some(sides)
}

/// How much of the step from side `l` to side `r` (one channel) the surface itself
/// makes, and that estimate's variance, from the slopes of the restored log signal
/// inside the two plateaus (the stripes are flat there, so a slope is the surface's
/// colour or shading changing): the slope times the distance between
/// the plateaus' centres, taking the smaller of the two slopes, and none where they
/// differ in sign: a surface's drift runs on across the boundary, while a stripe's
/// profile (a blurred or lobed stripe rising into the boundary on one side and falling
/// away on the other) need not. `None` when a plateau is too short for a slope or does
/// not fit a line ([`SLOPE_FIT`]), a side is clipped, the slopes differ in sign, or the
/// shift is within [`NOISE_SIGMAS`] of its noise (`nl`, `nr`: the sides'
/// [`log_noise`]); most boundaries then keep their plain step, and the noise of a slope
/// from a few pixels stays out of them.
///
/// Where this is not enough (`cargo run --release --example boundary_codes -- bag
/// default 140 100 500 420`, which compares each boundary's codes with the pattern's
/// transition at the ground truth's projector coordinate): of the bag's real
/// boundaries, 56 % (family 0) and 53 % (family 1) of those read as one exact code,
/// and 30 % of those read as 2 to 6 codes, leave out the true transition; on the
/// `wall`, none of 43 700. Its hue wanders over two turns of the
/// colour circle within a blotch, so a channel falls from 0.72 to 1 % over a few
/// pixels, as steep in the log as a stripe's step, and where that falls on a boundary
/// the channel reads the surface's step, not the pattern's. Tried and not kept: each
/// channel's step given the noise `k · max(|slope left|, |slope right|) · distance`,
/// with every plateau's slope (fitting its line or not) (`eval --hard --conditions
/// default,webcam` on six scenes, coverage): k = 0.15 bag 65.6 -> 68.7 %, bag/webcam
/// 57.1 -> 61.5 % (goal 64.5 %), but colorchecker 91.3 -> 91.0 %, wood 96.2 -> 95.8 %;
/// k = 0.3 with slopes over 0.05 a pixel only, bag 67.6 %, bag/webcam 61.1 %, wood
/// 95.7 %, wood/webcam 93.3 -> 92.9 %; only for a channel under a quarter of its side's
/// brightest, bag 66.6 %, wood 95.8 %. Exact readings that wrong want an alignment
/// that weighs each channel's reading by how flat its plateaus are, not a wider mask.
///
/// Also tried that day and not kept: a shift common to the three channels (a change of
/// the surface's brightness, as wood's grain or a blotch's edge makes, moves every
/// channel's log by the same amount) let through up to `s` times the largest step,
/// each code allowed whose channels' values all fit one shift (on the 24 `default`,
/// `webcam`, `world` and `wide` rows of wood, colorchecker, bag, skin, paper-dye and
/// occluders; mean coverage / outliers 85.75 % / 0.410 %): s = 0.15, 85.94 % / 0.388 %
/// (bag/webcam 57.1 -> 59.5 %, colorchecker/world 91.5 -> 92.0 %, but occluders/wide
/// 0.45 -> 0.62 % outliers, losing its goal, and wood/wide 85.6 -> 84.7 %); s = 0.3,
/// 85.85 % / 0.392 % (bag/webcam 62.3 %, bag/world 45.3 -> 49.4 %, wood 96.2 -> 94.6
/// %); s = 0.6, 83.11 % / 0.366 %. Of occluders/wide's new outliers at s = 0.15 (488
/// against 483 new right pixels), nearly all were in cast shadows, no projector light
/// at all: a shadow's edge drops every channel, and the shift let its edges read as
/// stripe boundaries, which a span tied to the largest step, large at a shadow's
/// edge, made easy. A fixed span of 0.15 in the log kept occluders/wide at 0.46 % but
/// gained less (85.80 % / 0.380 %; wood 96.2 -> 95.6 %, occluders 0.17 -> 0.23 %
/// outliers); 0.3, 85.33 % / 0.382 %. Two guards against shadow edges did not keep
/// occluders/wide's outliers down either (s = 0.15, the same 24 rows): the shift only
/// where both plateaus are bounded by other edges within [`HALF_DARK_STRIPE`] periods,
/// 85.91 % / 0.404 % with occluders/wide at 0.63 %; only where the two sides'
/// brightest channels are within a ratio of 2, 85.78 % / 0.413 % (0.59 %), of 4, 85.90
/// % / 0.407 %. What lets the shift put them in the shadows is not found.
fn surface_change(l: &Side, r: &Side, nl: f32, nr: f32) -> Option<(f32, f32)> {
    let (Some(gl), Some(gr)) = (l.slope, r.slope) else {
        return None;
    };
    if l.clipped || r.clipped || gl * gr <= 0.0 {
        return None;
    }
    let distance = r.centre - l.centre;
    let (side, slope, noise) = if gl.abs() < gr.abs() { (l, gl, nl) } else { (r, gr, nr) };
    let shift = distance * slope;
    // A side's per-pixel noise is its mean's noise times the root of its pixel count;
    // a slope's variance is that squared over the sum of squared offsets.
    let var = distance * distance * noise * noise * side.n as f32 / side.spread;
    (shift * shift > NOISE_SIGMAS * NOISE_SIGMAS * var).then_some((shift, var))
}

/// The noise (standard deviation) of a side's mean log signal, `root` the square root
/// of its pixel count (the same in every channel, so taken once per side).
fn log_noise(side: &Side, root: f32) -> f32 {
    NOISE_LINEAR / (max_f32(side.level, DARK_LEVEL) * root)
}

/// Which of down (bit 0), unchanged (bit 1) and up (bit 2) a channel allows.
type Values = u8;
const DOWN: Values = 1;
const SAME: Values = 2;
const UP: Values = 4;
const ANY_VALUE: Values = DOWN | SAME | UP;

/// The codes compatible with per-channel value sets.
fn codes_of(values: [Values; 3]) -> CodeMask {
    let mut mask = 0;
    for r in 0..3 {
        for g in 0..3 {
            for b in 0..3 {
                if values[0] & (1 << r) != 0 && values[1] & (1 << g) != 0 && values[2] & (1 << b) != 0 {
                    mask |= 1 << (r * 9 + g * 3 + b);
                }
            }
        }
    }
    mask & ANY_BOUNDARY
}

/// Give each edge its compatible codes from the plateaus either side (bounded by the
/// neighbouring edges, or a typical stripe width at the ends of a run); edges that are
/// no boundary of this family get an empty mask.
///
/// Each channel's step is read against a reference, the full step of a channel the
/// pattern changes. Unclipped channels give it; but a channel clipped on its bright
/// side only reads too small a step, never too large, so the reference is at least
/// that. Where a clipped channel's step is larger than every clean one, the clean ones
/// are partial: the camera's colour mixing (blue lifting green on a blue stripe), or
/// the surface. Until 2026-12-06 the largest clean step alone was the reference, and
/// such a leak read as a full change. Measured (`eval --hard --conditions
/// clipped,world --scenes colorchecker,wood,skin,bag,sphere,paper-dye`, 12 rows, mean
/// coverage / outliers): 87.64 % / 0.206 % before, 88.22 % / 0.207 % after, every row
/// gaining coverage (wood/world 93.7 -> 95.2 %, colorchecker/world 92.3 -> 92.8 %; bag
/// / clipped 0.15 -> 0.22 % outliers); rows without clipping do not change. On
/// tingck's wall (`scripts/real-data.sh`) 25.8 -> 28.2 % of the object, with the
/// stripe coordinates 96.6 -> 97.2 % within a quarter stripe and 0.06 -> 0.01 % a
/// stripe off; its hand 3.0 -> 4.2 %.
///
/// Tried on 2026-12-07 and not kept: allowing every code that fits the readable
/// channels after one common offset of up to half the reference step (an albedo edge,
/// such as wood's growth rings, shifts every channel's log alike; on `wood` the family
/// of horizontal stripes, whose boundaries run along the rings, reads half its real
/// boundaries on the board without their true transition: `cargo run --release
/// --example boundary_codes -- wood default 200 140 560 340`).
/// The wider masks carry less information: over 18 rows (`default`, `webcam`, `wide`
/// of wood, textured, skin, colorchecker, sphere, bag) mean coverage 87.03 % -> 85.03
/// %, outliers 0.212 % -> 0.158 %, wood 4.5 to 9.4 points down, the bag 2.7 to 3.1 up.
fn classify(edges: &mut [Edge], sc: &LineScratch, period: f32, value_tolerance: f32, unlit: [bool; 3]) {
    let n = edges.len();
    // The plateau right of an edge is the next edge's left one when both are bounded
    // by the same two edges: measured once.
    let mut carried: Option<(f32, f32, Option<[Side; 3]>)> = None;
    // Each side is read no further from the edge than PLATEAU_REACH (the surface's
    // own colour drifts across a wide stripe), except on broad lines (a soft
    // projector, another system's lobes), which read the whole plateau.
    let reach = if sc.shape != PeakShape::Sharp { f32::INFINITY } else { PLATEAU_REACH };
    for i in 0..n {
        let here = edges[i];
        let has_prev = i > 0 && edges[i - 1].run == here.run && here.pos - edges[i - 1].pos <= HALF_DARK_STRIPE * period;
        let has_next = i + 1 < n && edges[i + 1].run == here.run && edges[i + 1].pos - here.pos <= HALF_DARK_STRIPE * period;
        let prev = if i > 0 && edges[i - 1].run == here.run { edges[i - 1].pos } else { here.pos - period };
        let next = if i + 1 < n && edges[i + 1].run == here.run { edges[i + 1].pos } else { here.pos + period };
        let (prev, next) = (max_f32(prev, here.pos - reach), next.min(here.pos + reach));
        let left = match carried {
            Some((a, b, side)) if a == prev && b == here.pos => side,
            _ => plateau(sc, prev, here.pos),
        };
        let right = plateau(sc, here.pos, next);
        carried = Some((here.pos, next, right));
        let (Some(left), Some(right)) = (left, right) else {
            // Not enough of a stripe on one side to read: an edge of unknown transition,
            // which still keeps its place in the order of boundaries.
            edges[i].mask = ANY_BOUNDARY;
            continue;
        };
        let sides: [(Side, Side); 3] = std::array::from_fn(|ch| (left[ch], right[ch]));
        // Each side's pixel count is the same in every channel: what depends on it
        // alone is computed once.
        let (nl, nr) = (left[0].n, right[0].n);
        let (root_l, root_r) = ((nl as f32).sqrt(), (nr as f32).sqrt());
        let level_noise = NOISE_LINEAR * (1.0 / nl.max(1) as f32 + 1.0 / nr.max(1) as f32).sqrt();
        // Per channel: the step, its noise, and whether it can be read at all.
        let mut delta = [0f32; 3];
        let mut sigma = [0f32; 3];
        let mut wildcard = [false; 3];
        // A channel dark on one side only and clearly lit on the other has a known
        // direction even though its ratio cannot be read (a black stripe's edge), when
        // the dark side is a stripe: another boundary ends it within a stripe's width
        // or so (a shadow's edge has none).
        let mut half_dark: [Values; 3] = [0; 3];
        for ch in 0..3 {
            let (l, r) = sides[ch];
            delta[ch] = r.log - l.log;
            // Neither is near overflow: the plain root, not `hypot`'s careful one.
            let (nl, nr) = (log_noise(&l, root_l), log_noise(&r, root_r));
            sigma[ch] = (nl * nl + nr * nr).sqrt();
            if let Some((shift, var)) = surface_change(&l, &r, nl, nr) {
                // The surface's own colour changes across the boundary (a dye's hue
                // drifting), clearly more than noise: what the stripes changed is the
                // rest.
                delta[ch] -= shift;
                sigma[ch] = (sigma[ch] * sigma[ch] + var).sqrt();
            }
            let lit = |s: &Side| !s.dark && s.level >= LIT_BESIDE_DARK * DARK_LEVEL;
            if has_prev && l.dark && lit(&r) {
                half_dark[ch] = UP;
            } else if has_next && r.dark && lit(&l) {
                half_dark[ch] = DOWN;
            }
            wildcard[ch] = l.dark || r.dark || (l.clipped && r.clipped);
        }
        // The reference step: the largest significant change among readable channels,
        // preferring channels not clipped on either side, but at least the step of a
        // channel clipped on its bright side (see the function's doc).
        let significant = |ch: usize| !wildcard[ch] && delta[ch].abs() > NOISE_SIGMAS * sigma[ch];
        let clean = |ch: usize| significant(ch) && !sides[ch].0.clipped && !sides[ch].1.clipped;
        let largest_of = |pick: &dyn Fn(usize) -> bool| (0..3).filter(|&c| pick(c)).fold(0f32, |m, c| max_f32(m, delta[c].abs()));
        let mut largest = largest_of(&clean);
        if largest == 0.0 {
            largest = largest_of(&significant);
        } else {
            // Clipped on its bright side only (one side clipped on both is a wildcard).
            let bound = |ch: usize| significant(ch) && ((sides[ch].0.clipped && delta[ch] < 0.0) || (sides[ch].1.clipped && delta[ch] > 0.0));
            largest = max_f32(largest, largest_of(&bound));
        }
        // The camera's own signal must change too: the restoration rings beside strong
        // steps (a few tenths in the log, in wide stripes), and a ring between two
        // plateaus of one stripe is no boundary however the restored signal reads.
        // Compared as a ratio (at least 1), which needs no logarithm.
        let seen_ratio = (0..3).fold(1f32, |m, ch| {
            let (l, r) = sides[ch];
            if (r.level - l.level).abs() <= NOISE_SIGMAS * level_noise {
                return m;
            }
            let (a, b) = (max_f32(r.level, DARK_LEVEL), max_f32(l.level, DARK_LEVEL));
            max_f32(m, max_f32(a, b) / if a < b { a } else { b })
        });
        if seen_ratio < MIN_SEEN_STEP.exp() {
            continue;
        }
        if largest < MIN_STEP && half_dark.iter().any(|&v| v != 0) {
            largest = MIN_STEP;
        }
        if largest < MIN_STEP {
            // Too little reliable change for a boundary of this family: noise, shading,
            // or another family's boundary leaking through the restoration. Dropped, so
            // that it does not split a window of real boundaries.
            continue;
        }
        let mut values = [ANY_VALUE; 3];
        for ch in 0..3 {
            if half_dark[ch] != 0 {
                values[ch] = half_dark[ch];
                continue;
            }
            if wildcard[ch] {
                let (l, r) = sides[ch];
                if unlit[ch] && l.clipped && r.clipped && !l.dark && !r.dark {
                    values[ch] = SAME;
                }
                continue;
            }
            let (l, r) = sides[ch];
            let tol = value_tolerance * largest + NOISE_SIGMAS * sigma[ch];
            let d = delta[ch];
            let mut v: Values = 0;
            for (bit, value) in [(DOWN, -largest), (SAME, 0.0), (UP, largest)] {
                // A side clipped in this channel reads too low: the true step is at least
                // what is seen when the right side clipped, at most when the left did.
                let fits = if r.clipped {
                    value >= d - tol
                } else if l.clipped {
                    value <= d + tol
                } else {
                    (d - value).abs() <= tol
                };
                if fits {
                    v |= bit;
                }
            }
            if v == 0 {
                // Between the values (a step of about half the largest): either.
                v = if d > 0.0 { SAME | UP } else { SAME | DOWN };
            }
            values[ch] = v;
        }
        let mask = codes_of(values);
        edges[i].mask = mask;
        if mask.count_ones() == 1 {
            edges[i].code = mask.trailing_zeros() as Code;
        }
    }
}

/// Least step of the camera's gamma-encoded luma (8-bit levels) across a boundary for
/// the luma to take part in its position (see [`refine_with_luma`]).
pub const LUMA_MIN_STEP: f32 = 12.0;

/// The luma crossing's share of a refined boundary position, the rest the colour
/// gradient's (see [`refine_with_luma`]). Measured on the `webcam` rows of `eval --hard`
/// (sphere, paper, textured, occluders, colorchecker, skin, wood, paper-dye; mean
/// coverage / outliers / RMSE): colour alone 86.04 % / 0.986 % / 0.979 mm; share 0.35
/// 86.34 % / 0.850 % / 0.911 mm; 0.5 86.44 % / 0.827 % / 0.890 mm; 0.65 86.40 % /
/// 0.821 % / 0.877 mm; luma alone 86.19 % / 0.874 % / 0.878 mm. Weighting the share by
/// the luma step was worse than a fixed share. (These with the crossing interpolated
/// straight in luma; read through the luma curve, as now, 0.65 gives 86.41 % / 0.821 %
/// / 0.873 mm.)
pub const LUMA_SHARE: f32 = 0.65;

/// Linear light to the camera's gamma-encoded 8-bit level, by a table over the square
/// root of the light (where the power law is nearly straight), so that no power is
/// computed per boundary.
#[derive(Clone, Debug)]
pub struct LumaEncoder {
    /// Per step k, the level at its start and the difference to the next step's.
    table: Box<[[f32; 2]; Self::STEPS]>,
    /// One over the light of the top code (1 for a power law): the table runs over
    /// the root of the light as a share of it.
    inv_top: f32,
}

impl LumaEncoder {
    const STEPS: usize = 1024;

    /// The encoder of a camera whose 8-bit level `x` has linear light `(x / 255)^gamma`.
    pub fn new(gamma: f32) -> Self {
        let exponent = 2.0 / gamma.max(0.1);
        let level = |k: usize| 255.0 * (k as f32 / Self::STEPS as f32).powf(exponent);
        let mut table = Box::new([[0.0; 2]; Self::STEPS]);
        for (k, t) in table.iter_mut().enumerate() {
            let (a, b) = (level(k), level(k + 1));
            *t = [a, b - a];
        }
        LumaEncoder { table, inv_top: 1.0 }
    }

    /// The encoder of a camera whose 8-bit level `x` has linear light `linear[x]` (a
    /// measured [`crate::calib::CameraResponse`]'s table: non-decreasing), the light
    /// between two codes read as straight between them.
    pub fn from_table(linear: &[f32; 256]) -> Self {
        let top = linear[255].max(f32::MIN_POSITIVE);
        // The (fractional) level of light v, by a walk along the table: the steps'
        // lights increase with k, so the walk only moves forward.
        let mut code = 0usize;
        let mut level = |v: f32| {
            while code < 254 && linear[code + 1] < v {
                code += 1;
            }
            let (a, b) = (linear[code], linear[code + 1]);
            let t = if b > a { ((v - a) / (b - a)).clamp(0.0, 1.0) } else { 0.0 };
            code as f32 + t
        };
        let mut table = Box::new([[0.0; 2]; Self::STEPS]);
        let mut start = level(0.0);
        for (k, t) in table.iter_mut().enumerate() {
            let end = level(top * ((k + 1) as f32 / Self::STEPS as f32).powi(2));
            *t = [start, end - start];
            start = end;
        }
        LumaEncoder { table, inv_top: 1.0 / top }
    }

    /// The 8-bit level (not rounded) of linear light `v`, clamped to the table's range.
    #[inline]
    pub fn encode(&self, v: f32) -> f32 {
        let x = (v * self.inv_top).clamp(0.0, 1.0).sqrt() * Self::STEPS as f32;
        // Through i32: a cheaper conversion than to usize, and x is at most STEPS.
        let k = (x as i32 as usize).min(Self::STEPS - 1);
        let t = x - k as f32;
        // The step's difference is the one this took between the two levels.
        let [a, d] = self.table[k];
        a + t * d
    }

    /// [`encode`](Self::encode) of the three channels of a colour, the clamp, root,
    /// scaling and conversion in four lanes: the same arithmetic lane by lane (the
    /// clamp as `f32::clamp`'s two comparisons, the conversion saturating with NaN to
    /// 0 as `as i32`), so the same values.
    #[inline]
    pub fn encode3(&self, v: [f32; 3]) -> [f32; 3] {
        use wide::{f32x4, CmpGt, CmpLt};
        let (zero, one) = (f32x4::splat(0.0), f32x4::splat(1.0));
        let v = f32x4::new([v[0], v[1], v[2], 0.0]) * f32x4::splat(self.inv_top);
        let v = v.cmp_lt(zero).blend(zero, v);
        let v = v.cmp_gt(one).blend(one, v);
        let x = v.sqrt() * f32x4::splat(Self::STEPS as f32);
        let (k, x) = (x.trunc_int().to_array(), x.to_array());
        std::array::from_fn(|c| {
            let k = (k[c] as usize).min(Self::STEPS - 1);
            let t = x[c] - k as f32;
            let [a, d] = self.table[k];
            a + t * d
        })
    }
}

/// Points of the luma curve across an edge in [`refine_with_luma`] (an odd count, so
/// that the middle is one).
const LUMA_CURVE_POINTS: usize = 5;

/// How far across an edge (0 to 1) the luma `y` is, on the `curve` of
/// [`refine_with_luma`] (piecewise straight): the solution nearest the middle, walking
/// out from it on the side the luma lies (the curve may turn back near its ends, where
/// one channel's gamma is steepest); its end where there is none.
fn across(curve: &[f32; LUMA_CURVE_POINTS], y: f32) -> f32 {
    let mid = LUMA_CURVE_POINTS / 2;
    let rising = curve[LUMA_CURVE_POINTS - 1] > curve[0];
    let step = 1.0 / (LUMA_CURVE_POINTS - 1) as f32;
    // Where on segment k the luma is, if it is on it.
    let on = |k: usize| {
        let (a, b) = (curve[k], curve[k + 1]);
        ((a <= y && y <= b) || (b <= y && y <= a)).then(|| (k as f32 + if b != a { (y - a) / (b - a) } else { 0.5 }) * step)
    };
    if (y > curve[mid]) == rising {
        (mid..LUMA_CURVE_POINTS - 1).find_map(on).unwrap_or(1.0)
    } else {
        (0..mid).rev().find_map(on).unwrap_or(0.0)
    }
}

/// Refine each boundary of `seg` with the frame's luma, for frames whose chroma came at
/// half resolution (4:2:0 or 4:2:2, interpolated back): `colour` is that 8-bit frame,
/// `w` its width, `lut` its 8-bit to linear table and `encoder` the inverse;
/// `period` the expected stripe period in pixels.
///
/// Why: such a frame keeps every pixel's own luma, while its colour edges come from
/// chroma at half the resolution, smeared by the interpolation and by JPEG's coarser
/// chroma blocks; boundary positions from the colour gradient wander by a quarter of a
/// pixel (RMS, against 0.14 px in a full-resolution frame). Luma does not peak at a
/// colour edge (each channel's gamma moves its gradient's peak by up to half a pixel),
/// but at the edge every channel's linear light is halfway between the two stripes'
/// (the blur is symmetric), so the luma there is the luma of the two stripes' mean
/// colour. Where the frame's luma crosses that value within a pixel and a half of the
/// boundary, and the stripes' lumas differ by at least [`LUMA_MIN_STEP`], the boundary
/// moves [`LUMA_SHARE`] of the way to the crossing. The stripes' colours are the mean
/// linear light of each side, from 1.2 pixels off the boundary to the next boundary or
/// half a period; a side with a clipped pixel leaves the boundary where it is.
pub fn refine_with_luma(
    seg: &mut Segmentation,
    colour: &[[u8; 3]],
    w: usize,
    lut: &[f32; 256],
    encoder: &LumaEncoder,
    period: f32,
) {
    let Some(axis) = seg.axis else { return };
    if w == 0 {
        return;
    }
    let (_, len) = axis.lines(w, colour.len() / w);
    let half = 0.5 * period;
    // The larger and the smaller of two positions as comparisons (`f32::max` and
    // `f32::min` are calls in WebAssembly): the other where one is NaN, as those give;
    // the sign of a zero, where they might differ, does not change a side.
    let larger = |a: f32, b: f32| if a >= b || b.is_nan() { a } else { b };
    let smaller = |a: f32, b: f32| if a <= b || b.is_nan() { a } else { b };
    for (line, edges) in seg.lines.iter_mut().enumerate() {
        let (origin, stride) = match axis {
            ScanAxis::Rows => (line * w, 1),
            ScanAxis::Columns => (line, w),
        };
        let at = |s: usize| colour[origin + s * stride];
        // The mean linear light of the pixels from `a` to `b` (positions), None where
        // there are none or one is clipped.
        let side = |a: f32, b: f32| -> Option<[f32; 3]> {
            let (a, b) = (larger(a, 0.0).ceil(), smaller(b, len as f32 - 1.0).floor());
            if b < a {
                return None;
            }
            let mut sum = [0f32; 3];
            for s in a as usize..=b as usize {
                let c = at(s);
                if c.iter().any(|&v| v >= SATURATED) {
                    return None;
                }
                for (acc, &v) in sum.iter_mut().zip(&c) {
                    *acc += lut[v as usize];
                }
            }
            let k = b - a + 1.0;
            Some(sum.map(|v| v / k))
        };
        let encoded_luma = |c: [f32; 3]| luma(encoder.encode3(c));
        // The previous boundary's position before it was refined, and after.
        let (mut prev, mut prev_refined) = (f32::NEG_INFINITY, f32::NEG_INFINITY);
        for i in 0..edges.len() {
            let p = edges[i].pos;
            let next = edges.get(i + 1).map_or(f32::INFINITY, |e| e.pos);
            let before = side(larger(prev + 1.2, p - half), p - 1.2);
            let after = side(p + 1.2, smaller(next - 1.2, p + half));
            let floor = prev_refined + 0.5;
            prev = p;
            prev_refined = p;
            let (Some(before), Some(after)) = (before, after) else {
                continue;
            };
            let (ya, yb) = (encoded_luma(before), encoded_luma(after));
            if (yb - ya).abs() < LUMA_MIN_STEP {
                continue;
            }
            // The luma along the blurred edge, as a function of how far across it the
            // linear light is (0 before, 1 after), in steps of 1 / (LUMA_CURVE_POINTS
            // - 1); it must be monotonic over the middle steps to be read back.
            let mut curve = [0f32; LUMA_CURVE_POINTS];
            (curve[0], curve[LUMA_CURVE_POINTS - 1]) = (ya, yb);
            for (k, y) in curve.iter_mut().enumerate().take(LUMA_CURVE_POINTS - 1).skip(1) {
                let t = k as f32 / (LUMA_CURVE_POINTS - 1) as f32;
                *y = encoded_luma([0, 1, 2].map(|ch| before[ch] + t * (after[ch] - before[ch])));
            }
            let rising = yb > ya;
            if curve[1..LUMA_CURVE_POINTS - 1]
                .windows(2)
                .any(|p| (p[1] > p[0]) != rising)
            {
                continue;
            }
            let target = curve[LUMA_CURVE_POINTS / 2];
            // The crossing of the target nearest the boundary, between pixel centres,
            // interpolated in how far across the edge each pixel is (the luma is not
            // straight in it).
            // (A negative or NaN position converts to 0.)
            let first = (p - 1.5).floor() as usize;
            let last = ((p + 1.5).ceil() as usize).min(len - 1);
            let mut best: Option<f32> = None;
            let mut y0 = luma(at(first).map(f32::from));
            for t in first..last {
                let y1 = luma(at(t + 1).map(f32::from));
                let crosses = if rising {
                    y0 <= target && y1 > target
                } else {
                    y0 >= target && y1 < target
                };
                if crosses {
                    let (a, b) = (across(&curve, y0), across(&curve, y1));
                    let x = if b != a {
                        t as f32 + (0.5 - a) / (b - a)
                    } else {
                        t as f32 + 0.5
                    };
                    if (x - p).abs() <= 1.5 && best.is_none_or(|q| (x - p).abs() < (q - p).abs()) {
                        best = Some(x);
                    }
                }
                y0 = y1;
            }
            // Boundaries stay in order, half a pixel apart at least.
            if let Some(x) = best {
                let moved = p + LUMA_SHARE * (x - p);
                if moved > floor && moved < next - 0.5 {
                    edges[i].pos = moved;
                    prev_refined = moved;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raster::gamma_lut;

    /// One row with a red-to-green edge at `x0`, blurred in linear light (a logistic
    /// profile of spread 0.4 px, about a Gaussian of σ 0.7: any symmetric blur does)
    /// and gamma-encoded (2.2): the colours' gamma moves the luma gradient's peak off
    /// the edge, not the crossing of the mean colour's luma.
    fn edge_row(x0: f32, left: [f32; 3], right: [f32; 3]) -> Vec<[u8; 3]> {
        (0..40)
            .map(|x| {
                let t = 1.0 / (1.0 + (-(x as f32 - x0) / 0.4).exp());
                [0, 1, 2].map(|c| (255.0 * (left[c] + (right[c] - left[c]) * t).powf(1.0 / 2.2)).round() as u8)
            })
            .collect()
    }

    /// The light at `x` of stripes cycling through `palette` with boundaries at `bounds`,
    /// each blurred in linear light as in [`edge_row`].
    fn blurred_stripes(palette: &[[f32; 3]], bounds: &[f32], x: f32) -> [f32; 3] {
        blurred_stripes_by(palette, bounds, x, 0.4)
    }

    /// [`blurred_stripes`] with each boundary a logistic step of `scale` pixels.
    fn blurred_stripes_by(palette: &[[f32; 3]], bounds: &[f32], x: f32, scale: f32) -> [f32; 3] {
        [0, 1, 2].map(|c| {
            bounds.iter().enumerate().fold(palette[0][c], |v, (k, &b)| {
                let step = palette[(k + 1) % palette.len()][c] - palette[k % palette.len()][c];
                v + step / (1.0 + (-(x - b) / scale).exp())
            })
        })
    }

    /// One line of `len` pixels of [`blurred_stripes_by`]: its restored log signal (the
    /// light's log) and its linear light.
    fn stripe_line(palette: &[[f32; 3]], bounds: &[f32], len: usize, scale: f32) -> (Restored, Vec<[f32; 3]>) {
        let mut restored = Restored::new(len, 1);
        let mut linear = vec![[0f32; 3]; len];
        for (x, px) in linear.iter_mut().enumerate() {
            *px = blurred_stripes_by(palette, bounds, x as f32, scale);
            for c in 0..3 {
                restored.log[c][x] = px[c].ln();
            }
        }
        (restored, linear)
    }

    fn one_edge(pos: f32) -> Segmentation {
        let edge = Edge {
            pos,
            code: NO_CODE,
            mask: ANY_BOUNDARY,
            run: 0,
            id: -1,
            tentative: Tentative::NONE,
        };
        Segmentation { axis: Some(ScanAxis::Rows), lines: vec![vec![edge]], ..Segmentation::default() }
    }

    /// Stripes 3 pixels wide, each boundary a weak one (one channel changes) followed
    /// by a strong one (all three change), blurred in linear light: every boundary is
    /// found, within a fifth of a pixel, and nothing else.
    #[test]
    fn three_pixel_stripes_keep_their_weaker_boundaries() {
        let palette = [[1.0, 0.25, 0.25], [1.0, 1.0, 0.25], [0.25, 0.25, 1.0], [0.25, 1.0, 1.0]];
        let bounds: Vec<f32> = (0..16).map(|k| 5.3 + 3.0 * k as f32).collect();
        let len = 60;
        let (restored, linear) = stripe_line(&palette, &bounds, len, 0.4);
        let flags = vec![0; len];
        let mut seg = Segmentation::default();
        seg.run(&restored, &linear, &flags, ScanAxis::Rows, 3.0, ChromaPairs::default());
        let found: Vec<f32> = seg.lines[0].iter().map(|e| e.pos).collect();
        assert_eq!(found.len(), bounds.len(), "boundaries at {bounds:?}, edges at {found:?}");
        for (&f, &b) in found.iter().zip(&bounds) {
            assert!((f - b).abs() < 0.2, "boundaries at {bounds:?}, edges at {found:?}");
        }
    }

    /// A red stripe and a dark one, blue dim (about 0.04 of full scale) in both, rising
    /// from the red to the dark stripe by `share` of red's change in the log.
    fn red_and_dim_blue(share: f32) -> [[f32; 3]; 2] {
        let blue_step = share * (1.0f32 / 0.3).ln();
        [[1.0, 0.5, 0.037], [0.3, 0.5, 0.037 * blue_step.exp()]]
    }

    /// The blue values the masks of `edges` allow, one list per boundary, from red
    /// stripes alternating with dark ones whose blue is dim (the two tests below):
    /// `count` boundaries, each naming red's change and green unchanged.
    fn blue_values_read(edges: &[Edge], count: usize) -> Vec<Vec<i8>> {
        assert_eq!(edges.len(), count, "edges at {:?}", edges.iter().map(|e| e.pos).collect::<Vec<_>>());
        edges
            .iter()
            .enumerate()
            .map(|(k, e)| {
                let red = if k % 2 == 0 { -1 } else { 1 };
                let codes: Vec<[i8; 3]> = (0..27u8).filter(|&c| e.mask & 1 << c != 0).map(unpack).collect();
                assert!(!codes.is_empty() && codes.iter().all(|t| t[0] == red && t[1] == 0), "boundary {k}: mask {:#x}", e.mask);
                let mut blue: Vec<i8> = codes.iter().map(|t| t[2]).collect();
                blue.dedup();
                blue
            })
            .collect()
    }

    /// Every boundary of [`blue_values_read`]'s lists allows blue unchanged and blue
    /// going the way it does there (up at the even boundaries, down at the odd ones).
    fn assert_blue_allows_both(values: &[Vec<i8>], what: &str) {
        for (k, blue) in values.iter().enumerate() {
            let rise = if k % 2 == 0 { 1 } else { -1 };
            let mut both = vec![0, rise];
            both.sort();
            assert_eq!(blue, &both, "{what}, boundary {k}: blue {blue:?}");
        }
    }

    /// Red stripes alternating with dark ones whose dim blue (about 0.04 of full scale)
    /// rises and falls by 0.3 of red's change in the log: a noisy reading between
    /// "unchanged" and "changed". With full-resolution colour it reads as unchanged; in
    /// a frame whose chroma came at half resolution, where a channel the luma does not
    /// carry strays further, as either ([`SMEARED_VALUE_TOLERANCE`]). Red's reading
    /// is the same in both.
    #[test]
    fn a_noisy_channel_between_values_allows_both_only_with_subsampled_chroma() {
        let len = 52;
        let bounds: Vec<f32> = (0..6).map(|k| 4.5 + 8.0 * k as f32).collect();
        let palette = red_and_dim_blue(0.3);
        let (restored, linear) = stripe_line(&palette, &bounds, len, 0.4);
        let blue_values = |chroma: ChromaPairs| -> Vec<Vec<i8>> {
            let mut seg = Segmentation::default();
            seg.run(&restored, &linear, &vec![0; len], ScanAxis::Rows, 8.0, chroma);
            blue_values_read(&seg.lines[0], bounds.len())
        };
        for (k, blue) in blue_values(ChromaPairs::default()).iter().enumerate() {
            assert_eq!(blue, &vec![0], "full resolution, boundary {k}: blue {blue:?}");
        }
        let subsampled = ChromaPairs { horizontal: true, vertical: true };
        assert_blue_allows_both(&blue_values(subsampled), "half-resolution chroma");
    }

    /// The same kind of dim blue on a line whose boundaries are blurred over several
    /// pixels (a projector out of focus; the line reads as broad), in a frame with
    /// full-resolution colour: its blue allows both values there, while the same stripes
    /// with sharp boundaries read it as unchanged ([`SMEARED_VALUE_TOLERANCE`]).
    #[test]
    fn a_noisy_channel_between_values_allows_both_on_a_broad_line() {
        let len = 100;
        let bounds: Vec<f32> = (0..7).map(|k| 8.5 + 12.0 * k as f32).collect();
        let palette = red_and_dim_blue(0.35);
        let blue_values = |scale: f32| -> Vec<Vec<i8>> {
            let (restored, linear) = stripe_line(&palette, &bounds, len, scale);
            let mut seg = Segmentation::default();
            seg.run(&restored, &linear, &vec![0; len], ScanAxis::Rows, 12.0, ChromaPairs::default());
            assert_eq!(seg.scratch[0].shape != PeakShape::Sharp, scale > 1.0, "blur scale {scale}: line read as {:?}", seg.scratch[0].shape);
            blue_values_read(&seg.lines[0], bounds.len())
        };
        for (k, blue) in blue_values(0.4).iter().enumerate() {
            assert_eq!(blue, &vec![0], "sharp line, boundary {k}: blue {blue:?}");
        }
        assert_blue_allows_both(&blue_values(1.4), "broad line");
    }

    /// Two stripe colours that differ in red and blue only, alternating at `bounds`
    /// (sharp edges) over `len` pixels of a surface whose green albedo at `x` is
    /// `green(x)`, segmented as stripes `period` pixels wide: every boundary must be
    /// found, allow "green unchanged" (the surface's green is no stripe change) and
    /// name the red and blue changes (its mask allows green's three values at most).
    fn green_never_changes(bounds: &[f32], len: usize, period: f32, green: impl Fn(f32) -> f32) {
        let palette = [[1.0, 1.0, 0.3], [0.3, 1.0, 1.0]];
        let mut restored = Restored::new(len, 1);
        let mut linear = vec![[0f32; 3]; len];
        for (x, px) in linear.iter_mut().enumerate() {
            let albedo = [1.0, green(x as f32), 1.0];
            let light = blurred_stripes(&palette, bounds, x as f32);
            for c in 0..3 {
                px[c] = light[c] * albedo[c];
                restored.log[c][x] = px[c].ln();
            }
        }
        let mut seg = Segmentation::default();
        seg.run(&restored, &linear, &vec![0; len], ScanAxis::Rows, period, ChromaPairs::default());
        let edges = &seg.lines[0];
        assert_eq!(edges.len(), bounds.len(), "edges at {:?}", edges.iter().map(|e| e.pos).collect::<Vec<_>>());
        for (k, e) in edges.iter().enumerate() {
            let truth = if k % 2 == 0 { pack([-1, 0, 1]) } else { pack([1, 0, -1]) };
            assert!(e.mask & 1 << truth != 0, "boundary {k} at {}: mask {:#x} lacks the true code", e.pos, e.mask);
            assert!(e.mask.count_ones() <= 3, "boundary {k}: mask {:#x}", e.mask);
        }
    }

    /// An overexposed white surface: stripes 8 pixels wide alternate between white, three
    /// times what clips in every channel, and pink, whose green is under the clip; blurred
    /// in linear light, then clipped. The white stripes are clipped in every channel, yet
    /// lit: the line is one run, and every boundary says which way green went (the
    /// clipped red and blue say nothing). (Taken as unusable, as they were until
    /// 2026-12-05, the white stripes split the line into runs and left every boundary's
    /// code unread.)
    #[test]
    fn a_stripe_clipped_in_every_channel_keeps_the_line_whole_and_its_boundaries_read() {
        let bounds: Vec<f32> = (0..6).map(|k| 4.5 + 8.0 * k as f32).collect();
        let seg = segment_white_and_pink(&bounds, Segmentation::default());
        let edges = &seg.lines[0];
        assert_eq!(edges.len(), bounds.len(), "edges at {:?}", edges.iter().map(|e| e.pos).collect::<Vec<_>>());
        for (k, e) in edges.iter().enumerate() {
            assert_eq!(e.run, edges[0].run, "boundary {k} at {} starts a new run", e.pos);
            // Clipping cuts the brighter side's flank off the blurred step, so the
            // steepest change seen lies towards the unclipped side: here 1.06 pixels.
            assert!((e.pos - bounds[k]).abs() < 1.25, "boundary {k} at {}, true {}", e.pos, bounds[k]);
            // White to pink is green going down; pink to white, up.
            let green = if k % 2 == 0 { -1 } else { 1 };
            for code in 0..27u8 {
                if e.mask & 1 << code != 0 {
                    assert_eq!(unpack(code)[1], green, "boundary {k}: mask {:#x} allows green {}", e.mask, unpack(code)[1]);
                }
            }
            assert!(e.mask != 0, "boundary {k} was dropped");
        }
    }

    /// One line of white and pink stripes (pink: green at 0.2 of white) between
    /// `bounds`, exposed three times over, so red and blue clip on every stripe and
    /// white's green too, photographed (gamma 2.2, 8 bits) and segmented by `seg`
    /// with a period of 8 pixels.
    fn segment_white_and_pink(bounds: &[f32], seg: Segmentation) -> Segmentation {
        let (seg, flags) = segment_stripes(&[[3.0, 3.0, 3.0], [3.0, 0.6, 3.0]], bounds, seg);
        assert!(flags.iter().any(|&f| f & 0x07 == 0x07), "some pixels are clipped in every channel");
        seg
    }

    /// One line of stripes of the linear colours `palette` in turn between `bounds`
    /// (a colour above 1 clips), photographed (gamma 2.2, 8 bits) and segmented by
    /// `seg` with a period of 8 pixels; with the pixels' flags.
    fn segment_stripes(palette: &[[f32; 3]], bounds: &[f32], mut seg: Segmentation) -> (Segmentation, Vec<PixelFlags>) {
        let len = 52;
        let lut = gamma_lut(2.2);
        let mut linear = vec![[0f32; 3]; len];
        let mut frame = vec![[0u8; 3]; len];
        let mut restored = Restored::new(len, 1);
        for x in 0..len {
            let light = blurred_stripes(palette, bounds, x as f32);
            for c in 0..3 {
                let code = (255.0 * light[c].min(1.0).powf(1.0 / 2.2)).round() as u8;
                frame[x][c] = code;
                linear[x][c] = lut[code as usize];
                restored.log[c][x] = linear[x][c].ln();
            }
        }
        let mut flags = vec![0; len];
        assert_eq!(pixel_flags_into(&frame, &linear, None, &mut flags), len, "every pixel is lit, so usable");
        seg.run(&restored, &linear, &flags, ScanAxis::Rows, 8.0, ChromaPairs::default());
        (seg, flags)
    }

    /// Red and blue clip on both sides of every boundary of the white and pink stripes.
    /// For a pattern whose stripes leave red and blue unlit somewhere, both sides are
    /// lit stripes, so those channels are unchanged and each boundary has exactly one
    /// code (green down, then up); for a pattern whose lower level is above 0 they
    /// stay wildcards (three values each: nine codes).
    #[test]
    fn a_channel_clipped_on_both_sides_is_unchanged_where_the_pattern_leaves_it_unlit() {
        let bounds: Vec<f32> = (0..6).map(|k| 4.5 + 8.0 * k as f32).collect();
        let unlit = segment_white_and_pink(&bounds, Segmentation::for_pattern([true; 3]));
        let lit = segment_white_and_pink(&bounds, Segmentation::for_pattern([false; 3]));
        assert_eq!(unlit.lines[0].len(), bounds.len());
        assert_eq!(lit.lines[0].len(), bounds.len());
        for (k, (a, b)) in unlit.lines[0].iter().zip(&lit.lines[0]).enumerate() {
            let green = if k % 2 == 0 { -1 } else { 1 };
            assert_eq!(a.mask, 1 << pack([0, green, 0]), "boundary {k}: mask {:#x}", a.mask);
            assert_eq!(b.mask.count_ones(), 9, "boundary {k}: mask {:#x}", b.mask);
            assert!(b.mask & a.mask != 0, "boundary {k}: the wildcards leave out the code");
        }
    }

    /// Blue stripes that clip, on black stripes that hold the room's light, through a
    /// camera whose blue leaks a little into green (0.12 against 3 of blue, unclipped):
    /// green's step is the largest unclipped one, but blue's, though clipped, is larger
    /// still, so green's is a leak, not a change of the pattern's green. Each boundary
    /// has exactly one code, blue's alone; with green's step as the reference (until
    /// 2026-12-06) every code read green changing with blue.
    #[test]
    fn a_clipped_step_larger_than_every_clean_one_is_the_reference() {
        let bounds: Vec<f32> = (0..6).map(|k| 4.5 + 8.0 * k as f32).collect();
        let (seg, flags) = segment_stripes(&[[0.03, 0.04, 0.03], [0.04, 0.12, 3.0]], &bounds, Segmentation::default());
        assert!(flags.iter().any(|&f| f & 0x07 == 0x04), "blue clips, alone");
        assert_eq!(seg.lines[0].len(), bounds.len());
        for (k, e) in seg.lines[0].iter().enumerate() {
            let blue = if k % 2 == 0 { 1 } else { -1 };
            assert_eq!(e.mask, 1 << pack([0, 0, blue]), "boundary {k} at {}: mask {:#x}", e.pos, e.mask);
        }
    }

    /// A pixel whose red clips: the unmixing took too little red out of blue, so a blue
    /// below what the hidden red could have put there is unreadable (dark); a blue above
    /// it, or any channel of a pixel with nothing clipped, or a frame not unmixed, is
    /// read as it is. In a frame with half-resolution chroma, red counts from
    /// [`SUBSAMPLED_CLIP_LEVEL`].
    #[test]
    fn a_channel_within_a_clipped_channels_leak_is_unreadable() {
        // The simulated camera's mixing: 0.86 on the diagonal, 0.07 off it.
        let mix = glam::Mat3::from_cols_array(&[0.86, 0.07, 0.07, 0.07, 0.86, 0.07, 0.07, 0.07, 0.86]);
        let leak = clip_leak(&mix.inverse());
        let bound = leak[2][0];
        assert!((bound - CLIP_EXCESS * 0.0886).abs() < 1e-3, "red's leak into blue {bound}");
        let frame = [[255, 120, 40], [255, 120, 60], [200, 120, 40]];
        let linear = [[1.1, 0.2, 0.5 * bound], [1.1, 0.2, 2.0 * bound], [0.6, 0.2, 0.5 * bound]];
        let mut flags = [0; 3];
        assert_eq!(pixel_flags_into(&frame, &linear, Some((&leak, SATURATED)), &mut flags), 3);
        assert_eq!(flags[0], 0x01 | 0x20, "red clipped, blue within its leak: {:#x}", flags[0]);
        assert_eq!(flags[1], 0x01, "blue above the leak is read: {:#x}", flags[1]);
        assert_eq!(flags[2], 0x00, "nothing clipped, nothing leaks: {:#x}", flags[2]);
        pixel_flags_into(&frame, &linear, None, &mut flags);
        assert_eq!(flags[0], 0x01, "not unmixed, no leak: {:#x}", flags[0]);
        // Red at 230 after 4:2:0 and JPEG: not clipped, but it may have been in the
        // sensor, so blue within its leak is unreadable there; not in a full frame.
        let frame = [[230, 120, 40]];
        let linear = [[0.8, 0.2, 0.5 * bound]];
        let mut flags = [0; 1];
        pixel_flags_into(&frame, &linear, Some((&leak, SUBSAMPLED_CLIP_LEVEL)), &mut flags);
        assert_eq!(flags[0], 0x20, "subsampled: red not a bound, blue unreadable: {:#x}", flags[0]);
        pixel_flags_into(&frame, &linear, Some((&leak, SATURATED)), &mut flags);
        assert_eq!(flags[0], 0x00, "full colour: nothing clipped: {:#x}", flags[0]);
    }

    /// Stripes 8 pixels wide on a surface whose green fades along the line (its log
    /// falls 0.1 a pixel, 0.8 a stripe: a dye's hue drifting): the fade is taken out of
    /// each step.
    #[test]
    fn a_surface_colour_drift_is_not_read_as_a_stripe_change() {
        let bounds: Vec<f32> = (0..6).map(|k| 4.5 + 8.0 * k as f32).collect();
        green_never_changes(&bounds, 52, 8.0, |x| (-0.1 * x).exp());
    }

    /// Five samples of a Gaussian of variance 1.5 whose top lies 0.3 past the middle
    /// sample: the fit finds the top and reports the gradient's variance (twice the
    /// squared gradient's); a sample of zero gives no fit.
    #[test]
    fn a_broad_peak_is_fitted_through_five_samples() {
        let g = [-2.0f32, -1.0, 0.0, 1.0, 2.0].map(|k| (-(k - 0.3) * (k - 0.3) / 3.0).exp());
        let (offset, var) = broad_fit(g).expect("a Gaussian fits");
        assert!((offset - 0.3).abs() < 1e-4, "offset {offset}");
        assert!((var - 3.0).abs() < 1e-3, "variance {var}");
        assert!(broad_fit([0.0, g[1], g[2], g[3], g[4]]).is_none());
    }

    /// A line's exponentials, four at a time, are each sample's own (a tail shorter than
    /// four included) and do not depend on where in the line a sample is.
    #[test]
    fn a_line_s_exponentials_are_each_sample_s_own() {
        let x: Vec<f32> = (0..11).map(|k| -3.0 + 0.55 * k as f32).collect();
        let mut out = vec![f32::NAN; 11];
        exp_into(&x, &mut out);
        for (v, e) in x.iter().zip(&out) {
            assert!((e / v.exp() - 1.0).abs() < 1e-6, "exp({v}) = {e}");
        }
        let mut shifted = vec![f32::NAN; 10];
        exp_into(&x[1..], &mut shifted);
        assert_eq!(shifted[..], out[1..]);
    }

    /// A soft projector's stripes, 7.1 pixels wide, whose red steps between 0.2 and 0.6
    /// over a blur of about 2 pixels, under noise of 0.01 (deterministic): the 7-tap
    /// derivative of a soft line places the boundaries closer to their true places than
    /// the 5-tap one (RMS, over 56 boundaries).
    #[test]
    fn a_soft_line_s_boundaries_are_placed_closer_with_the_wider_derivative() {
        let bounds: Vec<f32> = (0..60).map(|k| 5.3 + 7.1 * k as f32).collect();
        let len = 440;
        let mut state = 12345u32;
        let mut uniform = || {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (state >> 8) as f32 / (1u32 << 24) as f32
        };
        let level: [Vec<f32>; 3] = std::array::from_fn(|ch| {
            (0..len)
                .map(|x| {
                    let x = x as f32;
                    let red = bounds.iter().enumerate().fold(0.2, |v, (k, &b)| {
                        let step = 0.4 / (1.0 + (-(x - b) / 1.1).exp());
                        if k % 2 == 0 { v + step } else { v - step }
                    });
                    // A Gaussian draw from two uniforms (Box-Muller).
                    let noise = 0.01 * (-2.0 * (uniform() + 1e-7).ln()).sqrt() * (std::f32::consts::TAU * uniform()).cos();
                    if ch == 0 { red + noise } else { 0.3 + noise }
                })
                .collect()
        });
        let signal: [Vec<f32>; 3] = std::array::from_fn(|ch| level[ch].iter().map(|v| v.ln()).collect());
        let light: [Vec<f32>; 3] = std::array::from_fn(|ch| {
            let mut out = vec![0.0; len];
            exp_into(&signal[ch], &mut out);
            out
        });
        let rms = |shape: PeakShape| {
            let errs: Vec<f32> = bounds[2..58]
                .iter()
                .map(|&b| {
                    let (p, offset, _) = subpixel_peak(&light, &level, None, b.round() as usize, len, shape).expect("a peak inside the line");
                    p as f32 + offset - b
                })
                .collect();
            (errs.iter().map(|e| e * e).sum::<f32>() / errs.len() as f32).sqrt()
        };
        let (broad, soft) = (rms(PeakShape::Broad), rms(PeakShape::Soft));
        eprintln!("boundaries RMS: 5-tap {broad:.3} px, 7-tap {soft:.3} px");
        assert!(soft < 0.9 * broad, "RMS soft {soft}, broad {broad}");
    }

    /// The strength of one broad step with a ripple on its slope (two maxima, as a
    /// boundary whose channels change a few pixels apart gives), beside an unusable
    /// sample (strength 0): smoothed, the step has one maximum, the unusable sample
    /// stays 0, and the sample beside it is not pulled down by it.
    #[test]
    fn smoothing_a_rippled_step_leaves_one_maximum_and_unusable_samples_alone() {
        let mut s = [0.0, 0.1, 0.3, 0.52, 0.45, 0.5, 0.3, 0.1, 0.6, 0.0, 0.6, 0.2, 0.0];
        let maxima = |s: &[f32]| (1..s.len() - 1).filter(|&i| s[i] >= s[i - 1] && s[i] > s[i + 1]).collect::<Vec<_>>();
        assert_eq!(maxima(&s[..8]), vec![3, 5], "the ripple's two maxima");
        smooth_strength(&mut s);
        assert_eq!(maxima(&s[..8]), vec![4], "one maximum: {s:?}");
        assert_eq!(s[9], 0.0, "an unusable sample stays unusable");
        assert_eq!(s[10], 0.25 * 0.6 + 0.5 * 0.6 + 0.25 * 0.2, "beside it, its own value stands in for it");
        assert_eq!((s[0], s[12]), (0.0, 0.0), "the ends are not moved");
    }

    /// A step of red from 1 to 0.05 blurred by 4 pixels (a Gaussian, as four logistic
    /// steps): the log strength peaks 3.7 pixels on the dark side, where the edge is
    /// found, and the linear-light gradient's peak is at the boundary. On a soft line
    /// the climb goes two pixels back ([`SOFT_PEAK_REACH`]) and the fit places the
    /// boundary 1.2 pixels off; one pixel of climb, on a broad line, leaves it 2.2 off.
    #[test]
    fn a_soft_line_s_edge_climbs_from_the_log_peak_to_the_linear_one() {
        let (len, b, sigma) = (60, 30.3f32, 4.0f32);
        let red: Vec<f32> = (0..len)
            .map(|x| {
                let t = (x as f32 - b) / sigma;
                1.0 - 0.95 * [-0.4f32, -0.13, 0.13, 0.4].iter().map(|o| 0.25 / (1.0 + (-(t + o) * 1.702).exp())).sum::<f32>()
            })
            .collect();
        let level: [Vec<f32>; 3] = [red, vec![0.5; len], vec![0.5; len]];
        let log: Vec<f32> = level[0].iter().map(|v| v.ln()).collect();
        let s = (1..len - 1).max_by(|&i, &j| (log[i - 1] - log[i + 1]).total_cmp(&(log[j - 1] - log[j + 1]))).unwrap_or(0);
        assert!(s as f32 - b >= 1.5, "the log strength peaks at {s}, the boundary is at {b}");
        let place = |shape: PeakShape| {
            let (p, offset, _) = subpixel_peak(&level, &level, None, s, len, shape).expect("a peak inside the line");
            p as f32 + offset
        };
        let (soft, broad) = (place(PeakShape::Soft), place(PeakShape::Broad));
        assert!((soft - b).abs() + 0.75 < (broad - b).abs(), "soft at {soft}, broad at {broad}, true {b}");
    }

    /// One boundary where red falls from three times what clips to 0.6 of it and blue
    /// rises from 0.25 to 0.8, blurred in linear light and then clipped ([`edge_row`]):
    /// the clipped red would pull the boundary towards its unclipped (right) side, by
    /// 0.38 px with its full weight; blue, clipped at neither end, places it
    /// ([`CLIPPED_WEIGHT`]).
    #[test]
    fn a_clipped_channel_leaves_the_boundary_to_an_unclipped_one() {
        let lut = gamma_lut(2.2);
        for x0 in [14.0, 14.25, 14.5, 14.75] {
            // Over 1, the 8-bit cast saturates: the camera clips.
            let frame = edge_row(x0, [3.0, 0.5, 0.25], [0.6, 0.5, 0.8]);
            let len = frame.len();
            let linear: Vec<Rgb> = frame.iter().map(|p| p.map(|v| lut[v as usize])).collect();
            let mut flags = vec![0; len];
            pixel_flags_into(&frame, &linear, None, &mut flags);
            assert!(flags[..12].iter().all(|&f| f & 1 != 0) && flags[17..].iter().all(|&f| f & 0x07 == 0), "red clipped on the left only");
            let level: [Vec<f32>; 3] = std::array::from_fn(|ch| linear.iter().map(|p| p[ch]).collect());
            let (p, offset, _) = subpixel_peak(&level, &level, Some(&flags), x0.round() as usize, len, PeakShape::Sharp).expect("a peak inside the line");
            let pos = p as f32 + offset;
            assert!((pos - x0).abs() < 0.2, "edge at {x0}, placed at {pos}");
        }
    }

    /// Stripes 40 pixels wide on a surface whose green dips smoothly (to 0.2, σ 7
    /// pixels) in the middle of every other stripe: each boundary is read from the
    /// pixels within [`PLATEAU_REACH`]. Read from the whole stripe, the dip on one side
    /// moved green's mean as a step would (four of the five boundaries read green as
    /// changing).
    #[test]
    fn a_wide_stripe_s_texture_far_from_its_boundary_is_not_read_as_a_stripe_change() {
        let bounds: Vec<f32> = (0..5).map(|k| 12.5 + 40.0 * k as f32).collect();
        let dips = [bounds[0] + 20.0, bounds[2] + 20.0, bounds[4] + 20.0];
        green_never_changes(&bounds, 186, 40.0, |x| (-dips.iter().map(|&d| 1.6 * (-(x - d).powi(2) / 98.0).exp()).sum::<f32>()).exp());
    }

    /// A soft projector's stripes: 7 pixels wide, blurred by 2 pixels (a Gaussian,
    /// as the sum of 4 logistic steps approximates it), with noise of 1 % of full
    /// light, on 200 lines. The boundaries are found within 0.13 pixels RMS (0.10);
    /// from the peak of the central difference alone (no line taken as broad) they
    /// were 0.165 off.
    #[test]
    fn a_soft_projector_s_boundaries_are_placed_within_an_eighth_of_a_pixel() {
        let (lines, width) = (200, 7.0f32);
        let bounds: Vec<f32> = (0..15).map(|k| 8.3 + width * k as f32).collect();
        let errors = soft_boundary_errors(lines, 120, &bounds);
        let n = errors.len();
        assert!(n > 14 * lines, "{n} boundaries found near the true ones");
        let rms = (errors.iter().map(|(_, e)| e * e).sum::<f32>() / n as f32).sqrt();
        assert!(rms < 0.13, "boundaries {rms:.3} px RMS from the true ones");
    }

    /// Boundaries of a soft line two or three pixels from either end are placed as
    /// well as those inside: the smoothed derivative would leave the line there, and a
    /// fit to a gradient cut off at the end leaned inwards by a pixel.
    #[test]
    fn a_soft_line_s_boundaries_beside_its_ends_are_placed_within_a_quarter_of_a_pixel() {
        let (lines, len, width) = (200, 100, 7.0f32);
        let mut bounds: Vec<f32> = (0..14).map(|k| 2.3 + width * k as f32).collect();
        bounds.push(len as f32 - 3.2);
        let errors = soft_boundary_errors(lines, len, &bounds);
        for end in [bounds[0], bounds[14]] {
            let near: Vec<f32> = errors.iter().filter(|&&(b, _)| b == end).map(|&(_, e)| e).collect();
            assert!(near.len() > lines / 2, "{} of {lines} lines found the boundary at {end}", near.len());
            let rms = (near.iter().map(|e| e * e).sum::<f32>() / near.len() as f32).sqrt();
            assert!(rms < 0.25, "the boundary at {end}: {rms:.3} px RMS from its place");
        }
    }

    /// Segments `lines` lines of `len` samples with stripes of the 8 colours (levels
    /// 0.35 and 1, each differing from the last) between `bounds`, blurred as by a soft
    /// projector (a Gaussian of 2 pixels), with noise, each line's stripes shifted by a
    /// different fraction of a pixel. Returns each edge within 2 pixels of a true
    /// boundary as that boundary (unshifted) and the edge's distance from it.
    fn soft_boundary_errors(lines: usize, len: usize, bounds: &[f32]) -> Vec<(f32, f32)> {
        let (width, sigma) = (7.0f32, 2.0f32);
        let colour = |k: usize| (k * 5 + 1) % 8;
        let level = |c: usize, ch: usize| if c >> ch & 1 != 0 { 1.0 } else { 0.35 };
        let mut restored = Restored::new(len, lines);
        let mut linear = vec![[0f32; 3]; len * lines];
        let mut state = 7u32;
        for line in 0..lines {
            let shift = line as f32 * 0.37 % 1.0;
            for x in 0..len {
                for ch in 0..3 {
                    let mut v = level(colour(0), ch);
                    for (k, &b) in bounds.iter().enumerate() {
                        let step = level(colour(k + 1), ch) - level(colour(k), ch);
                        // A Gaussian step of deviation sigma as four logistic ones.
                        let t = (x as f32 - b - shift) / sigma;
                        v += step * [-0.4f32, -0.13, 0.13, 0.4].iter().map(|o| 0.25 / (1.0 + (-(t + o) * 1.702).exp())).sum::<f32>();
                    }
                    state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                    let noise = 0.01 * ((state >> 8) as f32 / (1 << 24) as f32 - 0.5) * 3.46;
                    let v = (v + noise).max(0.01);
                    linear[line * len + x][ch] = v;
                    restored.log[ch][line * len + x] = v.ln();
                }
            }
        }
        let mut seg = Segmentation::default();
        seg.run(&restored, &linear, &vec![0; len * lines], ScanAxis::Rows, width, ChromaPairs::default());
        let mut errors = Vec::new();
        for (line, edges) in seg.lines.iter().enumerate() {
            let shift = line as f32 * 0.37 % 1.0;
            for e in edges {
                let (b, err) = bounds.iter().map(|&b| (b, e.pos - b - shift)).fold((0.0, f32::INFINITY), |m, d| if d.1.abs() < m.1.abs() { d } else { m });
                if err.abs() < 2.0 {
                    errors.push((b, err));
                }
            }
        }
        errors
    }

    /// The three-lane encoding gives `encode`'s values bit for bit, out of range and
    /// NaN included.
    #[test]
    fn luma_encoder_three_lanes_match_one() {
        let encoder = LumaEncoder::new(2.2);
        let mut values: Vec<f32> = (0..=4096).map(|k| k as f32 / 4096.0).collect();
        values.extend([-1.0, -0.0, 1.0 + f32::EPSILON, 2.0, f32::INFINITY, f32::NEG_INFINITY, f32::NAN, 0.999_999_9]);
        for w in values.windows(3) {
            let three = encoder.encode3([w[0], w[1], w[2]]);
            for (c, &v) in w.iter().enumerate() {
                assert_eq!(three[c].to_bits(), encoder.encode(v).to_bits(), "value {v}");
            }
        }
    }

    #[test]
    fn luma_encoder_inverts_the_camera_table() {
        let (lut, encoder) = (gamma_lut(2.2), LumaEncoder::new(2.2));
        for v in 0..=255u8 {
            let back = encoder.encode(lut[v as usize]);
            assert!(
                (back - v as f32).abs() < 0.1,
                "level {v} came back as {back}"
            );
        }
    }

    #[test]
    fn luma_encoder_of_a_measured_table_inverts_it_past_full_scale() {
        // A table like a shoulder's: the power law to code 200, then half again as
        // much light by the top code. Its encoder gives each code back, in one lane
        // and in four, and the power law's table gives the power law's encoder.
        let mut table = gamma_lut(2.2);
        for c in 201..256 {
            table[c] = table[200] + (c - 200) as f32 * (1.5 - table[200]) / 55.0;
        }
        let encoder = LumaEncoder::from_table(&table);
        for c in 0..=255usize {
            let back = encoder.encode(table[c]);
            assert!((back - c as f32).abs() < 0.15, "level {c} came back as {back}");
            let three = encoder.encode3([table[c], 0.0, 2.0]);
            assert_eq!(three[0].to_bits(), back.to_bits());
            assert_eq!(three[2], encoder.encode(2.0));
        }
        let (plain, from_plain) = (LumaEncoder::new(2.2), LumaEncoder::from_table(&gamma_lut(2.2)));
        for k in 0..=1000 {
            let v = k as f32 / 1000.0;
            assert!((plain.encode(v) - from_plain.encode(v)).abs() < 0.15, "light {v}");
        }
    }

    #[test]
    fn luma_moves_a_boundary_towards_the_edge_and_a_clipped_side_keeps_it() {
        let (lut, encoder) = (gamma_lut(2.2), LumaEncoder::new(2.2));
        let (x0, off) = (20.3, 0.8);
        let (red, green) = ([0.6, 0.05, 0.05], [0.05, 0.6, 0.05]);
        let row = edge_row(x0, red, green);
        let mut seg = one_edge(x0 + off);
        refine_with_luma(&mut seg, &row, row.len(), &lut, &encoder, 12.0);
        let moved = seg.lines[0][0].pos;
        // LUMA_SHARE of the way to a crossing within 0.08 px of the edge.
        let expected = x0 + off * (1.0 - LUMA_SHARE);
        assert!(
            (moved - expected).abs() < 0.05,
            "moved to {moved}, expected about {expected}"
        );
        // Green clipped on the right: the boundary stays where it was.
        let row = edge_row(x0, red, [0.05, 1.0, 0.05]);
        let mut seg = one_edge(x0 + off);
        refine_with_luma(&mut seg, &row, row.len(), &lut, &encoder, 12.0);
        assert_eq!(seg.lines[0][0].pos, x0 + off);
    }
}
