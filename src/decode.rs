//! Stripe identification from neighbour windows (spatially windowed uniqueness), and
//! the projector stripe coordinate of every pixel between identified boundaries.
//!
//! Along a scan line the boundaries of one run (no unusable pixel between them) are
//! matched to the pattern by their transition codes: every `window - 1` consecutive
//! codes occur once in the pattern, so each run of that many readable boundaries names
//! its first boundary. Each such window votes for the identities of all its
//! boundaries; a boundary is identified where at least two overlapping windows agree
//! and none disagrees, so a single misread code or a spurious edge leaves its
//! neighbours empty instead of wrong. This is the joint, order-preserving decoding
//! along a line: identities must increase by one from boundary to boundary, which is
//! what a dynamic-programming alignment (Zhang, Curless, Seitz 2002) enforces too,
//! restricted here to exact agreement because a wrong identity is worse than none.
//!
//! Then across lines: a stripe boundary continues from line to line, so identities are
//! checked against the boundaries at the same place on the neighbouring lines (a
//! disagreeing majority removes one) and propagated along connected boundaries to
//! those that could not be identified on their own line (short runs near occluding
//! edges, where only a partial window is visible), provided their own code matches
//! the pattern's code for that boundary.

use crate::pattern::PatternSpec;
use crate::segment::{pack, reverse, Code, Edge, ScanAxis, Segmentation, NO_CODE};
use std::collections::HashMap;

/// Largest distance between a boundary and its continuation on the next scan line,
/// pixels. Scan lines are at most 45 degrees from across the stripes, so a boundary
/// moves at most about one pixel per line; perspective and curvature add a little.
pub const CONTINUATION_TOLERANCE: f32 = 1.6;

/// How many lines above and below take part in the consistency vote.
pub const VOTE_LINES: usize = 2;

/// Propagation sweeps (down, up, down, ...) along connected boundaries.
pub const PROPAGATION_SWEEPS: usize = 4;

/// The identification tables of one stripe family.
pub struct Decoder {
    /// Transitions per window (`spec.window - 1`).
    span: usize,
    /// Pattern code of boundary j (between stripes j-1 and j), j in 1..count.
    codes: Vec<Code>,
    /// Codes of `span` consecutive boundaries → the first boundary's index.
    lookup: HashMap<u64, i32>,
    /// Boundary identities grow along the scan direction.
    increasing: bool,
    key_codes: Vec<Code>,
    votes: Vec<(i32, u8, bool)>,
}

fn key_of(codes: &[Code]) -> u64 {
    codes.iter().fold(0u64, |k, &c| k * 27 + c as u64)
}

impl Decoder {
    /// Tables for family `family` of `spec`, whose boundary index grows along the scan
    /// direction when `increasing`.
    pub fn new(spec: &PatternSpec, family: usize, increasing: bool) -> Self {
        let count = spec.families[family].count;
        let mut codes = vec![NO_CODE; count];
        for (j, c) in codes.iter_mut().enumerate().skip(1) {
            *c = pack(spec.boundary_transition(family, j));
        }
        let span = spec.window.saturating_sub(1).max(1);
        let mut lookup = HashMap::new();
        if count > span {
            for j in 1..=count - span {
                lookup.insert(key_of(&codes[j..j + span]), j as i32);
            }
        }
        Decoder { span, codes, lookup, increasing, key_codes: Vec::new(), votes: Vec::new() }
    }

    /// The pattern's code for boundary `j` as seen along the scan direction.
    fn seen_code(&self, j: i32) -> Code {
        if j < 1 || j as usize >= self.codes.len() {
            return NO_CODE;
        }
        let c = self.codes[j as usize];
        if self.increasing {
            c
        } else {
            reverse(c)
        }
    }

    /// Whether identities grow along the scan direction.
    pub fn increasing(&self) -> bool {
        self.increasing
    }

    /// Identify the boundaries of every line of `seg` (sets `Edge::id`).
    pub fn run(&mut self, seg: &mut Segmentation) {
        for line in seg.lines.iter_mut() {
            self.identify_line(line);
        }
        self.check_across_lines(seg);
        for sweep in 0..PROPAGATION_SWEEPS {
            self.propagate(seg, sweep % 2 == 0);
        }
    }

    /// Window votes along one line.
    fn identify_line(&mut self, edges: &mut [Edge]) {
        let n = edges.len();
        let span = self.span;
        self.votes.clear();
        self.votes.resize(n, (-1, 0, false));
        for e in edges.iter_mut() {
            e.id = -1;
        }
        if n < span {
            return;
        }
        for start in 0..=n - span {
            let win = &edges[start..start + span];
            if win.iter().any(|e| e.code == NO_CODE || e.run != win[0].run) {
                continue;
            }
            // In pattern order: along the scan for increasing families, reversed and
            // with reversed transitions otherwise.
            self.key_codes.clear();
            if self.increasing {
                self.key_codes.extend(win.iter().map(|e| e.code));
            } else {
                self.key_codes.extend(win.iter().rev().map(|e| reverse(e.code)));
            }
            let Some(&first) = self.lookup.get(&key_of(&self.key_codes)) else {
                continue;
            };
            for k in 0..span {
                // The identity of edges[start + k].
                let id = if self.increasing { first + k as i32 } else { first + (span - 1 - k) as i32 };
                let v = &mut self.votes[start + k];
                if v.1 == 0 {
                    *v = (id, 1, false);
                } else if v.0 == id {
                    v.1 = v.1.saturating_add(1);
                } else {
                    v.2 = true; // conflicting windows
                }
            }
        }
        for (e, v) in edges.iter_mut().zip(&self.votes) {
            if v.1 >= 2 && !v.2 {
                e.id = v.0;
            }
        }
    }

    /// Remove identities that the neighbouring lines contradict.
    fn check_across_lines(&self, seg: &mut Segmentation) {
        let nlines = seg.lines.len();
        for line in 0..nlines {
            for i in 0..seg.lines[line].len() {
                let e = seg.lines[line][i];
                if e.id < 0 {
                    continue;
                }
                let (mut agree, mut disagree) = (0, 0);
                for d in 1..=VOTE_LINES {
                    for other in [line.checked_sub(d), (line + d < nlines).then_some(line + d)].into_iter().flatten() {
                        if let Some(o) = nearest(&seg.lines[other], e.pos, CONTINUATION_TOLERANCE * d as f32) {
                            if o.id == e.id {
                                agree += 1;
                            } else if o.id >= 0 {
                                disagree += 1;
                            }
                        }
                    }
                }
                if disagree > agree {
                    seg.lines[line][i].id = -1;
                }
            }
        }
    }

    /// One sweep of propagation along connected boundaries (`down`: from line l-1 to
    /// l; otherwise from l+1 to l), and along the line to the next boundary of a run.
    fn propagate(&self, seg: &mut Segmentation, down: bool) {
        let nlines = seg.lines.len();
        let step: i32 = if self.increasing { 1 } else { -1 };
        for k in 0..nlines {
            let line = if down { k } else { nlines - 1 - k };
            let from = if down { line.checked_sub(1) } else { (line + 1 < nlines).then_some(line + 1) };
            if let Some(from) = from {
                let (a, b) = if from < line {
                    let (lo, hi) = seg.lines.split_at_mut(line);
                    (&lo[from], &mut hi[0])
                } else {
                    let (lo, hi) = seg.lines.split_at_mut(from);
                    (&hi[0], &mut lo[line])
                };
                for e in b.iter_mut().filter(|e| e.id < 0 && e.code != NO_CODE) {
                    if let Some(o) = nearest(a, e.pos, CONTINUATION_TOLERANCE) {
                        if o.id >= 0 && self.seen_code(o.id) == e.code {
                            e.id = o.id;
                        }
                    }
                }
            }
            // Along the line, within a run: the next boundary is the next identity.
            let edges = &mut seg.lines[line];
            for i in 1..edges.len() {
                let (p, e) = (edges[i - 1], edges[i]);
                if p.run != e.run {
                    continue;
                }
                if e.id < 0 && p.id >= 0 && e.code != NO_CODE && self.seen_code(p.id + step) == e.code {
                    edges[i].id = p.id + step;
                }
            }
            for i in (0..edges.len().saturating_sub(1)).rev() {
                let (e, nx) = (edges[i], edges[i + 1]);
                if nx.run != e.run {
                    continue;
                }
                if e.id < 0 && nx.id >= 0 && e.code != NO_CODE && self.seen_code(nx.id - step) == e.code {
                    edges[i].id = nx.id - step;
                }
            }
        }
    }

    /// The stripe coordinate (pattern units: boundary j at j) of every pixel that lies
    /// between two identified, consecutive boundaries of the same run; NaN elsewhere.
    /// Consecutive boundaries further apart than `max_width` pixels are not bridged.
    pub fn stripe_coords_into(&self, seg: &Segmentation, width: usize, max_width: f32, out: &mut [f32]) {
        out.iter_mut().for_each(|q| *q = f32::NAN);
        let Some(axis) = seg.axis else { return };
        let step = if self.increasing { 1 } else { -1 };
        for (line, edges) in seg.lines.iter().enumerate() {
            for pair in edges.windows(2) {
                let (a, b) = (pair[0], pair[1]);
                if a.id < 0 || b.id != a.id + step || a.run != b.run || b.pos - a.pos > max_width || b.pos <= a.pos {
                    continue;
                }
                let first = a.pos.ceil() as usize;
                let mut s = first;
                while (s as f32) < b.pos {
                    let t = (s as f32 - a.pos) / (b.pos - a.pos);
                    out[axis_index(axis, line, s, width)] = a.id as f32 + step as f32 * t;
                    s += 1;
                }
            }
        }
    }
}

#[inline]
fn axis_index(axis: ScanAxis, line: usize, s: usize, width: usize) -> usize {
    axis.index(line, s, width)
}

/// The edge of `edges` (sorted by position) nearest to `pos` within `tol`.
fn nearest(edges: &[Edge], pos: f32, tol: f32) -> Option<Edge> {
    let i = edges.partition_point(|e| e.pos < pos);
    let mut best: Option<Edge> = None;
    for j in [i.wrapping_sub(1), i] {
        if let Some(e) = edges.get(j) {
            let d = (e.pos - pos).abs();
            if d <= tol && best.is_none_or(|b| d < (b.pos - pos).abs()) {
                best = Some(*e);
            }
        }
    }
    best
}
