//! Order-preserving alignment of one run of boundaries to the pattern (dynamic
//! programming over stripe identities, in the spirit of Zhang, Curless and Seitz 2002),
//! tolerating spurious edges, missed boundaries and misread transitions.
//!
//! Along a run of a scan line (usable pixels only) the boundaries' identities increase
//! along the scan direction: the pattern's rank of a boundary (its index, counted along
//! the scan direction) grows by one from boundary to boundary, or by more where a
//! boundary was missed; an edge can also be no boundary of the pattern at all (another
//! family leaking through the restoration, texture). Each labelling is scored in bits
//! of evidence against chance:
//! - an edge given rank `r` whose compatible codes include the pattern's code there
//!   gains the information its evidence carries, `log2(P / m)` for `m` compatible codes
//!   of the `P` the pattern uses (an exact transition the most, a wildcard nothing);
//!   one whose evidence contradicts it loses [`MISREAD_BITS`];
//! - a spurious edge costs [`SPURIOUS_BITS`], a missed boundary [`MISSED_BITS`] (at most
//!   [`MAX_MISSED`] in a row), or [`INVISIBLE_BITS`] where its transition changes only
//!   channels that neither neighbouring edge can read: on a saturated dye only the
//!   boundaries where its own channel changes make edges;
//! - the spacing of two consecutively labelled edges must fit the number of ranks
//!   between them at the local stripe period: each labelling carries a running estimate
//!   of that period (set by its first step), and a step whose spacing is off
//!   costs the bits of its log-ratio under a Gaussian of [`SPACING_SPREAD`] and the
//!   position noise ([`SPACING_CAP_BITS`] at most). Where edges show only some
//!   boundaries (one readable channel), their spacing is what says how many were
//!   skipped;
//! - a jump to any rank (a depth discontinuity inside the run: the surface beyond shows
//!   another part of the pattern) costs [`JUMP_BITS`] and lands only on an edge with
//!   specific evidence ([`JUMP_MAX_CODES`]) that the best labelling so far cannot
//!   take in a short step. Without it, the edges beyond a
//!   discontinuity could only be labelled by a wrong labelling carried on from before
//!   it, which with the period estimate and exact codes can look consistent.
//!
//! A forward and a backward pass give, for every edge and every label, the score of the
//! best labelling of the whole run with the edge so labelled. An edge takes the rank of
//! its best labelling only where that is ahead of every other rank by
//! [`ACCEPT_BITS`] and ahead of "spurious" by [`SPURIOUS_MARGIN_BITS`]: a wrong depth
//! is worse than none, so an ambiguous edge stays empty.

/// Cost of an edge whose evidence contradicts the rank it is given, bits (about one
/// misread transition in eight on a saturated dye).
pub const MISREAD_BITS: f32 = 3.0;

/// Cost of an edge that is no boundary of the pattern, bits.
pub const SPURIOUS_BITS: f32 = 3.0;

/// Cost of a boundary of the pattern that has no edge, bits.
pub const MISSED_BITS: f32 = 3.0;

/// Most boundaries that may be missed between two consecutive labelled edges.
pub const MAX_MISSED: usize = 2;

/// Cost of a boundary of the pattern that has no edge where its transition changes
/// only channels that neither neighbouring edge can read (a saturated dye's dark
/// channels): no edge is what such a boundary shows, so skipping it is nearly free.
pub const INVISIBLE_BITS: f32 = 0.3;

/// Most ranks one step may cross (`MAX_STEP - 1` boundaries without an edge) where
/// some channel is unreadable at both edges: on a red dye only the boundaries where
/// red changes make edges, and red stays the same over up to five boundaries of the
/// default pattern.
pub const MAX_STEP: usize = 6;

/// Relative spread of the spacing of neighbouring boundaries about the local stripe
/// period (slant and curvature change the period from one stripe to the next): the
/// simulated hard scenes' local period varies by ±8 % between quartiles over whole
/// objects, much less from one stripe to the next.
pub const SPACING_SPREAD: f32 = 0.08;

/// Standard deviation of a boundary's sub-pixel position, pixels (a webcam frame's,
/// with JPEG and 4:2:0 chroma; see [`crate::decode::SMOOTH_TOLERANCE`]).
pub const POSITION_NOISE: f32 = 0.25;

/// Largest cost of a spacing that does not fit the step between two edges, bits:
/// about two misreads, what a depth discontinuity between the two edges costs.
pub const SPACING_CAP_BITS: f32 = 4.0;

/// How much of a step's measured period goes into a labelling's running estimate of
/// the local stripe period.
pub const PACE_UPDATE: f32 = 0.35;

/// The period estimate of a labelling that starts at an edge: unknown until its first
/// step, which costs nothing for its spacing and sets the estimate (the expected period
/// is off by a third on a near object or a slanted surface).
const UNKNOWN_PACE: f32 = 0.0;

/// Range of the running period estimate, as multiples of the expected period.
pub const PACE_RANGE: (f32, f32) = (0.5, 2.0);

/// Cost of a jump between two labelled edges to any rank (a depth discontinuity: the
/// stripes beyond belong to another part of the pattern), bits: four misreads, so that
/// about three exact codes in a row are needed to pay for it. A jump lands only on an
/// edge that the best labelling so far cannot take in a short step: offered at every
/// edge, jumps keep a dozen more labels in the beam and made the decoding four times
/// slower.
pub const JUMP_BITS: f32 = 12.0;

/// Most compatible codes of an edge a jump may land on: a jump needs specific evidence
/// (and this keeps the candidates of every other edge to the steps from its
/// predecessor's labels).
pub const JUMP_MAX_CODES: u32 = 2;

/// How many edges after a jump's edge may show the next boundary: a jump lands only on
/// the ranks from which one of them can be reached in a step. Why: texture edges with a
/// specific code that the best labelling cannot take are common (a fifth of the edges
/// of the end-to-end test's textured frame), and each seeded a label at every rank of
/// its code (about 37), nearly all of which stayed in the beam, all scoring the same.
/// Two edges ahead took the alignment of that frame (`examples/bench_frame`, textured,
/// 4:2:0) from 343 M to 285 M instructions. 77 VGA rows of the hard evaluation (11
/// scenes under every condition but `8mp`) stayed within 0.01 points of coverage and
/// outliers but one: bag under `world` gained one wrong patch of 160 pixels (0.33 %
/// to 0.52 % outliers). Tried on 2026-12-03, when 3-pixel stripes still decoded with
/// 2-3 % outliers, it raised those by half, and was taken out; they decode with 0.1 %
/// now, and the lookahead changes them by under 0.01 points.
pub const JUMP_LOOKAHEAD: usize = 2;

/// Margin of an edge's best rank over every other rank for it to be taken, bits.
/// Measured on the simulated scenes (`eval --scenes sphere,colorchecker,sphere-dye,
/// paper-dye,bag,occluders,wood,skin --directions 1,2 --filters loggrad`, mean of the
/// 16 rows, coverage / outliers): 10 bits 75.4 % / 0.97 %, 12 bits 74.5 % / 0.79 %,
/// 14 bits 73.6 % / 0.73 %.
pub const ACCEPT_BITS: f32 = 12.0;

/// Margin of an edge's best rank over its being spurious, bits.
pub const SPURIOUS_MARGIN_BITS: f32 = 3.0;

/// How far below an edge's best prefix score a rank may be and still be carried on,
/// bits. Measured on the simulated scenes (the 16 rows of [`ACCEPT_BITS`], mean
/// coverage / outliers, decoding ms per family of `examples/bench_frame`): 16 bits
/// 79.5 % / 0.62 %, 38 ms; 14 bits 79.5 % / 0.63 %, 30 ms; 12 bits 79.8 % / 0.64 %,
/// 26 ms; 10 bits 77.7 % / 0.69 %, 22 ms. Below 14 bits the occluders under the
/// `world` condition (`eval --hard`) gain outliers (0.71 % to 0.90 % at 13 bits): the
/// labellings beyond a depth edge start behind the best. Keeping at most the best 12
/// or 16 labels of an edge instead lost a point of coverage for the same time.
pub const BEAM_BITS: f32 = ACCEPT_BITS + 2.0;

use crate::segment::Tentative;

const NONE: f32 = f32::NEG_INFINITY;

/// Per channel c and value v (0 down, 1 unchanged, 2 up), the codes whose channel c
/// has value v, as a [`crate::segment::CodeMask`].
const fn digit_masks() -> [[u32; 3]; 3] {
    let mut out = [[0u32; 3]; 3];
    let mut code = 0;
    while code < 27 {
        let t = crate::segment::unpack(code);
        let mut c = 0;
        while c < 3 {
            out[c][(t[c] + 1) as usize] |= 1 << code;
            c += 1;
        }
        code += 1;
    }
    out
}
const DIGITS: [[u32; 3]; 3] = digit_masks();

/// The channels (bit c) an edge with the compatible codes `mask` cannot read: every
/// value is compatible.
#[inline]
pub fn blind_channels(mask: u32) -> u8 {
    let mut blind = 0;
    for (c, d) in DIGITS.iter().enumerate() {
        if mask & d[0] != 0 && mask & d[1] != 0 && mask & d[2] != 0 {
            blind |= 1 << c;
        }
    }
    blind
}

/// The channels (bit c) whose value code `code` changes.
#[inline]
pub fn changed_channels(code: u8) -> u8 {
    if code >= 27 {
        return 7;
    }
    (0..3).filter(|&ch| DIGITS[ch][1] >> code & 1 == 0).fold(0, |m, ch| m | 1 << ch)
}

/// Reusable tables of the alignment of one run.
///
/// The labels carried on for an edge (its ranks within [`BEAM_BITS`] of its best prefix
/// score) are few, a handful of the pattern's hundred or so, so they are kept as a list
/// per edge in increasing rank, and the steps between consecutive edges go through
/// per-rank scratch tables that are written for the labels of one edge and put back to
/// empty after it.
#[derive(Clone, Default)]
pub struct Aligner {
    /// Per rank, the bit of its code in a [`crate::segment::CodeMask`] widened to 64
    /// bits (bit 63, never set, for boundaries without a code).
    rank_bit: Vec<u8>,
    /// Per rank, the channels (bit c) the projector lights on at least one side of the
    /// boundary (all for the spare ranks): only there does an unreadable channel say
    /// that the surface hides it, and not that the pattern is black in it.
    lit: Vec<u8>,
    /// Per set of channels the surface hides at both ends of a step (unreadable there
    /// though the projector lights them; 8 sets), the cost of
    /// missing the ranks before each rank: `missed[b * (nr + MAX_STEP + 1) + r]` is the
    /// sum over ranks below `r`, so a step from `r` to `r + k` costs
    /// `missed[r + k] - missed[r + 1]`.
    missed: Vec<f32>,
    /// Per code, the ranks that show it: bit sets of `words` 64-bit words.
    words: usize,
    code_ranks: Vec<u64>,
    /// The codes the pattern shows (a [`crate::segment::CodeMask`]), and the bits of
    /// evidence of an edge compatible with 0..=27 of them.
    used: u32,
    gain_of: [f32; 28],
    /// Per edge, the bits of evidence its compatible codes carry, and the channels it
    /// cannot read.
    gain: Vec<f32>,
    blind: Vec<u8>,
    /// Per edge, whether a labelling may jump to it (see [`JUMP_BITS`]).
    jumps: Vec<bool>,
    /// The labels carried on, edge after edge: edge `i`'s are `start[i]..start[i + 1]`.
    start: Vec<usize>,
    labels: Vec<Label>,
    /// Per edge, the best prefix score with nothing labelled yet (`none`), and the best
    /// suffix score after the edge with nothing labelled at or before it (`after_none`).
    none: Vec<f32>,
    after_none: Vec<f32>,
    /// Per edge, its best and second best whole-run scores by rank and the best of its
    /// keeping a label of the previous edge over being spurious itself ([`Verdict`]).
    verdicts: Vec<Verdict>,
    /// Per edge, the verdict as [`Aligner::tentative`] gives it.
    tentative: Vec<Tentative>,
    /// Per rank, the cost of the boundaries a step of `k` = 1..=[`MAX_MISSED`] + 1 ranks
    /// from it skips where nothing is hidden (`missed`'s first row, differenced once
    /// here rather than at every step; index `k`, 0 unused).
    step_cost: Vec<[f32; MAX_MISSED + 2]>,
    /// Per-rank scratch, [`NONE`] between uses (`MAX_STEP` spare ranks at the end):
    /// forward, the best score of reaching a rank from the previous edge's labels and of
    /// keeping the previous edge's label ([`Slot`]), with the set of ranks touched
    /// (`cand`, one spare word for the ranges that cross a word's end); backward, the
    /// next edge's suffix scores and evidence ([`BackSlot`]), and the same of this
    /// edge's labels for the step to the edge before (`back`'s halves, in turn).
    slots: Vec<Slot>,
    cand: Vec<u64>,
    /// The ranks a jump may land on ([`JUMP_LOOKAHEAD`]), and scratch: two bit sets of
    /// `words` words.
    landing: Vec<u64>,
    back: Vec<BackSlot>,
}

/// One label an edge carries on (one record, so that keeping it is one copy).
#[derive(Clone, Copy, Default)]
struct Label {
    /// Its rank.
    rank: u32,
    /// The best prefix score with the edge labelled with it.
    labelled: f32,
    /// With it the last label at or before the edge, the best prefix score.
    last: f32,
    /// The position of the last labelled edge of the best labelling so far.
    last_pos: f32,
    /// That labelling's running estimate of the stripe period.
    pace: f32,
}

/// Forward scratch of one rank: what the steps from the previous edge's labels bring
/// to it (one record, so that a step reads and writes one place).
#[derive(Clone, Copy)]
struct Slot {
    /// The best score of reaching the rank from the previous edge's labels, and that
    /// step's period estimate.
    reach: f32,
    reach_pace: f32,
    /// The score of keeping the previous edge's label with this rank over a spurious
    /// edge, with that label's last position and period estimate.
    kept: f32,
    kept_pos: f32,
    kept_pace: f32,
    /// The rank's code as a [`crate::segment::CodeMask`] bit (0 where it has none),
    /// and what an edge whose evidence does not include it says of the rank
    /// (-[`MISREAD_BITS`], [`NONE`] where it has no code): fixed, beside the scratch so
    /// that a candidate's evidence is read from the record it is built from.
    bit: u32,
    miss: f32,
}

impl Default for Slot {
    fn default() -> Self {
        Slot { reach: NONE, reach_pace: 0.0, kept: NONE, kept_pos: 0.0, kept_pace: 0.0, bit: 0, miss: NONE }
    }
}

impl Slot {
    /// The same as [`emit`] for this slot's rank.
    #[inline(always)]
    fn emit(&self, (mask, gain): (u64, f32)) -> f32 {
        if mask as u32 & self.bit != 0 {
            gain
        } else {
            self.miss
        }
    }
}

/// Backward scratch of one rank: the next edge's suffix score with the rank, and what
/// that edge's evidence says of it.
#[derive(Clone, Copy)]
struct BackSlot {
    stay: f32,
    emitted: f32,
}

impl Default for BackSlot {
    fn default() -> Self {
        BackSlot { stay: NONE, emitted: NONE }
    }
}

/// What decides an edge, gathered by the backward pass.
#[derive(Clone, Copy)]
struct Verdict {
    /// The best whole-run score of a labelling that labels the edge, its rank
    /// (`u32::MAX` for none), and the second best score of another rank with its rank.
    best: f32,
    second: f32,
    rank: u32,
    second_rank: u32,
    /// The best whole-run score with the edge spurious and a label of the previous edge
    /// kept over it ([`NONE`] for none).
    kept: f32,
}

impl Default for Verdict {
    fn default() -> Self {
        Verdict { best: NONE, second: NONE, rank: u32::MAX, second_rank: u32::MAX, kept: NONE }
    }
}

impl Verdict {
    /// Weigh one label of the edge, whose whole-run score is `s`, in rank order (of
    /// equal scores the first stays best).
    #[inline(always)]
    fn weigh(&mut self, s: f32, rank: u32) {
        if s > self.best {
            self.second = self.best;
            self.second_rank = self.rank;
            self.best = s;
            self.rank = rank;
        } else if s > self.second {
            self.second = s;
            self.second_rank = rank;
        }
    }
}

/// What the alignment of one run reads of each edge and of the pattern's appearance.
#[derive(Clone, Copy)]
pub struct RunInput<'a> {
    /// Each edge's compatible codes.
    pub masks: &'a [u32],
    /// Each edge's position along the line, pixels, increasing.
    pub positions: &'a [f32],
    /// The expected stripe period along the line, pixels.
    pub period: f32,
}

impl Aligner {
    /// Tables for a pattern whose boundaries, in the order of the scan direction, show
    /// the codes `seen` ([`crate::segment::NO_CODE`] where a boundary has none), each
    /// with the channels (bit c) the projector lights on at least one side of it.
    pub fn new(seen: impl Iterator<Item = (u8, u8)>) -> Self {
        let (rank_bit, mut lit): (Vec<u8>, Vec<u8>) = seen.map(|(c, l)| (if c < 27 { c } else { 63 }, l & 7)).unzip();
        let nr = rank_bit.len();
        let words = nr.div_ceil(64);
        let mut code_ranks = vec![0u64; 27 * words];
        for (r, &c) in rank_bit.iter().enumerate() {
            if c < 27 {
                code_ranks[c as usize * words + r / 64] |= 1 << (r % 64);
            }
        }
        let used = rank_bit.iter().filter(|&&c| c < 27).fold(0u32, |m, &c| m | 1 << c);
        let p = used.count_ones().max(1) as f32;
        let spare = nr + MAX_STEP + 1;
        lit.resize(spare, 7);
        // The channels each rank's transition changes (all, for a rank without a code).
        let changes: Vec<u8> = rank_bit.iter().map(|&c| changed_channels(c)).collect();
        let mut missed = vec![0f32; 8 * spare];
        for blind in 0..8u8 {
            let row = &mut missed[blind as usize * spare..(blind as usize + 1) * spare];
            for r in 0..spare - 1 {
                let visible = r >= nr || changes[r] & !blind != 0;
                row[r + 1] = row[r] + if visible { MISSED_BITS } else { INVISIBLE_BITS };
            }
        }
        let step_cost = (0..nr).map(|r| std::array::from_fn(|k| if k == 0 { 0.0 } else { missed[r + k] - missed[r + 1] })).collect();
        let slots = (0..spare)
            .map(|r| match rank_bit.get(r) {
                Some(&c) if c < 27 => Slot { bit: 1 << c, miss: -MISREAD_BITS, ..Slot::default() },
                _ => Slot::default(),
            })
            .collect();
        Aligner {
            rank_bit,
            lit,
            missed,
            words,
            code_ranks,
            used,
            gain_of: std::array::from_fn(|m| (p / m.max(1) as f32).log2()),
            step_cost,
            slots,
            cand: vec![0; words + 1],
            landing: vec![0; 2 * words],
            back: vec![BackSlot::default(); 2 * spare],
            ..Default::default()
        }
    }

    /// Label the edges of one run (in scan order): `out[i]` is the rank of edge `i`, or
    /// -1 where no rank is clear enough.
    pub fn align(&mut self, run: RunInput, out: &mut [i32]) {
        let n = run.masks.len();
        let nr = self.rank_bit.len();
        out.iter_mut().for_each(|o| *o = -1);
        self.tentative.clear();
        if n == 0 || nr == 0 || run.positions.len() != n {
            return;
        }
        // The information of `m` compatible codes depends on `m` alone (a table).
        self.gain.clear();
        self.gain.extend(run.masks.iter().map(|&m| self.gain_of[(m & self.used).count_ones() as usize]));
        self.blind.clear();
        self.blind.extend(run.masks.iter().map(|&m| blind_channels(m)));
        self.forward(run);
        self.backward(run);
        self.decide(out);
    }

    /// Prefix scores, edge after edge: the labels of an edge are the previous edge's
    /// labels and up to [`MAX_MISSED`] + 1 ranks beyond them ([`MAX_STEP`] where a
    /// channel is unreadable at both edges), and where a new alignment may still start
    /// (nothing labelled is within the beam of the best), every rank the edge fits; only
    /// those within [`BEAM_BITS`] of the edge's best are kept.
    fn forward(&mut self, run: RunInput) {
        let nr = self.rank_bit.len();
        let spare = nr + MAX_STEP + 1;
        let (masks, positions, period) = (run.masks, run.positions, run.period);
        let n = masks.len();
        let pace_range = (PACE_RANGE.0 * period, PACE_RANGE.1 * period);
        // The fields apart, and the tables as slices, so that the loops keep them in
        // registers and the compiler sees their lengths.
        let Aligner { rank_bit, lit, missed, step_cost, words, code_ranks, used, gain, blind, jumps, start, labels, none, slots, cand, landing, .. } =
            self;
        let (rank_bit, lit, missed, step_cost, code_ranks, gain, blind) = (&rank_bit[..nr], &lit[..spare], &missed[..], &step_cost[..nr], &code_ranks[..], &gain[..n], &blind[..n]);
        let words = *words;
        let (slots, cand) = (&mut slots[..spare], &mut cand[..words + 1]);
        // The bits of the last word that are ranks (the rest are steps past the last).
        let last_word = if nr % 64 == 0 { u64::MAX } else { (1 << (nr % 64)) - 1 };
        none.clear();
        none.resize(n, 0.0);
        jumps.clear();
        jumps.resize(n, false);
        // `labels` is used up to `len`; past it, room for one edge's candidates (every
        // rank at most), written in place and then thinned to the beam. The table only
        // grows, so no call writes it twice.
        let mut len = 0;
        start.clear();
        let mut prev = 0..0;
        let mut prev_max = NONE;
        // The rank of the previous edge's best labelling (u32::MAX before the first).
        let mut prev_best = u32::MAX;
        for (i, &mask) in masks.iter().enumerate() {
            let edge = (mask as u64, gain[i]);
            let pos = positions[i];
            let prev_none = if i == 0 { 0.0 } else { none[i - 1] };
            none[i] = prev_none - SPURIOUS_BITS;
            let both_blind = if i == 0 { 0 } else { blind[i - 1] & blind[i] };
            // The labels in decreasing rank: a rank is reached from the lower ranks, so
            // the one-rank step, usually the best, comes first and the longer ones
            // seldom need their spacing costed. Of equal scores the lowest rank's step
            // wins (`>=`), as it would in increasing order with `>`.
            for &Label { rank, last: v, last_pos: from_pos, pace: p, .. } in labels[prev.clone()].iter().rev() {
                let r = rank as usize;
                let slot = &mut slots[r];
                slot.kept = v - SPURIOUS_BITS;
                slot.kept_pos = from_pos;
                slot.kept_pace = p;
                let gap = pos - from_pos;
                let hidden = both_blind & lit[r];
                if hidden == 0 {
                    // Ranks r..=r + MAX_MISSED + 1 are candidates (the spare bits past
                    // the last rank are dropped when the candidates are read).
                    // (Two 64-bit words, not a u128: WebAssembly shifts those by a call.)
                    let (range, w, shift) = ((1u64 << (MAX_MISSED + 2)) - 1, r / 64, r % 64);
                    cand[w] |= range << shift;
                    // What crosses into the next word, `range >> (64 - shift)`, in two
                    // shifts so that a shift of 0 carries nothing.
                    cand[w + 1] |= range >> 1 >> (63 - shift);
                    if v == NONE {
                        continue;
                    }
                    let cost = &step_cost[r];
                    let Some((first, longer)) = slots[r + 1..r + 2 + MAX_MISSED].split_first_mut() else { continue };
                    // Nothing reaches `r + 1` before the one-rank step: the labels above
                    // `r` reach only above `r + 1`.
                    land(first, v - cost[1] - spacing_bits(gap, 1, p), gap, 1, p, pace_range);
                    for (k, slot) in longer.iter_mut().enumerate() {
                        let k = k + 2;
                        step(slot, v - cost[k], gap, k, p, pace_range);
                    }
                } else {
                    cand[r / 64] |= 1 << (r % 64);
                    for k in 1..=MAX_STEP {
                        let t = r + k;
                        let Some(cost) = skip_cost(missed, spare, hidden & lit[t], r, k) else { continue };
                        if v != NONE {
                            step(&mut slots[t], v - cost, gap, k, p, pace_range);
                        }
                        if t < nr {
                            cand[t / 64] |= 1 << (t % 64);
                        }
                    }
                }
            }
            // A labelling may start here after nothing, or after a jump from the best
            // labelling so far: only where the edge's evidence is specific and that
            // labelling cannot take the edge in a short step (what a discontinuity
            // looks like; elsewhere the candidates stay those of the steps).
            let explained = prev_best != u32::MAX
                && (1..=MAX_MISSED + 1).any(|k| {
                    let t = prev_best as usize + k;
                    t < nr && emit(rank_bit, edge, t) > 0.0
                });
            let jump = i > 0 && !explained && jumpable(mask, *used);
            jumps[i] = jump;
            let restart = if jump { better(prev_none, prev_max - JUMP_BITS) } else { prev_none };
            let fresh = i == 0 || restart >= prev_max - BEAM_BITS;
            if fresh {
                // Where only the jump makes the edge fresh, it lands only on the ranks
                // the next edges can follow ([`JUMP_LOOKAHEAD`]; none on a run's last
                // edge).
                let only_jump = i > 0 && prev_none < prev_max - BEAM_BITS;
                if only_jump {
                    let ahead = i + 1..(i + 1 + JUMP_LOOKAHEAD).min(n);
                    let codes = masks[ahead.clone()].iter().fold(0, |m, &x| m | x) & *used;
                    let hidden = blind[ahead].iter().fold(0, |h, &b| h | (b & blind[i]));
                    followed_by(code_ranks, words, codes, if hidden == 0 { MAX_MISSED + 1 } else { MAX_STEP }, landing);
                }
                let mut m = mask & ((1 << 27) - 1);
                while m != 0 {
                    let c = m.trailing_zeros() as usize;
                    m &= m - 1;
                    for ((w, bits), &land) in cand.iter_mut().zip(&code_ranks[c * words..(c + 1) * words]).zip(&landing[..words]) {
                        *w |= if only_jump { bits & land } else { *bits };
                    }
                }
            }
            if labels.len() < len + nr {
                labels.resize(len + nr, Label::default());
            }
            let candidates = &mut labels[len..len + nr];
            let mut count = 0;
            let mut row_max = NONE;
            let mut best_rank = u32::MAX;
            cand[words - 1] &= last_word;
            cand[words] = 0;
            for (w, word) in cand[..words].iter_mut().enumerate() {
                let mut bits = std::mem::take(word);
                while bits != 0 {
                    let r = w * 64 + bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    let slot = &mut slots[r];
                    let (from, p) = if fresh && restart > slot.reach { (restart, UNKNOWN_PACE) } else { (slot.reach, slot.reach_pace) };
                    let here = from + slot.emit(edge);
                    let label = if here >= slot.kept {
                        Label { rank: r as u32, labelled: here, last: here, last_pos: pos, pace: p }
                    } else {
                        Label { rank: r as u32, labelled: here, last: slot.kept, last_pos: slot.kept_pos, pace: slot.kept_pace }
                    };
                    slot.reach = NONE;
                    slot.kept = NONE;
                    if let Some(c) = candidates.get_mut(count) {
                        *c = label;
                    }
                    if label.last > row_max {
                        row_max = label.last;
                        best_rank = r as u32;
                    }
                    count += 1;
                }
            }
            // Keep the ranks within the beam, in order.
            let floor = row_max - BEAM_BITS;
            let mut kept = 0;
            for j in 0..count.min(nr) {
                let c = candidates[j];
                if c.last >= floor {
                    candidates[kept] = c;
                    kept += 1;
                }
            }
            // The steps past the last rank.
            if labels[prev.clone()].last().is_some_and(|l| l.rank as usize + MAX_STEP >= nr) {
                for slot in &mut slots[nr..] {
                    slot.reach = NONE;
                }
            }
            start.push(len);
            prev = len..len + kept;
            len += kept;
            prev_max = row_max;
            prev_best = best_rank;
        }
        start.push(len);
    }

    /// Suffix scores, from the last edge back: for each label of an edge, the best of
    /// keeping it over a spurious next edge and of stepping to a label of the next edge
    /// (the step's spacing measured from this edge, at the label's period estimate).
    /// Each label's whole-run score goes straight into its edge's [`Verdict`], so the
    /// suffix scores live only in the per-rank scratch of the two edges at hand.
    fn backward(&mut self, run: RunInput) {
        let (masks, positions) = (run.masks, run.positions);
        let (n, nr) = (masks.len(), self.rank_bit.len());
        let spare = nr + MAX_STEP + 1;
        let Aligner { lit, missed, step_cost, gain, blind, jumps, start, labels, after_none, verdicts, slots, back, .. } = self;
        let (slots, lit, missed, step_cost, gain, blind, jumps, start, labels) =
            (&slots[..spare], &lit[..spare], &missed[..], &step_cost[..nr], &gain[..n], &blind[..n], &jumps[..n], &start[..n + 1], &labels[..]);
        // `next` holds the next edge's labels, `here` this edge's for the edge before.
        let (mut next, mut here) = back[..2 * spare].split_at_mut(spare);
        after_none.clear();
        after_none.resize(n, NONE);
        verdicts.clear();
        verdicts.resize(n, Verdict::default());
        // The last edge: nothing after it.
        let edge = (masks[n - 1] as u64, gain[n - 1]);
        let mut best_start = NONE;
        let mut verdict = Verdict::default();
        for l in &labels[start[n - 1]..start[n]] {
            let emitted = slots[l.rank as usize].emit(edge);
            next[l.rank as usize] = BackSlot { stay: 0.0, emitted };
            best_start = better(best_start, emitted + 0.0);
            verdict.weigh(l.labelled + 0.0, l.rank);
        }
        verdicts[n - 1] = verdict;
        after_none[n - 1] = 0.0;
        for i in (0..n - 1).rev() {
            let edge = (masks[i] as u64, gain[i]);
            let gap = positions[i + 1] - positions[i];
            let both_blind = blind[i] & blind[i + 1];
            let jump = if jumps[i + 1] { best_start - JUMP_BITS } else { NONE };
            let mut verdict = Verdict::default();
            let mut kept = NONE;
            let mut start_here = NONE;
            for &Label { rank, labelled, last, pace: p, .. } in &labels[start[i]..start[i + 1]] {
                let r = rank as usize;
                let hidden = both_blind & lit[r];
                let stay = next[r].stay;
                // The next edge spurious, this label kept over it.
                kept = better(kept, last - SPURIOUS_BITS + stay);
                let mut v = better(stay - SPURIOUS_BITS, jump);
                if hidden == 0 {
                    // The spare ranks past the last are never emitted.
                    let cost = &step_cost[r];
                    for (k, b) in next[r + 1..r + 2 + MAX_MISSED].iter().enumerate() {
                        let k = k + 1;
                        if b.emitted != NONE {
                            let base = b.emitted - cost[k] + b.stay;
                            if base > v {
                                v = better(v, base - spacing_bits(gap, k, p));
                            }
                        }
                    }
                } else {
                    for k in 1..=MAX_STEP {
                        let t = r + k;
                        let b = next[t];
                        if t < nr && b.emitted != NONE {
                            if let Some(cost) = skip_cost(missed, spare, hidden & lit[t], r, k) {
                                let base = b.emitted - cost + b.stay;
                                if base > v {
                                    v = better(v, base - spacing_bits(gap, k, p));
                                }
                            }
                        }
                    }
                }
                verdict.weigh(labelled + v, rank);
                let emitted = slots[r].emit(edge);
                here[r] = BackSlot { stay: v, emitted };
                start_here = better(start_here, emitted + v);
            }
            verdicts[i] = verdict;
            verdicts[i + 1].kept = kept;
            after_none[i] = better(after_none[i + 1] - SPURIOUS_BITS, best_start);
            for l in &labels[start[i + 1]..start[i + 2]] {
                next[l.rank as usize] = BackSlot::default();
            }
            std::mem::swap(&mut next, &mut here);
            best_start = start_here;
        }
        for l in &labels[start[0]..start[1]] {
            next[l.rank as usize] = BackSlot::default();
        }
    }

    /// Decisions from the best whole-run score of each edge's labels (and of its being
    /// spurious).
    fn decide(&mut self, out: &mut [i32]) {
        self.tentative.clear();
        for (i, (o, v)) in out.iter_mut().zip(&self.verdicts).enumerate() {
            let spurious = if i == 0 { 0.0 } else { self.none[i - 1] } - SPURIOUS_BITS + self.after_none[i];
            // With a label of the previous edge kept over it (`kept` is NONE on the
            // first edge).
            let spurious = better(spurious, v.kept);
            let rank = |r: u32| if r == u32::MAX { -1 } else { r as i32 };
            let (margin, spurious_margin) = (v.best - v.second, v.best - spurious);
            self.tentative.push(Tentative { id: rank(v.rank), alt: rank(v.second_rank), margin, spurious_margin });
            if v.rank != u32::MAX && margin >= ACCEPT_BITS && spurious_margin >= SPURIOUS_MARGIN_BITS {
                *o = v.rank as i32;
            }
        }
    }

    /// Every edge's reading by the last [`Aligner::align`], taken or not, with ranks
    /// (not identities) in its `id` and `alt`.
    pub fn tentative(&self) -> &[Tentative] {
        &self.tentative
    }
}

/// A step of `k` ranks, from a label whose score less the boundaries skipped is `base`,
/// to the rank whose forward scratch is `slot`, `gap` pixels on at the label's period
/// estimate `pace`: it replaces what reaches the rank when at least as good (the labels
/// come in decreasing rank, so of equal scores the lowest rank's step stays).
#[inline(always)]
fn step(slot: &mut Slot, base: f32, gap: f32, k: usize, pace: f32, pace_range: (f32, f32)) {
    // The spacing's cost only lowers a score: skipped where the step cannot beat what
    // reaches the rank already.
    if base >= slot.reach {
        let s = base - spacing_bits(gap, k, pace);
        if s >= slot.reach {
            land(slot, s, gap, k, pace, pace_range);
        }
    }
}

/// A step of `k` ranks with the score `s` reaches the rank whose forward scratch is
/// `slot` (see [`step`]): the score, and the period estimate updated with the step.
#[inline(always)]
fn land(slot: &mut Slot, s: f32, gap: f32, k: usize, pace: f32, (lo, hi): (f32, f32)) {
    slot.reach = s;
    let seen = gap / k as f32;
    let next = if pace == UNKNOWN_PACE { seen } else { pace + PACE_UPDATE * (seen - pace) };
    // max then min, not clamp: a caller's period of 0 or less must not panic. As
    // comparisons, not `f32::max` and `f32::min` (which handle NaN with more
    // instructions, and in WebAssembly a call): the same values for any period that
    // is a number, a NaN estimate giving `lo` as `f32::max` does. Strict, so that each
    // is one `maxss` / `minss` natively (an equal value is the same number; only the
    // sign of a zero bound, from a period of 0, could differ).
    let above = if next > lo { next } else { lo };
    slot.reach_pace = if above < hi { above } else { hi };
}

/// The larger of two scores. Scores are never NaN (no infinity but [`NONE`] is ever
/// added to another), and for any other values this is [`crate::num::max_f32`] (of
/// equal values `a`, the sign of a zero included); written as `b > a`, it is one
/// `maxss` natively where `max_f32`'s NaN rule takes a compare and a blend.
#[inline(always)]
fn better(a: f32, b: f32) -> f32 {
    if b > a {
        b
    } else {
        a
    }
}

/// What the evidence of an edge (compatible codes, information) says of rank `r`,
/// whose code has bit `rank_bit[r]`.
#[inline]
fn emit(rank_bit: &[u8], (mask, gain): (u64, f32), r: usize) -> f32 {
    let bit = rank_bit[r];
    if bit == 63 {
        NONE
    } else if mask >> bit & 1 != 0 {
        gain
    } else {
        -MISREAD_BITS
    }
}

/// Into `out[..words]`, the ranks from which a step of 1 to `reach` ranks lands on a
/// rank whose code is in `codes` (`code_ranks` and `words` as in [`Aligner`]; `out` has
/// `2 * words` words, the second half scratch).
fn followed_by(code_ranks: &[u64], words: usize, codes: u32, reach: usize, out: &mut [u64]) {
    let (out, target) = out[..2 * words].split_at_mut(words);
    out.fill(0);
    target.fill(0);
    let mut m = codes;
    while m != 0 {
        let c = m.trailing_zeros() as usize;
        m &= m - 1;
        for (t, bits) in target.iter_mut().zip(&code_ranks[c * words..(c + 1) * words]) {
            *t |= bits;
        }
    }
    // Bit r of `out` for bit r + k of `target`: the set shifted down k bits across its
    // words (k < 64).
    for k in 1..=reach {
        for w in 0..words {
            let above = if w + 1 < words { target[w + 1] << (64 - k) } else { 0 };
            out[w] |= target[w] >> k | above;
        }
    }
}

/// Whether a labelling may jump to an edge with the compatible codes `mask` (of the
/// pattern's `used` codes): its evidence must name at most [`JUMP_MAX_CODES`] of them.
#[inline]
fn jumpable(mask: u32, used: u32) -> bool {
    (mask & used).count_ones() <= JUMP_MAX_CODES
}

/// The cost of the boundaries a step from rank `r` to rank `r + k` skips, with the
/// channels `hidden` unreadable at both its edges (`missed`, `spare` as in [`Aligner`]);
/// `None` when the step is too long for what is hidden.
#[inline]
fn skip_cost(missed: &[f32], spare: usize, hidden: u8, r: usize, k: usize) -> Option<f32> {
    if hidden == 0 {
        // The table's first row, without the slicing of the general case (the common
        // case: nothing hidden).
        return (k <= MAX_MISSED + 1).then(|| missed[r + k] - missed[r + 1]);
    }
    let row = &missed[hidden as usize * spare..(hidden as usize + 1) * spare];
    Some(row[r + k] - row[r + 1])
}

/// The cost of a step of `k` ranks between two labelled edges `gap` pixels apart, at a
/// running period estimate of `pace` pixels: the bits of the log-ratio of the gap to
/// `k` periods under a Gaussian of [`SPACING_SPREAD`] and the two positions' noise, at
/// most [`SPACING_CAP_BITS`].
#[inline]
fn spacing_bits(gap: f32, k: usize, pace: f32) -> f32 {
    if pace == UNKNOWN_PACE {
        return 0.0;
    }
    let expected = k as f32 * pace;
    // As one `maxss` (a NaN gap gives 0.05, as `max_f32` did).
    let gap = if gap > 0.05 { gap } else { 0.05 };
    // ln(gap / expected) by the series of the area hyperbolic tangent: 2 (x + x³/3 +
    // x⁵/5) with x = (gap - expected) / (gap + expected), within 1 % of ln up to a ratio
    // of 3 (beyond, the cost is capped anyway); no library call in WebAssembly. The
    // log-ratio's variance is SPREAD² + 2 NOISE² / expected², so with
    // `scaled = SPREAD² expected² + 2 NOISE²` the bits are
    // ln² expected² / (2 scaled) log2 e; `q` gives x² and the bits with one division.
    let e2 = expected * expected;
    let scaled = SPACING_SPREAD * SPACING_SPREAD * e2 + 2.0 * POSITION_NOISE * POSITION_NOISE;
    let (d, sum) = (gap - expected, gap + expected);
    let q = 1.0 / (sum * sum * scaled);
    let d2 = d * d;
    let x2 = d2 * scaled * q;
    let poly = 1.0 + x2 * (1.0 / 3.0 + x2 * 0.2);
    let bits = 2.0 * d2 * poly * poly * e2 * q * std::f32::consts::LOG2_E;
    if bits < SPACING_CAP_BITS {
        bits
    } else {
        SPACING_CAP_BITS
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `n` pseudo-random codes from the 26 boundary codes (no "unchanged"), from `seed`.
    fn random_codes(seed: u32, n: usize) -> Vec<u8> {
        let mut state = seed;
        (0..n)
            .map(|_| {
                state ^= state << 13;
                state ^= state >> 17;
                state ^= state << 5;
                let c = (state % 26) as u8;
                if c >= 13 { c + 1 } else { c }
            })
            .collect()
    }

    /// A run with one spurious edge, one missed boundary and one misread code is still
    /// labelled in order, the spurious edge left empty; no edge takes a wrong rank (the
    /// two edges at either end of the run and the edges beside the faults may stay
    /// empty).
    #[test]
    fn alignment_tolerates_insertions_deletions_and_misreads() {
        // Ranks 0..40 with pseudo-random codes from the 26 boundary codes.
        let codes = random_codes(0x2545_f491, 40);
        let mut al = Aligner::new(codes.iter().map(|&c| (c, 7)));
        let truth: Vec<i32> = (5..25).collect();
        let mut masks: Vec<u32> = truth.iter().map(|&r| 1u32 << codes[r as usize]).collect();
        let mut positions: Vec<f32> = truth.iter().map(|&r| 7.0 * r as f32).collect();
        let mut expect: Vec<i32> = truth.clone();
        // Misread edge 4 (a code the true rank does not have).
        let wrong = (codes[truth[4] as usize] + 1) % 27;
        masks[4] = 1 << if wrong == 13 { 14 } else { wrong };
        // Drop the boundary of edge 10 (missed).
        masks.remove(10);
        positions.remove(10);
        expect.remove(10);
        // A spurious edge with some exact code at 15.
        masks.insert(15, 1 << 0);
        positions.insert(15, 0.5 * (positions[14] + positions[15]));
        expect.insert(15, -1);
        let mut out = vec![0; masks.len()];
        al.align(RunInput { masks: &masks, positions: &positions, period: 7.0 }, &mut out);
        for (i, (&o, &e)) in out.iter().zip(&expect).enumerate() {
            assert!(o == e || (o == -1 && (i < 2 || i + 2 >= expect.len() || i.abs_diff(4) <= 1 || i.abs_diff(10) <= 1 || i.abs_diff(15) <= 1)), "edge {i}: {o} expected {e}; all {out:?}");
        }
        let labelled = out.iter().filter(|&&o| o >= 0).count();
        assert!(labelled >= 10, "only {labelled} labelled: {out:?}");
    }

    /// On a saturated red dye only the boundaries where red changes make edges, and they
    /// say nothing of green and blue: the spacing of the edges (how many boundaries lie
    /// between them) identifies them, and no edge takes a wrong rank.
    #[test]
    fn one_readable_channel_is_identified_by_spacing() {
        let mut state = 0x1234_5678u32;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state
        };
        // Stripe colours with no two neighbours alike; boundary r lies between stripes
        // r and r + 1.
        let mut colours = vec![0u32];
        while colours.len() < 121 {
            let c = next() % 8;
            if c != *colours.last().unwrap() {
                colours.push(c);
            }
        }
        let digit = |a: u32, b: u32, ch: u32| ((b >> ch) & 1) as i8 - ((a >> ch) & 1) as i8;
        // A code's digits are red, green, blue in base 3, each shifted by one.
        let code = |a: u32, b: u32| (0..3).fold(0, |c, ch| c * 3 + (digit(a, b, 2 - ch) + 1) as u8);
        let codes: Vec<u8> = colours.windows(2).map(|w| code(w[0], w[1])).collect();
        let mut al = Aligner::new(codes.iter().map(|&c| (c, 7)));
        // A red dye over boundaries 30..90, stripes 7.3 pixels wide: an edge where red
        // changes, its mask every code with that red step.
        let (mut masks, mut positions, mut truth) = (vec![], vec![], vec![]);
        for r in 30..90usize {
            let red = digit(colours[r], colours[r + 1], 2);
            if red != 0 {
                let mask = (0..27u32).filter(|&c| c != 13 && (c / 9) as i8 - 1 == red).fold(0, |m, c| m | 1 << c);
                masks.push(mask);
                positions.push(7.3 * r as f32 + 0.2 * ((next() % 100) as f32 / 100.0 - 0.5));
                truth.push(r as i32);
            }
        }
        let mut out = vec![0; masks.len()];
        al.align(RunInput { masks: &masks, positions: &positions, period: 7.0 }, &mut out);
        for (i, (&o, &t)) in out.iter().zip(&truth).enumerate() {
            assert!(o == t || o == -1, "edge {i}: rank {o}, truth {t}; all {out:?}");
        }
        let named = out.iter().filter(|&&o| o >= 0).count();
        assert!(named * 2 >= masks.len(), "only {named} of {} edges identified: {out:?}", masks.len());
    }

    /// The ranks a jump may land on: those from which a step of 1 to `reach` ranks
    /// reaches one of the codes, across the 64-bit words of a 150-rank pattern.
    #[test]
    fn landing_ranks_are_those_a_short_step_follows() {
        let codes = random_codes(0x1a2d_1e55, 150);
        let al = Aligner::new(codes.iter().map(|&c| (c, 7)));
        let wanted = (1 << codes[10]) | (1 << codes[64]) | (1 << codes[129]);
        for reach in [MAX_MISSED + 1, MAX_STEP] {
            let mut out = vec![0u64; 2 * al.words];
            followed_by(&al.code_ranks, al.words, wanted, reach, &mut out);
            for r in 0..codes.len() {
                let follows = (1..=reach).any(|k| codes.get(r + k).is_some_and(|&c| wanted >> c & 1 != 0));
                assert_eq!(out[r / 64] >> (r % 64) & 1 != 0, follows, "rank {r}, reach {reach}");
            }
        }
    }

    /// One run with a depth discontinuity between ranks 29 and 60: the pattern's codes,
    /// an aligner for them, and the run's true ranks, masks and positions. The far
    /// surface's stripes are narrower (it is further away) and start right after the
    /// near one's.
    fn jump_run() -> (Vec<u8>, Aligner, Vec<i32>, Vec<u32>, Vec<f32>) {
        let codes = random_codes(0x0bad_5eed, 100);
        let al = Aligner::new(codes.iter().map(|&c| (c, 7)));
        let truth: Vec<i32> = (10..30).chain(60..80).collect();
        let masks = truth.iter().map(|&r| 1u32 << codes[r as usize]).collect();
        let positions = truth.iter().map(|&r| if r < 30 { 7.0 * r as f32 } else { 210.0 + 5.0 * (r - 59) as f32 }).collect();
        (codes, al, truth, masks, positions)
    }

    /// A depth discontinuity inside one run: the ranks jump from 30 to 60. The edges
    /// beyond it take their true ranks (or none), never ranks carried on from before,
    /// and at most the first two stay empty.
    #[test]
    fn a_jump_inside_a_run_is_followed() {
        let (_, mut al, truth, masks, positions) = jump_run();
        let mut out = vec![0; masks.len()];
        al.align(RunInput { masks: &masks, positions: &positions, period: 7.0 }, &mut out);
        for (i, (&o, &t)) in out.iter().zip(&truth).enumerate() {
            assert!(o == t || o == -1, "edge {i}: rank {o}, truth {t}; all {out:?}");
        }
        let beyond = out[20..].iter().filter(|&&o| o >= 0).count();
        assert!(beyond >= 18, "only {beyond} of 20 edges beyond the jump labelled: {out:?}");
    }

    /// Texture right at a depth edge: the jump's first edge is followed by a spurious
    /// one that no step from it takes. The edges beyond still take their true ranks (or
    /// none), all but the first.
    #[test]
    fn a_jump_followed_by_a_spurious_edge_is_followed() {
        let (codes, mut al, mut truth, mut masks, mut positions) = jump_run();
        let spurious = (0..27u32).find(|&c| c != 13 && (61..=63).all(|r| codes[r] as u32 != c)).unwrap();
        masks.insert(21, 1 << spurious);
        positions.insert(21, 0.5 * (positions[20] + positions[21]));
        truth.insert(21, -1);
        let mut out = vec![0; masks.len()];
        al.align(RunInput { masks: &masks, positions: &positions, period: 7.0 }, &mut out);
        for (i, (&o, &t)) in out.iter().zip(&truth).enumerate() {
            assert!(o == t || o == -1, "edge {i}: rank {o}, truth {t}; all {out:?}");
        }
        let beyond = out[22..].iter().filter(|&&o| o >= 0).count();
        assert!(beyond >= 18, "only {beyond} of 19 edges beyond the spurious one labelled: {out:?}");
    }
}
