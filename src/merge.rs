//! Merging the range images of the stripe families (paper section 5: "merged into one
//! by removing erroneous points and by averaging multiple reliable points").
//!
//! Where several families measured a pixel, their depths must agree within
//! [`agree_tolerance`]; then the merged depth is their average weighted by
//! `1 / (dz/dq)²` (the least-squares point on the camera ray for the families' light
//! planes, so the family that triangulates with more of the baseline counts more).
//! Where they disagree, at least one identity is wrong and the pixel is dropped. A
//! pixel measured by one family only is kept as it is, unless its identity came from
//! its boundary's chain across lines alone and no other family's depths around it agree
//! ([`remove_unconfirmed`]), or the depths the merge kept from other families around it
//! contradict it ([`remove_contradicted`]), or it is on the rim of the
//! projector's light: on the border of the decoded region and much darker than its
//! decoded neighbours ([`remove_rim`]; the lens blur carries the stripes about a pixel
//! into shadows), or with under half the light of its neighbour along the stripe
//! ([`remove_half_lit`]: lit over less than half its area, it may be centred on an
//! occluder in front). Where the families disagree over a connected region, the one whose
//! depths agree with the decoded pixels around it settles it ([`resolve_disputes`]).
//! Finally points without enough support from their neighbours are
//! removed (an isolated depth is almost always a wrong identity).

use crate::num::max_f32;

/// Two depths (mm) of one pixel agree within max(2 mm, 0.4 % of the depth): about a
/// sixth of a stripe on the demo rig, far above the measurement noise and far below
/// the error of a wrong stripe identity (a whole stripe).
pub fn agree_tolerance(z: f32) -> f32 {
    crate::num::max_f32(0.004 * z, 2.0)
}

/// Neighbouring pixels (mm) belong to one surface within max(4 mm, 1 % of the depth),
/// which allows surfaces slanted up to about 75 degrees at the demo rig's resolution.
pub fn neighbour_tolerance(z: f32) -> f32 {
    crate::num::max_f32(0.01 * z, 4.0)
}

/// How far, pixels (in x and in y), [`remove_unconfirmed`] looks for the other families'
/// depths that vouch for a pixel whose boundary only its chain labelled.
pub const CONFIRM_REACH: usize = 4;

/// How many of the other families' depths within [`CONFIRM_REACH`] must agree with such
/// a pixel (within [`agree_tolerance`]), none differing by more than
/// [`neighbour_tolerance`], for it to stay ([`remove_unconfirmed`]).
pub const CONFIRM_COUNT: usize = 5;

/// How far, pixels (in x and in y), [`remove_unconfirmed`] looks when none of the other
/// families' depths within [`CONFIRM_REACH`] agrees with the pixel or contradicts it
/// (all of them missing, or between the two tolerances). In the bag's near-black
/// blotches and on saturated dyes a family often decodes a patch where the other
/// decodes nothing for several pixels around: such a pixel had no evidence either way
/// and went. Measured on the `default`, `webcam`, `world` and `wide` rows of occluders,
/// wood, textured, paper, sphere, bag, colorchecker, skin and paper-dye (`eval --hard`),
/// mean coverage / outliers: 89.758 % / 0.3589 % without the further look; looking out
/// to 8 px 89.936 % / 0.3672 %, to 12 px 89.992 % / 0.3650 % (bag +1.7 to +2.1 points,
/// its outliers 0.14-0.27 % -> 0.16-0.36 %), to 16 px 89.964 % / 0.3653 %; out to 12 px
/// wherever nothing was decoded within 4 px (the depths between the tolerances not
/// counting as evidence) 89.983 % / 0.3672 %.
pub const CONFIRM_FAR_REACH: usize = 12;

/// Remove the pixels of family k listed in `weak[k]` (those whose stripe coordinate
/// comes from a boundary labelled by its chain across lines alone,
/// [`crate::decode::Decoder::weak`]) that the merge kept with family k alone and that
/// no other family vouches for: fewer than [`CONFIRM_COUNT`] of the other families'
/// depths (`family_depth`, each family's own map before the merge) within
/// [`CONFIRM_REACH`] agree with them, or one of those contradicts them; where none
/// within that reach agrees or contradicts, those within [`CONFIRM_FAR_REACH`] judge.
/// Where a patch of dye ends on a stripe boundary, a chain can take a wrong identity
/// with the votes of every line along it; another family, whose stripes cross that
/// edge, rarely makes the same mistake at the same depth, and a wrong identity is a
/// whole stripe off the surface the other family measures around it.
///
/// Why around the pixel and not only at it: on a saturated dye each family reads its
/// own few boundaries, so the families' decoded pixels lie side by side more often than
/// on top of each other (on `bag`, about 24 000 pixels decoded by one family alone, 94 % of
/// them right, went for want of the other at the same pixel). Measured on the
/// `default`, `webcam`, `wide`, `clipped` and `world` rows of sphere, occluders,
/// textured, paper, wood, colorchecker, bag, skin and paper-dye (`eval --hard`), mean
/// coverage / outliers: confirmed only at the pixel 87.15 % / 0.356 %; within 2 px, one
/// agreeing (a depth that differs by more than the agreement but within the neighbour
/// tolerance neither counts nor contradicts) 88.32 % / 0.372 %; within 3 px, 3 agreeing
/// 88.47 % / 0.374 %; within 4 px, 3 agreeing 88.56 % / 0.378 %, 5 agreeing 88.50 % /
/// 0.376 % (bag and paper-dye/world met), 8 agreeing 88.42 % / 0.371 %; within 4 px, 3
/// agreeing among the other family's pixels that are not weak themselves 88.02 % /
/// 0.370 %. Agreement within the neighbour tolerance (within 2 px) kept a few hundred
/// more pixels on each of bag, paper-dye/webcam, colorchecker/wide and textured/webcam,
/// with 55 to 130 more outliers each. Keeping the labels of chains whose vote led by
/// over 200 bits without any confirmation gave 88.07 % / 0.386 %.
///
/// Tried on 2026-12-07 and not kept: the family's own depths that its lines identified
/// (not weak) vouching too, over 35 rows (`default`, `webcam`, `wide`, `world` and
/// `clipped` of sphere-dye, bag, colorchecker, skin, wood, paper-dye and occluders):
/// mean coverage 87.48 -> 87.93 %, outliers 0.318 -> 0.343 % (bag 66.6 -> 68.1 % with
/// 0.12 -> 0.14 %, colorchecker/wide 0.46 -> 0.49 %), about one pixel in twenty of those
/// it kept wrong. Under 25-pixel stripes this test takes the most (skin/wide: 91.95 %
/// with it, 93.93 % without, at 0.24 -> 0.33 % outliers); looking out to 0.6 of the
/// stripe period there (every fourth pixel) kept only 91.95 -> 92.29 %.
pub fn remove_unconfirmed<D: AsRef<[f32]>>(depth: &mut [f32], families: &mut [u8], weak: &[&[u32]], family_depth: &[D], width: usize, height: usize) {
    if depth.len() != width * height || families.len() != depth.len() || family_depth.iter().any(|d| d.as_ref().len() != depth.len()) {
        return;
    }
    for (k, list) in weak.iter().enumerate() {
        for &i in list.iter() {
            let i = i as usize;
            if families.get(i) != Some(&(1u8 << k)) {
                continue;
            }
            let at = (i % width, i / width);
            let mut evidence = Confirmation::around(family_depth, k, depth[i], at, CONFIRM_REACH, (width, height));
            if evidence.agreeing == 0 && !evidence.contradicted {
                evidence = Confirmation::around(family_depth, k, depth[i], at, CONFIRM_FAR_REACH, (width, height));
            }
            if evidence.contradicted || evidence.agreeing < CONFIRM_COUNT {
                depth[i] = f32::NAN;
                families[i] = 0;
            }
        }
    }
}

/// What the other families' depths around a pixel say of its depth (see
/// [`remove_unconfirmed`]).
struct Confirmation {
    /// How many agree with it (within [`agree_tolerance`]).
    agreeing: usize,
    /// Whether one differs by more than [`neighbour_tolerance`] (the count stops there).
    contradicted: bool,
}

impl Confirmation {
    /// The depths of the families other than `k` within `reach` (in x and in y) of the
    /// pixel at `(x, y)` against its depth `z`.
    fn around<D: AsRef<[f32]>>(family_depth: &[D], k: usize, z: f32, (x, y): (usize, usize), reach: usize, (width, height): (usize, usize)) -> Self {
        let (agree, contradict) = (agree_tolerance(z), neighbour_tolerance(z));
        let (xs, ys) = (x.saturating_sub(reach)..(x + reach + 1).min(width), y.saturating_sub(reach)..(y + reach + 1).min(height));
        let mut agreeing = 0;
        for (j, other) in family_depth.iter().enumerate() {
            if j == k {
                continue;
            }
            let other = other.as_ref();
            for row in ys.clone() {
                // A NaN (no depth) neither agrees nor contradicts.
                for &o in &other[row * width + xs.start..row * width + xs.end] {
                    let d = (o - z).abs();
                    if d <= agree {
                        agreeing += 1;
                    } else if d > contradict {
                        return Confirmation { agreeing, contradicted: true };
                    }
                }
            }
        }
        Confirmation { agreeing, contradicted: false }
    }
}

/// How far, pixels (in x and in y), [`remove_contradicted`] looks around a pixel that
/// one family measured alone for the merged depths of the other families.
pub const CONTRADICT_REACH: usize = 2;

/// How many of the other families' merged depths within [`CONTRADICT_REACH`] must
/// contradict a pixel one family measured alone (differ by more than
/// [`CONTRADICT_FACTOR`] times [`agree_tolerance`]), none agreeing, for
/// [`remove_contradicted`] to remove it.
pub const CONTRADICT_COUNT: usize = 2;

/// How far, in [`agree_tolerance`]s, a depth must differ from a pixel one family
/// measured alone to contradict it ([`remove_contradicted`]); between one and this it
/// neither agrees nor contradicts.
pub const CONTRADICT_FACTOR: f32 = 2.0;

/// Remove the pixels that one family measured alone where the depths the merge kept
/// from the other families around them contradict them: at least [`CONTRADICT_COUNT`]
/// of those within [`CONTRADICT_REACH`] differ by more than [`CONTRADICT_FACTOR`]
/// times [`agree_tolerance`], and none agrees. `drop` is scratch.
///
/// A pixel two families measured is checked by their agreement; one measured alone was
/// kept as it was, and that is where most wrong depths stay. Under a soft projector
/// (`soft`, `paper`), 1 904 of the 2 928 outliers came from the 49 700 pixels that one
/// family measured alone (3.8 % of them wrong, against 0.5 % of the 194 400 that both
/// did), most of them 4 to 10 mm off: a boundary placed two or three projector pixels
/// wrong. Only depths the merge kept count as the other side: a family's own map still
/// holds its wrong identities (wood's grain read as boundaries), which the merge
/// removed.
///
/// Over the `soft` and `default` rows of paper, wood, occluders, textured, colorchecker
/// and skin (`eval --hard`), mean coverage / outliers: 91.883 % / 0.427 % without;
/// 91.850 % / 0.405 % as built. Contradicting beyond one agreement tolerance, 3 of 5x5:
/// 91.767 % / 0.367 % (textured/soft met); 2 of 5x5 91.717 % / 0.355 %; 3 of 7x7
/// 91.658 % / 0.353 %; 1 of 3x3 91.758 % / 0.378 %; each family's own map as the other
/// side 90.725 % / 0.323 % (wood/default missed, 96.2 % -> 93.1 %). Those took correct
/// pixels too: on the blotchy texture of `eval` (two directions, seeds 1 to 3) 629 of
/// loggrad's 768 451 and 191 of direct's 753 242 (3 of 5x5), which took loggrad's lead
/// there from 2.02 % to 1.96 %, under the 2 % that `tests/scan.rs` holds it to; beyond
/// 1.5 tolerances, 1.99 %; beyond 2 with 3 of 5x5 91.875 % / 0.413 %, with 3 of 7x7
/// 91.817 % / 0.393 % but 1.99 % again.
pub fn remove_contradicted(depth: &mut [f32], families: &mut [u8], width: usize, height: usize, drop: &mut Vec<u32>) {
    if depth.len() != width * height || families.len() != depth.len() {
        return;
    }
    let r = CONTRADICT_REACH;
    drop.clear();
    for (i, (&z, &own)) in depth.iter().zip(families.iter()).enumerate() {
        if own.count_ones() != 1 {
            continue;
        }
        let agree = agree_tolerance(z);
        let contradict = CONTRADICT_FACTOR * agree;
        let (x, y) = (i % width, i / width);
        let xs = x.saturating_sub(r)..(x + r + 1).min(width);
        let mut contradicting = 0;
        let mut agreed = false;
        'rows: for row in y.saturating_sub(r)..(y + r + 1).min(height) {
            let span = row * width + xs.start..row * width + xs.end;
            for (&o, &f) in depth[span.clone()].iter().zip(&families[span]) {
                // Depths with a family other than this pixel's (NaN ones have none).
                if f & !own == 0 {
                    continue;
                }
                let d = (o - z).abs();
                if d <= agree {
                    agreed = true;
                    break 'rows;
                }
                if d > contradict {
                    contradicting += 1;
                }
            }
        }
        if !agreed && contradicting >= CONTRADICT_COUNT {
            drop.push(i as u32);
        }
    }
    for &i in drop.iter() {
        depth[i as usize] = f32::NAN;
        families[i as usize] = 0;
    }
}

/// Of the 8 neighbours, at least this many must be on the same surface.
pub const MIN_SUPPORT: usize = 3;

/// Merge per-family depth maps (NaN = none) with their weights into `out`, and the
/// bit mask of contributing families into `families`. An empty weight plane weighs
/// every pixel 1 (a single family needs none).
pub fn merge_into<D: AsRef<[f32]>>(depths: &[D], weights: &[Vec<f32>], out: &mut [f32], families: &mut [u8]) {
    if let ([a, b], [wa, wb]) = (depths, weights) {
        let (a, b) = (a.as_ref(), b.as_ref());
        if [a.len(), b.len(), wa.len(), wb.len(), families.len()].iter().all(|&n| n == out.len()) {
            merge_two(a, b, wa, wb, out, families);
            return;
        }
    }
    for i in 0..out.len() {
        let (mut sum, mut wsum, mut mask) = (0.0f64, 0.0f64, 0u8);
        for (k, (d, w)) in depths.iter().zip(weights).enumerate() {
            let z = d.as_ref()[i];
            if z.is_nan() {
                continue;
            }
            let w = w.get(i).map_or(1.0, |&w| w as f64);
            sum += z as f64 * w;
            wsum += w;
            mask |= 1 << k;
        }
        families[i] = 0;
        out[i] = f32::NAN;
        if mask == 0 || wsum <= 0.0 {
            continue;
        }
        let z = (sum / wsum) as f32;
        let tol = agree_tolerance(z);
        if depths.iter().any(|d| { let d = d.as_ref()[i]; !d.is_nan() && (d - z).abs() > tol }) {
            continue;
        }
        out[i] = z;
        families[i] = mask;
    }
}

/// [`merge_into`] of two weighted families, one pass over planes of one length (the
/// common case, with the same results).
fn merge_two(a: &[f32], b: &[f32], wa: &[f32], wb: &[f32], out: &mut [f32], families: &mut [u8]) {
    for (((o, f), (&za, &zb)), (&wa, &wb)) in out.iter_mut().zip(families.iter_mut()).zip(a.iter().zip(b)).zip(wa.iter().zip(wb)) {
        (*o, *f) = match (za.is_nan(), zb.is_nan()) {
            (true, true) => (f32::NAN, 0),
            (false, true) => if wa > 0.0 { (za, 1) } else { (f32::NAN, 0) },
            (true, false) => if wb > 0.0 { (zb, 2) } else { (f32::NAN, 0) },
            (false, false) => {
                let wsum = wa as f64 + wb as f64;
                let z = ((za as f64 * wa as f64 + zb as f64 * wb as f64) / wsum) as f32;
                let tol = agree_tolerance(z);
                if wsum > 0.0 && (za - z).abs() <= tol && (zb - z).abs() <= tol { (z, 3) } else { (f32::NAN, 0) }
            }
        };
    }
}

/// Share of the border of a disputed region ([`resolve_disputes`]) that one family's
/// depths must agree with for it to settle the region. Over 16 rows of the hard
/// evaluation (sphere, paper, textured, occluders, colorchecker, skin, wood,
/// paper-dye; default and webcam), mean coverage / outliers, with a border of the
/// pixels where the families agreed: nothing settled 90.11 % / 0.510 %; 0.5 with rivals
/// at most 0.15 of the border 90.79 % / 0.526 %, at most 0.05 90.64 % / 0.519 %; 0.65
/// and 0.05 90.61 % / 0.517 %. With the pixels one family measured alone in the border
/// too (kept), 0.5 and 0.05: 90.66 % / 0.510 %. Agreement within 0.3 % of the
/// depth instead of the merge's 0.4 % gave 90.63 % / 0.522 %; within
/// [`neighbour_tolerance`] both families agree with most borders (the wrong family is
/// often off by less than 1 %), and one settled pixel at a time, spreading from
/// neighbour to neighbour, let the near surface flood across occluding edges (paper,
/// default: 0.30 to 0.54 % outliers).
pub const RESOLVE_SHARE: f32 = 0.5;

/// Largest share of the border of a disputed region that any other family's depths may
/// agree with for the region to be settled ([`RESOLVE_SHARE`]). The wrong family is
/// often off by less than 1 % of the depth, so it agrees with a few of the border's
/// pixels by chance: on wood under clipping 1427 pixels in 82 regions stayed empty
/// where the settling family agreed with 60-90 % of the border and the other with 5-15 %
/// (the first family was right on 1319 of them). Over 45 rows of the hard evaluation
/// (sphere, paper, textured, occluders, colorchecker, skin, wood, paper-dye, bag;
/// default, webcam, clipped, world, wide), mean coverage / outliers: at 0.05 86.962 % /
/// 0.361 %; 0.1 87.076 % / 0.366 % (wood/clipped 94.3 to 94.5 %, paper/wide 89.7 to
/// 91.2 %); 0.15 87.149 % / 0.372 %; or with the settling family agreeing with six
/// times the rivals' share instead, 87.136 % / 0.368 %.
pub const RESOLVE_RIVAL_SHARE: f32 = 0.1;

/// Fewest pairs of a disputed pixel and a decoded neighbour around a region for it to
/// be settled.
pub const RESOLVE_MIN_BORDER: usize = 3;

/// Settle the regions where the families disagree (the merge left them empty though two
/// or more measured them) by the decoded pixels around them. A connected region
/// (8-neighbours) of disputed pixels takes the depths of the one family that agrees
/// ([`agree_tolerance`]) with at least [`RESOLVE_SHARE`] of its border (the pairs of a
/// disputed pixel and a decoded neighbour outside the region: where the families
/// agreed, or one measured alone) while every other family agrees with at most
/// [`RESOLVE_RIVAL_SHARE`] of it; other regions stay empty.
///
/// Where wood's grain runs along one family's stripes, that family reads the grain's
/// edges as boundaries, and its depths there are off by a few millimetres to a stripe
/// in patches that the other family measures continuously with the plank around them
/// (wood, default: 10 745 lit pixels that one family had right were left empty by the
/// merge). Along an occluding edge parallel to one family's stripes that family can
/// continue the near surface onto the far one; the far surface's pixels then split the
/// border and the region stays empty. With only the agreeing pixels as the border,
/// regions on a plank that the wrong family leaves sparse had too little border to be
/// settled (wood, default: 94.5 % coverage against 95.1 %), and some regions were
/// settled wrongly that the wider border leaves empty (paper, webcam: 0.93 % outliers
/// against 0.86 %). `queue` is scratch. Returns how many pixels were settled.
///
/// Tried on 2026-12-07 and not kept: leaving out of the border the extensions
/// ([`remove_disputed_extensions`]) that the merge kept from one family alone, as
/// guesses. Over the 60 `soft`, `default`, `webcam`, `world` and `wide` rows of `eval
/// --hard`, mean coverage 89.632 % -> 89.635 %, outliers 0.3715 % -> 0.3707 %: within
/// noise. The region it was meant for (paper-dye/wide, 1865 pixels by the frame's left
/// edge that family 1 has right and family 0 two stripes off) stays empty: the 58 of
/// its 508 border pairs that agree with family 0 (450 agree with family 1) are family
/// 0's own interpolated pixels beside it, where family 1 has nothing.
pub fn resolve_disputes<D: AsRef<[f32]>>(depths: &[D], depth: &mut [f32], families: &mut [u8], width: usize, height: usize, queue: &mut Vec<u32>) -> usize {
    queue.clear();
    let n = width * height;
    let nf = depths.len();
    if !(2..=3).contains(&nf) || depth.len() != n || families.len() != n || depths.iter().any(|d| d.as_ref().len() != n) {
        return 0;
    }
    let disputed = |i: usize| depths.iter().filter(|d| !d.as_ref()[i].is_nan()).count() >= 2;
    // Bit 7 of `families` marks a pixel already put in a region, until the end.
    const SEEN: u8 = 1 << 7;
    let neighbours = |i: usize| {
        let (x, y) = (i % width, i / width);
        (y.saturating_sub(1)..(y + 2).min(height)).flat_map(move |yy| (x.saturating_sub(1)..(x + 2).min(width)).map(move |xx| yy * width + xx)).filter(move |&j| j != i)
    };
    let mut settled = 0;
    for seed in 0..n {
        if families[seed] != 0 || !depth[seed].is_nan() || !disputed(seed) {
            continue;
        }
        // The region: the disputed pixels connected to the seed, with each family's
        // agreement with its border.
        queue.clear();
        queue.push(seed as u32);
        families[seed] = SEEN;
        let (mut border, mut agree) = (0usize, [0usize; 3]);
        let mut head = 0;
        while let Some(&i) = queue.get(head) {
            let i = i as usize;
            head += 1;
            for j in neighbours(i) {
                let f = families[j];
                if f != 0 && f & SEEN == 0 {
                    border += 1;
                    for (a, d) in agree.iter_mut().zip(depths) {
                        let z = d.as_ref()[i];
                        if (z - depth[j]).abs() <= agree_tolerance(z) {
                            *a += 1;
                        }
                    }
                } else if f == 0 && depth[j].is_nan() && disputed(j) {
                    families[j] = SEEN;
                    queue.push(j as u32);
                }
            }
        }
        if border < RESOLVE_MIN_BORDER {
            continue;
        }
        let (need, rival) = (RESOLVE_SHARE * border as f32, RESOLVE_RIVAL_SHARE * border as f32);
        let Some(k) = (0..nf).find(|&k| agree[k] as f32 >= need) else { continue };
        if (0..nf).any(|o| o != k && agree[o] as f32 > rival) {
            continue;
        }
        for &i in queue.iter() {
            let z = depths[k].as_ref()[i as usize];
            if !z.is_nan() {
                depth[i as usize] = z;
                families[i as usize] = SEEN | 1 << k;
                settled += 1;
            }
        }
    }
    for f in families.iter_mut() {
        *f &= !SEEN;
    }
    settled
}

/// A pixel's light: the sum of its linear channels (below zero, none).
fn light(p: [f32; 3]) -> f32 {
    p.iter().map(|&v| v.max(0.0)).sum()
}

/// Empty the merged pixels `list` (no depth, no family); returns how many there were.
fn clear_pixels(depth: &mut [f32], families: &mut [u8], list: &[u32]) -> usize {
    for &i in list {
        depth[i as usize] = f32::NAN;
        families[i as usize] = 0;
    }
    list.len()
}

/// Share of the light of the brightest decoded pixel nearby (within [`RIM_REACH`])
/// under which a pixel on the border of the decoded region, measured by one family, is
/// taken for the rim of the projector's light: the lens blur carries the stripes about
/// a pixel past the edge of a shadow or of the light, where they can be decoded though
/// no projector light reaches the surface seen there. Measured on the occluders scene
/// (`eval --hard`, default condition): such pixels got 0.1-0.3 of the light of their
/// brightest decoded neighbour (1349 of 1446), and nearly all lit pixels on the border
/// 0.4 or more (24 of 5622 under 0.3). Over 18 rows of the hard evaluation (sphere,
/// paper, textured, occluders, colorchecker, wood; default, webcam, world), mean
/// coverage / outliers: without 89.67 % / 0.578 %, at 0.2 89.64 % / 0.536 %, 0.25
/// 89.62 % / 0.486 %, 0.3 89.57 % / 0.441 %, 0.35 89.52 % / 0.418 %.
pub const RIM_SHARE: f32 = 0.3;

/// How far, pixels (in x and in y), the brightest decoded neighbour of a rim pixel is
/// looked for.
pub const RIM_REACH: usize = 2;

/// Remove the rim of the projector's light from the merged depth: pixels measured by
/// one family (`families`, the bit mask of [`merge_into`]), next to a pixel without a
/// depth (4-neighbours), whose light (the sum of the linear channels of `linear`) is
/// under [`RIM_SHARE`] of the brightest pixel with a depth within [`RIM_REACH`]. All
/// are judged on the depths as they were before any was removed (`rim` keeps the
/// pixels to remove); returns how many were.
pub fn remove_rim(depth: &mut [f32], families: &mut [u8], linear: &[[f32; 3]], width: usize, height: usize, rim: &mut Vec<u32>) -> usize {
    rim.clear();
    if depth.len() != width * height || families.len() != depth.len() || linear.len() != depth.len() {
        return 0;
    }
    let light_at = |i: usize| light(linear[i]);
    for y in 0..height {
        for x in 0..width {
            let i = y * width + x;
            if depth[i].is_nan() || families[i].count_ones() != 1 {
                continue;
            }
            let open = (x > 0 && depth[i - 1].is_nan())
                || (x + 1 < width && depth[i + 1].is_nan())
                || (y > 0 && depth[i - width].is_nan())
                || (y + 1 < height && depth[i + width].is_nan());
            if !open {
                continue;
            }
            let mut brightest = 0.0f32;
            for yy in y.saturating_sub(RIM_REACH)..(y + RIM_REACH + 1).min(height) {
                for xx in x.saturating_sub(RIM_REACH)..(x + RIM_REACH + 1).min(width) {
                    let j = yy * width + xx;
                    if !depth[j].is_nan() {
                        brightest = max_f32(brightest, light_at(j));
                    }
                }
            }
            if light_at(i) < RIM_SHARE * brightest {
                rim.push(i as u32);
            }
        }
    }
    clear_pixels(depth, families, rim)
}

/// Share of the light of its neighbour along the stripe under which a pixel on the
/// border of the decoded region, measured by one family, is taken to be lit over less
/// than half its area ([`remove_half_lit`]). Along a stripe of one family only the other
/// families' stripes change the projector's light (the pattern is their product), so
/// between two neighbours that no other family's boundary separates it is the same,
/// and a pixel with under half its neighbour's light (the room's light adds to both)
/// gets under half of the projector's: its centre most likely sees something the
/// projector does not light, while its depth is the lit part's. (Across another
/// family's boundary a fully lit pixel can have under half its neighbour's light too,
/// down to a quarter with the default palette's low level; that and a dark patch's
/// blurred border are the correct pixels the test loses.) Where that is an
/// occluder's silhouette (the unlit side nearer than the lit surface behind it) the
/// depth at the pixel's centre is the occluder's, and the decoded one off by the depth
/// step. Measured on the 96 VGA rows of the hard evaluation (`eval --hard`, every
/// condition but `8mp`; mean coverage / outliers over the rows): without the test
/// 88.468 % / 0.355 %; at 0.5 88.456 % / 0.330 %; at 0.55 88.439 % / 0.325 %; at 0.7
/// 88.282 % / 0.305 % (it takes the blurred border of a dark patch, the ColorChecker's
/// and the wood's, for a half-lit pixel). Estimating the lit share with the pixel beyond
/// as the unlit level, `(l - l_out) / (l_in - l_out)`, removed three to four times as
/// many correct pixels for the same outliers on 15 rows of the plane, sphere, wood,
/// ColorChecker and occluders (an albedo edge's blur looks the same). The room's light
/// lifts a half-lit pixel over half of its neighbour's light: occluders/world keeps
/// most of its silhouette's pixels (0.63 % to 0.62 % outliers; 0.46 % at 0.6).
///
/// Tried on 2026-12-05 and not kept: the share with the room's light taken off,
/// `(l - l_out) / (l_in - l_out)` with `l_out` the undecoded pixel beyond, where that
/// pixel's colour does not change from 3 pixels either side across the stripes (an
/// unlit surface shows no stripes; the log-ratio of a channel beyond that of the light
/// under 0.2). On 24 rows (occluders, colorchecker, wood, plane, sphere, skin x
/// default, partial, world, webcam) occluders/world went from 0.55 % to 0.49 % outliers,
/// but mean coverage fell 95.375 % -> 95.312 % for outliers 0.174 % -> 0.160 %: per
/// outlier removed, 0.5 correct pixels on occluders/world, 5 on wood/webcam and 30 on
/// colorchecker/default. Most of occluders/world's silhouette stayed, the pixel beyond
/// failing the colour test (under 4:2:0 it shares its chroma with the half-lit pixel,
/// a likely cause); without the colour test the silhouette went (0.36 %), at 5-25
/// correct pixels per outlier elsewhere. Tried again on 2026-12-06 with the room's
/// light taken off only where the pixel beyond is darker than this one and than half
/// the lit neighbour (no colour test): occluders/world 0.55 % -> 0.40 % outliers, but
/// over 24 rows (`eval --hard --conditions default,webcam,world,wide --scenes wood,
/// colorchecker,bag,skin,paper-dye,occluders`) mean coverage 86.80 -> 86.69 % for
/// outliers 0.400 -> 0.374 %, about 4.5 correct pixels per outlier (3.4 on the 12
/// `clipped` and `world` rows of colorchecker, wood, skin, bag, sphere and paper-dye):
/// not kept either.
pub const HALF_LIT_SHARE: f32 = 0.5;

/// Remove the pixels lit over less than half their area from the merged depth: pixels
/// measured by one family (`families`, the bit mask of [`merge_into`]) with no depth
/// on one side along the family's stripes and a depth on the other, whose light (the
/// sum of the linear channels of `linear`) is under [`HALF_LIT_SHARE`] of that
/// neighbour's. Bit k of `stripes_along_rows` is set where family k's stripes run
/// closer to the image rows than to the columns (its scan lines are columns), so
/// its neighbours along the stripes are left and right; otherwise above and below.
/// All are judged on the depths as they were before any was removed (`removed` keeps
/// the pixels to remove); returns how many were.
pub fn remove_half_lit(depth: &mut [f32], families: &mut [u8], linear: &[[f32; 3]], width: usize, height: usize, stripes_along_rows: u8, removed: &mut Vec<u32>) -> usize {
    removed.clear();
    if depth.len() != width * height || families.len() != depth.len() || linear.len() != depth.len() {
        return 0;
    }
    let light_at = |i: usize| light(linear[i]);
    for y in 1..height.saturating_sub(1) {
        for x in 1..width.saturating_sub(1) {
            let i = y * width + x;
            let family = families[i];
            if depth[i].is_nan() || family.count_ones() != 1 {
                continue;
            }
            let step = if stripes_along_rows & family != 0 { 1 } else { width };
            let inside = match (depth[i - step].is_nan(), depth[i + step].is_nan()) {
                (true, false) => i + step,
                (false, true) => i - step,
                _ => continue,
            };
            if light_at(i) < HALF_LIT_SHARE * light_at(inside) {
                removed.push(i as u32);
            }
        }
    }
    clear_pixels(depth, families, removed)
}

/// How far, pixels (in x and in y), [`remove_disputed_extensions`] looks for a depth
/// that contradicts an extended pixel. Over 8 rows of the hard evaluation (occluders,
/// colorchecker, wood, skin; default and webcam), mean coverage / outliers: without the
/// extension 89.2 % / 0.433 %; extended, and then nothing removed 91.1 % / 0.509 %,
/// within 2 px 90.8 % / 0.448 %, within 3 px 90.5 % / 0.420 %.
pub const DISPUTE_REACH: usize = 3;

/// Remove the merged depths that some family's decoder only extended into
/// (`extended[k]`: the pixels of family k's [`crate::decode::Decoder::extended`],
/// judged where the merge kept family k alone) and that a depth within [`DISPUTE_REACH`]
/// contradicts (they differ by more than [`neighbour_tolerance`]): an extension past
/// an occluding edge that showed no change takes the near surface's coordinate onto
/// the far one (or the other way). An extended pixel that another family measured
/// too, in agreement (the merge kept both), is confirmed and stays: beside an
/// occluding edge the surface beyond is always within reach, and without that
/// exception the extensions on the near side of the edge went with the wrong ones.
/// On the occluders scene (`eval`, two directions) keeping them took the coverage of
/// the band around depth edges from 80.9 to 86.9 % with `loggrad` and from 82.6 to
/// 90.3 % with `direct`. That includes pixels both families extended into: two
/// extensions that agree looked as if they could be one mistake made twice (both
/// continuing the near surface across the edge), but measured they are not (keeping
/// them gave 773 more correct pixels for 12 more outliers with `loggrad`, 1001 for 13
/// with `direct`). All are judged on the depths as they were before any was removed
/// (`removed` keeps the pixels to remove); returns how many were.
pub fn remove_disputed_extensions(depth: &mut [f32], families: &mut [u8], extended: &[&[u32]], width: usize, height: usize, removed: &mut Vec<u32>) -> usize {
    removed.clear();
    if depth.len() != width * height || families.len() != depth.len() {
        return 0;
    }
    let r = DISPUTE_REACH;
    for (k, pixels) in extended.iter().enumerate() {
        for &i in pixels.iter() {
            let i = i as usize;
            let (Some(&z), Some(&f)) = (depth.get(i), families.get(i)) else { continue };
            if z.is_nan() || f != 1 << k {
                continue;
            }
            let (x, y) = (i % width, i / width);
            let tol = neighbour_tolerance(z);
            let disputed = (y.saturating_sub(r)..(y + r + 1).min(height))
                .any(|yy| depth[yy * width + x.saturating_sub(r)..yy * width + (x + r + 1).min(width)].iter().any(|&o| (o - z).abs() > tol));
            if disputed {
                removed.push(i as u32);
            }
        }
    }
    // Each pixel is judged once: only for the one family that measured it.
    clear_pixels(depth, families, removed)
}

/// Remove depths with fewer than [`MIN_SUPPORT`] of their 8 neighbours on the same
/// surface, as they were before any was removed. `scratch` is resized to two rows and
/// overwritten: it keeps the original values of the row above and of the row being
/// changed (the row below is not changed yet), so the pass needs no copy of the map.
///
/// Interior pixels take a path without bounds checks (a comparison with a NaN
/// neighbour is false, so missing neighbours need no test of their own); the one-pixel
/// border takes the general path.
pub fn remove_isolated(depth: &mut [f32], width: usize, height: usize, scratch: &mut Vec<f32>) -> usize {
    if width == 0 || height == 0 {
        return 0;
    }
    scratch.clear();
    scratch.resize(2 * width, f32::NAN);
    let (mut above, mut here) = scratch.split_at_mut(width);
    let mut removed = 0;
    for y in 0..height {
        let (head, tail) = depth.split_at_mut((y + 1) * width);
        let row = &mut head[y * width..];
        here.copy_from_slice(row);
        let below = (y + 1 < height).then(|| &tail[..width]);
        // The original rows y-1, y, y+1 (None beyond the map).
        let rows = [(y > 0).then_some(&*above), Some(&*here), below];
        let general = |x: usize, z: f32| -> usize {
            let tol = neighbour_tolerance(z);
            let mut support = 0;
            for (dy, r) in rows.iter().enumerate() {
                let Some(r) = r else { continue };
                for xx in x.saturating_sub(1)..(x + 2).min(width) {
                    if (xx, dy) != (x, 1) && (r[xx] - z).abs() <= tol {
                        support += 1;
                    }
                }
            }
            support
        };
        let mut border = |x: usize, row: &mut [f32]| {
            let z = here[x];
            if !z.is_nan() && general(x, z) < MIN_SUPPORT {
                row[x] = f32::NAN;
                removed += 1;
            }
        };
        match rows {
            [Some(up), Some(mid), Some(down)] if width >= 3 => {
                border(0, row);
                border(width - 1, row);
                // The interior without branches (it vectorizes): a NaN depth has no
                // support and is kept as it is. Every neighbour comes from a slice of
                // the interior's length, so there are no bounds checks, the counts are
                // u32 (four to a 128-bit vector, not two), and `&` (not `&&`) keeps the
                // NaN test from becoming a branch.
                let n = width - 2;
                let (ul, uc, ur) = (&up[..n], &up[1..n + 1], &up[2..n + 2]);
                let (ml, mc, mr) = (&mid[..n], &mid[1..n + 1], &mid[2..n + 2]);
                let (dl, dc, dr) = (&down[..n], &down[1..n + 1], &down[2..n + 2]);
                let out = &mut row[1..n + 1];
                let mut gone = 0u32;
                for i in 0..n {
                    let z = mc[i];
                    let tol = neighbour_tolerance(z);
                    let near = |v: f32| ((v - z).abs() <= tol) as u32;
                    let support = near(ul[i]) + near(uc[i]) + near(ur[i]) + near(ml[i]) + near(mr[i]) + near(dl[i]) + near(dc[i]) + near(dr[i]);
                    let drop = !z.is_nan() & (support < MIN_SUPPORT as u32);
                    out[i] = if drop { f32::NAN } else { z };
                    gone += drop as u32;
                }
                removed += gone as usize;
            }
            _ => (0..width).for_each(|x| border(x, row)),
        }
        std::mem::swap(&mut above, &mut here);
    }
    removed
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 20 x 12 plane at 750 mm that both families measure. Inside it, family 1 is off
    /// by a stripe (18 mm) over a 4 x 3 patch: the merge leaves the patch empty and
    /// settling gives it family 0's depth, which agrees with all of its border. Along
    /// the bottom rows (y >= 9) family 1 continues the plane while family 0 measures a
    /// far surface at 900 mm, and the far surface's agreeing pixels below (y = 11)
    /// agree with family 0: the border is split and the strip stays empty.
    #[test]
    fn disputed_regions_are_settled_by_the_family_their_border_agrees_with() {
        let (w, h) = (20, 12);
        let plane = |x: usize, y: usize| 750.0 + 0.1 * x as f32 + 0.05 * y as f32;
        let mut a = vec![0f32; w * h];
        let mut b = vec![0f32; w * h];
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                (a[i], b[i]) = (plane(x, y), plane(x, y));
                if (8..12).contains(&x) && (3..6).contains(&y) {
                    b[i] += 18.0;
                }
                if y >= 9 {
                    a[i] = 900.0;
                    b[i] = if y == 11 { 900.0 } else { plane(x, y) };
                }
            }
        }
        let weights = vec![vec![1.0; w * h]; 2];
        let (mut out, mut fam) = (vec![0f32; w * h], vec![0u8; w * h]);
        merge_into(&[&a[..], &b[..]], &weights, &mut out, &mut fam);
        assert!(out[4 * w + 9].is_nan() && out[10 * w + 5].is_nan(), "the merge leaves disputes empty");
        let settled = resolve_disputes(&[&a[..], &b[..]], &mut out, &mut fam, w, h, &mut Vec::new());
        assert_eq!(settled, 12, "the patch, not the strip");
        for y in 3..6 {
            for x in 8..12 {
                assert_eq!((out[y * w + x], fam[y * w + x]), (a[y * w + x], 1), "({x}, {y})");
            }
        }
        for x in 0..w {
            assert!(out[9 * w + x].is_nan() && out[10 * w + x].is_nan(), "strip at x {x}");
        }
        assert!(fam.iter().all(|&f| f < 4), "no marks left behind");
    }

    /// A near surface (x < 8, 700 mm) beside a far one (800 mm). Family 0 extended
    /// into column 8 with the near depth and into column 1 correctly; family 1 measured
    /// column 7 itself. Only the extension across the edge goes, and only where family
    /// 0 contributes: the far depth within 3 px disputes it, the near depths do not
    /// dispute the extension inside the near surface, and a measured pixel beside the
    /// edge stays.
    #[test]
    fn extensions_a_nearby_depth_disputes_are_removed() {
        let (w, h) = (14, 5);
        let mut depth: Vec<f32> = (0..w * h).map(|i| if i % w < 8 { 700.0 } else { 800.0 }).collect();
        let mut families = vec![1u8; w * h];
        let mut ext0 = vec![false; w * h];
        let mut ext1 = vec![false; w * h];
        for y in 0..h {
            depth[y * w + 8] = 700.5;
            ext0[y * w + 8] = true;
            ext0[y * w + 1] = true;
            families[y * w + 7] = 2;
            ext0[y * w + 7] = true;
        }
        // On one row, family 1 alone measured the extended pixel; on the next two,
        // family 1 measured it too, in agreement (the merge kept both), without
        // extending and by extending: both confirm the extension.
        families[2 * w + 8] = 2;
        families[3 * w + 8] = 3;
        families[4 * w + 8] = 3;
        ext1[4 * w + 8] = true;
        let before = families.clone();
        let mut removed = Vec::new();
        let list = |ext: &[bool]| (0..w * h).filter(|&i| ext[i]).map(|i| i as u32).collect::<Vec<u32>>();
        let n = remove_disputed_extensions(&mut depth, &mut families, &[&list(&ext0), &list(&ext1)], w, h, &mut removed);
        assert_eq!(n, h - 3);
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                let gone = x == 8 && y < 2;
                assert_eq!(depth[i].is_nan(), gone, "pixel ({x}, {y})");
                assert_eq!(families[i], if gone { 0 } else { before[i] }, "families of ({x}, {y})");
            }
        }
    }

    /// A `w` x `h` frame whose first `cols` columns family 1 measured at 700 mm under
    /// `light` (linear), the rest undecoded under `dark`: depths, families, light.
    fn lit_block(w: usize, h: usize, cols: usize, light: [f32; 3], dark: [f32; 3]) -> (Vec<f32>, Vec<u8>, Vec<[f32; 3]>) {
        let mut depth = vec![f32::NAN; w * h];
        let mut families = vec![0u8; w * h];
        let mut linear = vec![dark; w * h];
        for y in 0..h {
            for x in 0..cols {
                let i = y * w + x;
                depth[i] = 700.0;
                families[i] = 1;
                linear[i] = light;
            }
        }
        (depth, families, linear)
    }

    /// A lit block with a dim rim on its right (a fifth of the light, one family)
    /// loses the rim; a dim pixel inside the block, a dim border pixel that both
    /// families measured, and the block's bright border stay.
    #[test]
    fn the_rim_of_the_light_is_removed() {
        let (w, h) = (8, 6);
        let (mut depth, mut families, mut linear) = lit_block(w, h, 6, [0.2, 0.3, 0.25], [0.02; 3]);
        for y in 0..h {
            linear[y * w + 5] = [0.04, 0.05, 0.03];
        }
        // A dim pixel inside (a dark stripe of the pattern), and a dim rim pixel that
        // both families measured.
        linear[2 * w + 2] = [0.05, 0.05, 0.05];
        families[3 * w + 5] = 3;
        let mut rim = Vec::new();
        let removed = remove_rim(&mut depth, &mut families, &linear, w, h, &mut rim);
        assert_eq!(removed, h - 1);
        for y in 0..h {
            for x in 0..6 {
                let i = y * w + x;
                let gone = x == 5 && y != 3;
                assert_eq!(depth[i].is_nan(), gone, "pixel ({x}, {y})");
                assert_eq!(families[i] == 0, gone, "pixel ({x}, {y})");
            }
        }
    }

    /// A lit block whose right border column (x = 6) is dimmer than the pixels beside it
    /// inside: where family 0, whose stripes run along the rows, measured it alone with
    /// under half the light of its left neighbour, it goes (y = 1, 2); at 0.55 of the
    /// light (y = 3), where both families measured it (y = 4), and where family 1,
    /// whose neighbours along its stripes are above and below and both measured, did
    /// (y = 5), it stays, and so does a dim pixel inside the block (a dark stripe).
    #[test]
    fn pixels_lit_over_less_than_half_their_area_are_removed() {
        let (w, h) = (9, 7);
        let (mut depth, mut families, mut linear) = lit_block(w, h, 7, [0.2, 0.3, 0.1], [0.01; 3]);
        for (y, share) in [(1, 0.45), (2, 0.3), (3, 0.55), (4, 0.3), (5, 0.3)] {
            linear[y * w + 6] = [0.2 * share, 0.3 * share, 0.1 * share];
        }
        families[4 * w + 6] = 3;
        families[5 * w + 6] = 2;
        linear[3 * w + 3] = [0.02, 0.03, 0.01];
        let mut removed = Vec::new();
        let n = remove_half_lit(&mut depth, &mut families, &linear, w, h, 1, &mut removed);
        assert_eq!(n, 2);
        for y in 0..h {
            for x in 0..w {
                let i = y * w + x;
                let gone = x == 6 && (y == 1 || y == 2);
                assert_eq!(depth[i].is_nan(), gone || x > 6, "pixel ({x}, {y})");
                assert_eq!(families[i] == 0, gone || x > 6, "pixel ({x}, {y})");
            }
        }
    }

    #[test]
    fn agreeing_families_average_and_disagreeing_ones_drop() {
        let d = vec![vec![700.0, 700.0, f32::NAN], vec![701.0, 750.0, 800.0]];
        let w = vec![vec![1.0, 1.0, 0.0], vec![3.0, 1.0, 1.0]];
        let mut out = vec![0.0; 3];
        let mut fam = vec![0; 3];
        merge_into(&d, &w, &mut out, &mut fam);
        assert!((out[0] - 700.75).abs() < 1e-3 && fam[0] == 3);
        assert!(out[1].is_nan() && fam[1] == 0);
        assert_eq!((out[2], fam[2]), (800.0, 2));
    }

    /// Two families take a path of their own; it gives what the general one gives,
    /// bit for bit, on every combination of present, missing, agreeing and
    /// disagreeing depths and of zero weights.
    #[test]
    fn two_families_match_the_general_merge() {
        let values = [f32::NAN, 700.0, 701.5, 703.5, 760.0, 333.25];
        let ws = [0.0, 1.0, 2.5, 1e-3];
        let mut planes: [Vec<f32>; 4] = Default::default();
        for &za in &values {
            for &zb in &values {
                for &wa in &ws {
                    for &wb in &ws {
                        for (p, v) in planes.iter_mut().zip([za, zb, wa, wb]) {
                            p.push(v);
                        }
                    }
                }
            }
        }
        let [a, b, wa, wb] = planes;
        let n = a.len();
        let (mut out, mut fam) = (vec![0.0; n], vec![9; n]);
        merge_into(&[&a, &b], &[wa.clone(), wb.clone()], &mut out, &mut fam);
        // The general path: three families, the third empty everywhere.
        let none = vec![f32::NAN; n];
        let (mut out3, mut fam3) = (vec![0.0; n], vec![9; n]);
        merge_into(&[&a, &b, &none], &[wa, wb, vec![1.0; n]], &mut out3, &mut fam3);
        assert_eq!(out.iter().map(|v| v.to_bits()).collect::<Vec<_>>(), out3.iter().map(|v| v.to_bits()).collect::<Vec<_>>());
        assert_eq!(fam, fam3);
        assert!(fam.contains(&3) && fam.contains(&1) && fam.contains(&2) && out.iter().any(|v| v.is_nan()));
    }

    /// The fast path gives what the plain definition gives, borders included.
    #[test]
    fn isolated_removal_matches_the_definition() {
        let (w, h) = (13, 9);
        let mut state = 7u32;
        let mut next = || {
            state = state.wrapping_mul(1_103_515_245).wrapping_add(12_345);
            (state >> 8) as f32 / (1u32 << 24) as f32
        };
        let d: Vec<f32> = (0..w * h).map(|_| if next() < 0.3 { f32::NAN } else { 700.0 + 20.0 * next() }).collect();
        let mut expected = d.clone();
        for y in 0..h as i32 {
            for x in 0..w as i32 {
                let z = d[(y * w as i32 + x) as usize];
                let support = (-1..=1)
                    .flat_map(|dy| (-1..=1).map(move |dx| (dx, dy)))
                    .filter(|&(dx, dy)| (dx, dy) != (0, 0))
                    .filter(|&(dx, dy)| {
                        let (xx, yy) = (x + dx, y + dy);
                        xx >= 0 && yy >= 0 && xx < w as i32 && yy < h as i32 && {
                            let n = d[(yy * w as i32 + xx) as usize];
                            !n.is_nan() && (n - z).abs() <= neighbour_tolerance(z)
                        }
                    })
                    .count();
                if !z.is_nan() && support < MIN_SUPPORT {
                    expected[(y * w as i32 + x) as usize] = f32::NAN;
                }
            }
        }
        let mut got = d.clone();
        remove_isolated(&mut got, w, h, &mut Vec::new());
        assert_eq!(got.iter().map(|v| v.to_bits()).collect::<Vec<_>>(), expected.iter().map(|v| v.to_bits()).collect::<Vec<_>>());
    }

    #[test]
    fn isolated_points_go() {
        let mut d = vec![f32::NAN; 25];
        for i in [6, 7, 8, 11, 12, 13] {
            d[i] = 700.0;
        }
        d[24] = 650.0;
        d[13] = 900.0;
        let mut s = Vec::new();
        remove_isolated(&mut d, 5, 5, &mut s);
        assert!(d[24].is_nan() && d[13].is_nan());
        assert_eq!(d[12], 700.0);
    }

    /// A weak pixel of family 0 that family 1 also measured (and agreed with) stays; one
    /// family 0 measured alone stays where family 1's depths around it agree with it
    /// (five of them at least) and goes where they do not, or where one contradicts it;
    /// a weak pixel of family 1 the merge already left empty stays empty.
    /// A weak pixel with no other family's depth near it is judged by those further
    /// out ([`CONFIRM_FAR_REACH`]); where the near ones say anything, they judge alone.
    #[test]
    fn weak_pixels_with_nothing_near_are_judged_from_further_out() {
        let (w, h) = (40, 30);
        let nan = f32::NAN;
        let at = |x: usize, y: usize| y * w + x;
        let (x, y) = (20, 15);
        let far = CONFIRM_REACH + 4;
        assert!(far <= CONFIRM_FAR_REACH);
        // The weak pixel of family 0 alone, and family 1's depths around it.
        let judge = |other: &[f32]| {
            let mut depth = vec![nan; w * h];
            let mut families = vec![0u8; w * h];
            depth[at(x, y)] = 751.0;
            families[at(x, y)] = 1;
            let own = vec![nan; w * h];
            remove_unconfirmed(&mut depth, &mut families, &[&[at(x, y) as u32]], &[own, other.to_vec()], w, h);
            assert_eq!(depth[at(x, y)].is_nan(), families[at(x, y)] == 0);
            families[at(x, y)] == 1
        };
        let mut other = vec![nan; w * h];
        // Nothing within the far reach: it goes, as before.
        other[at(x + CONFIRM_FAR_REACH + 1, y)] = 751.5;
        assert!(!judge(&other));
        // Enough agreeing depths out there: it stays.
        for dy in 0..CONFIRM_COUNT {
            other[at(x + far, y - 2 + dy)] = 751.5;
        }
        assert!(judge(&other));
        // One contradicting depth out there: it goes.
        let mut contradicted = other.clone();
        contradicted[at(x - far, y)] = 790.0;
        assert!(!judge(&contradicted));
        // One agreeing depth near it: the near ones judge, and one is too few.
        let mut near = other.clone();
        near[at(x + 1, y + 1)] = 751.5;
        assert!(!judge(&near));
    }

    #[test]
    fn weak_pixels_stay_only_where_another_family_vouches_for_them() {
        let (w, h) = (12, 3);
        let nan = f32::NAN;
        let mut depth = vec![nan; w * h];
        let mut families = vec![0u8; w * h];
        let mut other = vec![nan; w * h];
        // Pixel 0: both families, in agreement. Pixels 13 and 22: family 0 alone.
        depth[0] = 750.0;
        families[0] = 3;
        other[0] = 750.5;
        for i in [13, 22] {
            depth[i] = 751.0;
            families[i] = 1;
        }
        // Around pixel 13 (x 1): five agreeing depths of family 1 (pixel 0's among
        // them); around pixel 22 (x 10), five agreeing and one far off.
        for i in [2, 14, 15, 26] {
            other[i] = 751.5;
        }
        for i in [9, 10, 11, 21, 23] {
            other[i] = 751.5;
        }
        other[34] = 790.0;
        let own = vec![nan; w * h];
        remove_unconfirmed(&mut depth, &mut families, &[&[0, 13, 22], &[5]], &[own.clone(), other.clone()], w, h);
        assert_eq!((families[0], families[13], families[22], families[5]), (3, 1, 0, 0));
        assert!(depth[0] == 750.0 && depth[13] == 751.0 && depth[22].is_nan() && depth[5].is_nan());
        // With one agreeing depth fewer, pixel 13 goes too.
        other[26] = nan;
        depth[13] = 751.0;
        families[13] = 1;
        remove_unconfirmed(&mut depth, &mut families, &[&[13]], &[own, other], w, h);
        assert!(depth[13].is_nan() && families[13] == 0);
    }

    #[test]
    fn a_pixel_one_family_measured_alone_goes_where_the_others_depths_around_contradict_it() {
        let (w, h) = (7, 7);
        let centre = 3 * w + 3;
        // Family 1's merged depths (alone, or with family 0) at 750 mm around the centre.
        let setup = |around: &[(usize, u8)], z: f32| {
            let mut depth = vec![f32::NAN; w * h];
            let mut families = vec![0u8; w * h];
            for &(i, f) in around {
                depth[i] = 750.0;
                families[i] = f;
            }
            depth[centre] = z;
            families[centre] = 1;
            (depth, families)
        };
        let two = [(centre - w - 1, 2), (centre + 2 * w - 2, 3)];
        let mut scratch = Vec::new();
        // 8 mm off (more than twice the 3 mm agreement at 750 mm) with two contradicting:
        // removed; 1 mm off: kept; 5 mm off neither agrees nor contradicts: kept.
        for (z, kept) in [(758.0, false), (751.0, true), (755.0, true)] {
            let (mut depth, mut families) = setup(&two, z);
            remove_contradicted(&mut depth, &mut families, w, h, &mut scratch);
            assert_eq!(families[centre] == 1, kept, "{z}");
            assert_eq!(depth[centre].is_nan(), !kept);
            assert_eq!(families.iter().filter(|&&f| f != 0).count(), 2 + kept as usize);
        }
        // One contradicting is not enough; nor three beyond the reach; nor three of the
        // pixel's own family; nor many when one agrees.
        let beyond = [(centre - 3, 2), (centre + 3, 2), (centre + 3 * w, 2)];
        let own = [(centre - w - 1, 1), (centre + 2, 1), (centre + 2 * w, 1)];
        for around in [&two[..1], &beyond[..], &own[..]] {
            let (mut depth, mut families) = setup(around, 758.0);
            remove_contradicted(&mut depth, &mut families, w, h, &mut scratch);
            assert_eq!(families[centre], 1);
        }
        let (mut depth, mut families) = setup(&[(centre - 1, 2), (centre + 1, 2), (centre + w, 2), (centre - w, 2)], 758.0);
        depth[centre - w] = 757.0;
        remove_contradicted(&mut depth, &mut families, w, h, &mut scratch);
        assert_eq!(families[centre], 1);
    }
}


