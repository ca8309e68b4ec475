//! Stripe identification from neighbour sequences (spatially windowed uniqueness), and
//! the projector stripe coordinate of every pixel between identified boundaries.
//!
//! Along a scan line the boundaries of one run (no unusable pixel between them) are
//! aligned to the pattern by the transitions they are compatible with
//! ([`crate::segment::CodeMask`]): a dynamic-programming alignment over stripe
//! identities (see [`crate::align`]) that keeps the pattern's order and tolerates
//! spurious edges, missed boundaries and misread transitions, and leaves an edge empty
//! unless its identity is well ahead of every other (a wrong identity is worse than
//! none). Every `window - 1` consecutive transitions occur once in the pattern, so a
//! few clean boundaries in a row are enough; looser evidence (a channel too dark to read
//! on a saturated dye, or clipped) needs more of them. Only every other line is
//! aligned so; a line between takes the identities the lines either side agree on,
//! unless too many of its edges are in doubt (`Decoder::infer_line`).
//!
//! Then across lines: a stripe boundary continues from line to line, so identities are
//! checked against the boundaries at the same place on the neighbouring lines (a
//! disagreeing majority removes one, and so does no agreeing neighbour at all: texture
//! in light the projector does not reach can fit by chance on one line, but not the
//! same identities on the next) and propagated along connected boundaries to those
//! that could not be identified on their own line (short runs near occluding edges,
//! where only a partial window is visible), provided their own code matches the
//! pattern's code for that boundary (is compatible with it). Last, boundaries that no
//! line could identify with enough margin are labelled by their chains: the lines'
//! best readings of one boundary, summed along it (`Decoder::label_chains`); the
//! merge keeps what those labels give only where another family's depths at or around
//! the pixel agree with it.

use crate::num::max_f32;
use crate::align::{blind_channels, changed_channels, Aligner, RunInput, MAX_STEP};
use crate::pattern::PatternSpec;
use crate::segment::{for_line_chunks, pack, reverse, unpack, Code, CodeMask, Edge, ScanAxis, Segmentation, Tentative, DARK_LEVEL, LINE_CHUNKS, NO_CODE};

/// Largest distance between a boundary and its continuation on the next scan line,
/// pixels. Scan lines are at most 45 degrees from across the stripes, so a boundary
/// moves at most about one pixel per line; perspective and curvature add a little.
pub const CONTINUATION_TOLERANCE: f32 = 1.6;

/// How many lines above and below take part in the consistency vote.
pub const VOTE_LINES: usize = 2;

/// Lines either side whose positions of the same boundary refine an identified
/// boundary's position (see [`Decoder::smooth_positions`]).
pub const SMOOTH_LINES: usize = 3;

/// Lines either side of the longer fit along a boundary's chain, taken where it agrees
/// with the fit over [`SMOOTH_LINES`] within [`SMOOTH_AGREE`] (see
/// [`Decoder::smooth_positions`]).
pub const SMOOTH_LINES_LONG: usize = 7;

/// How far apart, pixels, the fits over [`SMOOTH_LINES_LONG`] and [`SMOOTH_LINES`]
/// lines either side may put a boundary for the longer one to be taken: where they
/// differ by more, the chain bends over the longer reach (a crease, a curved surface,
/// the lens's distortion) and the shorter fit is nearer the truth. Measured on the
/// `webcam`, `soft` and `default` rows of wood, paper, skin, colorchecker, sphere,
/// occluders, textured and bag (`eval --hard`, 24 rows; mean RMSE, outliers): the
/// shorter fit alone 0.596 mm, 0.295 %; the longer fit alone 0.584 mm, 0.288 %, but
/// crumpled paper worse (paper/default 0.569 -> 0.622 mm) and the flat wall too under
/// `partial` (0.201 -> 0.237 mm); the longer one where the two agree within 0.05 px
/// 0.588 mm, within 0.1 px 0.579 mm and 0.293 % (paper/default 0.584 mm), within 0.15
/// px 0.577 mm and 0.291 % (paper/default 0.601 mm; under `partial`, `clipped`,
/// `shoulder`, `narrow` and `world`, paper, paper-dye, the wall and the plane 0.378 mm
/// against 0.372 mm with the shorter fit alone and 0.369 mm with 0.1 px).
pub const SMOOTH_AGREE: f32 = 0.1;

/// How far, pixels, a boundary's position on a line may be from the straight line
/// through its chain for the chain to be smoothed (see [`Decoder::smooth_positions`]):
/// about twice the sub-pixel noise of a webcam frame (JPEG, 4:2:0), below the jumps
/// where a chain crosses from one surface to another. At 0.6 the occluders scene gave
/// a fifth more outliers away from its depth edges than without smoothing; at 0.4,
/// fewer.
pub const SMOOTH_TOLERANCE: f32 = 0.4;

/// How far an identified boundary moves toward where its four neighbours on the line
/// put it (see [`Decoder::smooth_positions`]): one half. Measured on the `default`,
/// `webcam`, `world` and `wide` rows of eight scenes (sphere, paper, occluders,
/// colorchecker, sphere-dye, paper-dye, bag, wood; rows meeting issue 10's goals, mean
/// coverage / outliers), with [`ALONG_LINE_FIT`]: none 12 of 32, 82.89 % / 0.765 %;
/// 0.5 14 of 32, 82.98 % / 0.714 %. Without [`ALONG_LINE_FIT`] (stripes within a
/// third of each other's widths instead), 13 of 32 and 0.807 %: the `wide` rows of
/// the crumpled paper went from 3.02 % to 4.5 % outliers.
pub const ALONG_LINE_SHARE: f32 = 0.5;

/// How much, pixels, the stripes beyond a boundary's two neighbours may differ in width
/// from each other, and the two around the boundary together from those two, for the
/// boundary to move toward where its neighbours put it: a depth edge, a fold or a
/// crease between them changes the stripes' widths by more. Measured as
/// [`ALONG_LINE_SHARE`]: 1.0 px 13 of 32 rows, 0.719 %; 1.5 px 14, 0.714 %; 2.0 px
/// 14, 0.722 % (the `wide` rows lose what the `webcam` rows gain).
pub const ALONG_LINE_FIT: f32 = 1.5;

/// Share of a line's edges that may be in doubt (see `Decoder::infer_line`) for the
/// line to take its identities from the aligned lines either side instead of being
/// aligned itself. Why: the alignment is most of the decoding's time, and a stripe
/// boundary continues from line to line, so where the lines either side agree, the
/// line between almost always reads the same. Measured on the `default`, `webcam`,
/// `narrow` and `world` rows of eight scenes (sphere, paper, occluders,
/// colorchecker, sphere-dye, paper-dye, bag, wood; mean coverage / outliers), and on
/// the textured webcam frame (`examples/bench_frame`, one thread, decoding stages of
/// the fastest frame): every line aligned 85.57 % / 0.286 %, 28.1 + 16.5 ms; a share
/// of 0.08 85.50 % / 0.279 %, 23.5 + 15.3 ms; 0.15 85.31 % / 0.271 %, 19.2 + 14.1
/// ms; no line aligned for doubt 84.90 % / 0.259 %. Edges in doubt taking the one
/// identity a neighbour has: 86.17 % / 0.417 %. Aligning only a window of a dozen
/// edges around each edge in doubt cost nearly as much as the whole line.
pub const INFER_DOUBT_SHARE: f32 = 0.1;

/// Propagation sweeps (down, up, down, ...) along connected boundaries.
pub const PROPAGATION_SWEEPS: usize = 4;

/// Most compatible transitions (of those the pattern uses) an edge may have to take an
/// identity by propagation:
/// propagation checks one identity only, so a loose edge would take it by chance.
pub const MAX_PROPAGATION_CODES: u32 = 1;

/// Agreeing boundaries on the neighbouring lines an identity needs to be kept.
pub const MIN_LINE_SUPPORT: usize = 2;

/// Most bits one line's reading of an edge adds to its chain's vote (see
/// `Decoder::label_chains`): a line whose alignment is sure counts as much as one
/// edge taken at once, and no more.
pub const CHAIN_EDGE_CAP_BITS: f32 = crate::align::ACCEPT_BITS;

/// Margin of a chain's leading identity over the next, summed over its lines, for the
/// chain to be labelled with it: as much as one line needs to take an edge at once.
pub const CHAIN_ACCEPT_BITS: f32 = crate::align::ACCEPT_BITS;


/// The identification tables of one stripe family.
pub struct Decoder {
    /// The family's stripe width in the projector's image, its pixels.
    stripe_px: f32,
    /// Pattern code of boundary j (between stripes j-1 and j), j in 0..=count;
    /// [`NO_CODE`] for the outer two unless the stripes leave a margin there.
    codes: Vec<Code>,
    /// The channels (bit c) the projector lights on either side of boundary j.
    lit: Vec<u8>,
    /// The projector's colour of stripe j (between boundaries j and j + 1) at `j + 1`,
    /// j in -1..=count (the background beyond either end).
    colors: Vec<[f32; 3]>,
    /// Boundary identities grow along the scan direction.
    increasing: bool,
    /// The codes some boundary of the pattern shows, as seen along the scan direction.
    used_codes: CodeMask,
    /// The positions of every line's edges, in order (flat: line after line), as
    /// segmentation placed them (what [`Decoder::smooth_positions`] fits) ...
    placed: Vec<f32>,
    /// ... and as it refined them.
    smoothed: Vec<f32>,
    /// Where each line's edges start in the flat order, and one past the last line.
    line_start: Vec<usize>,
    /// Per chunk of lines ([`LINE_CHUNKS`], aligned at once with threads): the alignment
    /// of a run to the pattern, its masks and its ranks.
    aligners: Vec<RunAligner>,
    /// Per edge (flat order), its boundary's continuation on the previous and on the
    /// next line ([`NO_LINK`] where there is none).
    up: Vec<u32>,
    down: Vec<u32>,
    /// The edges of one line whose identities its neighbours contradict.
    dropped: Vec<u32>,
    /// Per line, whether it is aligned in full after inference left it in doubt.
    realign: Vec<bool>,
    /// The pixels [`Decoder::stripe_coords_into`] gave their coordinate by extending a
    /// decoded stretch past its last boundary (see [`EXTEND_REACH`]).
    extended: Vec<u32>,
    /// Whether boundaries are labelled by their chains across lines (see
    /// [`Decoder::label_chains`]): only where another family can confirm them.
    chains: bool,
    /// Per edge (flat order, as `line_start`), the same boundary on the next line
    /// ([`NO_LINK`] for none), whether the previous line links to it, and whether its
    /// chain labelled it; the chain being labelled and its lines' votes.
    chain_next: Vec<u32>,
    chain_linked: Vec<bool>,
    chain_labelled: Vec<bool>,
    chain: Vec<u32>,
    votes: Vec<(i32, f32)>,
    /// The pixels of the last [`Decoder::stripe_coords_into`] whose coordinate comes
    /// from a boundary its chain labelled.
    weak: Vec<u32>,
    /// The identified edges of one line (their indices), and those of them that lose
    /// their identity to [`settle_repeated_identities`].
    named: Vec<(u32, bool)>,
    /// Per chunk of lines ([`LINE_CHUNKS`]) of a family whose lines are rows, where
    /// [`Decoder::stripe_coords_into`] runs the chunks at once with threads: the
    /// chunk's masked line and the pixels it extended and took from chain labels.
    coord_chunks: Vec<CoordChunk>,
}

/// The alignment of a run to the pattern with its buffers.
#[derive(Clone)]
struct RunAligner {
    aligner: Aligner,
    masks: Vec<u32>,
    positions: Vec<f32>,
    ranks: Vec<i32>,
}

impl RunAligner {
    /// Identify every run of `edges` by its alignment to the pattern (see
    /// [`crate::align`]); `n_ranks` is the pattern's
    /// number of boundaries, `increasing` whether identities grow along the line,
    /// `period` the expected stripe period along it.
    fn align_line(&mut self, edges: &mut [Edge], increasing: bool, n_ranks: i32, period: f32) {
        let mut start = 0;
        while start < edges.len() {
            let run = edges[start].run;
            let end = start + edges[start..].iter().take_while(|e| e.run == run).count();
            self.masks.clear();
            self.masks.extend(edges[start..end].iter().map(|e| e.mask));
            self.positions.clear();
            self.positions.extend(edges[start..end].iter().map(|e| e.pos));
            self.ranks.resize(end - start, -1);
            self.aligner.align(RunInput { masks: &self.masks, positions: &self.positions, period }, &mut self.ranks);
            let id = |r: i32| if r < 0 {
                -1
            } else if increasing {
                r
            } else {
                n_ranks - 1 - r
            };
            for (e, &r) in edges[start..end].iter_mut().zip(&self.ranks) {
                e.id = id(r);
            }
            let tentative = self.aligner.tentative();
            for (i, e) in edges[start..end].iter_mut().enumerate() {
                e.tentative = tentative.get(i).map_or(Tentative::NONE, |t| Tentative { id: id(t.id), alt: id(t.alt), ..*t });
            }
            start = end;
        }
    }
}

/// Where two consecutive identified edges of a run have one identity (the same boundary
/// twice), the one that leaves the stripes either side of it as wide as each other,
/// within [`STRIPE_WIDTH_JUMP`], keeps it (of two, the nearer equal), and the other
/// loses it; `step` is +1 or -1 as identities grow or fall along the line. The widths
/// are measured to the identified boundaries one stripe before and after; where either
/// is missing, or neither edge fits, both keep their identity. `named` is scratch.
///
/// Why: a dye's or a texture's edge a few pixels from a boundary, or in the middle of a
/// stripe with a transition that fits the boundary beyond it, can be given that
/// boundary's identity by its chain or by propagation from the next line, while the
/// boundary itself keeps it too. The stripe between the edge before and the first of
/// the two then ends short, and its coordinates are stretched over the wrong pixels:
/// on `sphere` under `wide`, a dye edge 12 pixels before a boundary of a 30-pixel
/// stripe made one patch of 490 pixels 27 mm off. Measured on the `default`,
/// `webcam`, `wide`, `clipped` and `world` rows of sphere, occluders, textured, paper,
/// wood, colorchecker, bag, skin and paper-dye (`eval --hard`), mean coverage /
/// outliers 87.08 % / 0.366 % before, 87.15 % / 0.356 % after: sphere/wide 0.53 % to
/// 0.33 % outliers, textured/wide 82.5 % to 85.3 % coverage and 0.61 % to 0.47 %
/// outliers, no row worse by 0.05 points. Taking the identity from both instead (and
/// from every edge of a line out of order) lost 0.5 points of coverage and doubled
/// occluders/wide's outliers: a boundary repeated at an occluding edge is often right
/// twice.
fn settle_repeated_identities(edges: &mut [Edge], step: i32, named: &mut Vec<(u32, bool)>) {
    named.clear();
    named.extend(edges.iter().enumerate().filter(|(_, e)| e.id >= 0).map(|(i, _)| (i as u32, false)));
    for k in 1..named.len().saturating_sub(2) {
        let [p, a, b, q] = [k - 1, k, k + 1, k + 2].map(|j| edges[named[j].0 as usize]);
        let one_run = p.run == a.run && a.run == b.run && b.run == q.run;
        if a.id != b.id || !one_run || p.id != a.id - step || q.id != a.id + step {
            continue;
        }
        // How much wider the wider stripe beside each candidate is than the other.
        let unevenness = |x: f32| {
            let (before, after) = (x - p.pos, q.pos - x);
            let (wider, narrower) = if before >= after { (before, after) } else { (after, before) };
            wider / max_f32(narrower, 0.1)
        };
        let (ua, ub) = (unevenness(a.pos), unevenness(b.pos));
        if ua <= STRIPE_WIDTH_JUMP || ub <= STRIPE_WIDTH_JUMP {
            named[if ua < ub { k + 1 } else { k }].1 = true;
        }
    }
    for &(i, loses) in named.iter() {
        if loses {
            edges[i as usize].id = -1;
        }
    }
}

/// No continuation of a boundary on the neighbouring line.
const NO_LINK: u32 = u32::MAX;

impl Decoder {
    /// Tables for family `family` of `spec`, whose boundary index grows along the scan
    /// direction when `increasing`.
    pub fn new(spec: &PatternSpec, family: usize, increasing: bool) -> Self {
        let count = spec.families[family].count;
        let codes: Vec<Code> = (0..=count)
            .map(|j| {
                let inner = j > 0 && j < count;
                let t = spec.boundary_transition(family, j);
                if (inner || spec.boundary_on_image(family, j)) && t != [0; 3] {
                    pack(t)
                } else {
                    NO_CODE
                }
            })
            .collect();
        let used_codes = codes
            .iter()
            .filter(|&&c| c != NO_CODE)
            .map(|&c| if increasing { c } else { reverse(c) })
            .fold(0, |m: CodeMask, c| m | 1 << c);
        // The channels the projector lights on either side of each boundary.
        let lit: Vec<u8> = (0..=count as i64)
            .map(|j| {
                let (a, b) = (spec.stripe_color(family, j - 1), spec.stripe_color(family, j));
                (0..3).filter(|&c| a[c] > 0.0 || b[c] > 0.0).fold(0, |m, c| m | 1 << c)
            })
            .collect();
        let colors = (-1..=count as i64).map(|j| spec.stripe_color(family, j).map(|v| v as f32)).collect();
        let n = codes.len();
        let rank_id = |r: usize| if increasing { r } else { n - 1 - r };
        let aligner = Aligner::new((0..n).map(|r| {
            let c = codes[rank_id(r)];
            (if increasing { c } else { reverse(c) }, lit[rank_id(r)])
        }));
        Decoder {
            stripe_px: spec.families[family].stripe_width as f32,
            codes,
            lit,
            colors,
            increasing,
            used_codes,
            placed: Vec::new(),
            smoothed: Vec::new(),
            line_start: Vec::new(),
            aligners: vec![RunAligner { aligner, masks: Vec::new(), positions: Vec::new(), ranks: Vec::new() }; LINE_CHUNKS],
            up: Vec::new(),
            down: Vec::new(),
            dropped: Vec::new(),
            realign: Vec::new(),
            extended: Vec::new(),
            chains: spec.families.len() >= 2,
            chain_next: Vec::new(),
            chain_linked: Vec::new(),
            chain_labelled: Vec::new(),
            weak: Vec::new(),
            named: Vec::new(),
            coord_chunks: Vec::new(),
            chain: Vec::new(),
            votes: Vec::new(),
        }
    }

    /// Whether boundary `j` can be what an edge with the compatible codes `mask` shows.
    #[inline]
    fn fits(&self, mask: CodeMask, j: i32) -> bool {
        let c = self.seen_code(j);
        c != NO_CODE && mask & (1 << c) != 0
    }

    /// [`Decoder::fits`] for propagation: only edges with specific evidence.
    #[inline]
    fn confirms(&self, mask: CodeMask, j: i32) -> bool {
        (mask & self.used_codes).count_ones() <= MAX_PROPAGATION_CODES && self.fits(mask, j)
    }

    /// The pattern's code for boundary `j` as seen along the scan direction.
    fn seen_code(&self, j: i32) -> Code {
        if j < 0 || j as usize >= self.codes.len() {
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

    /// Identify the boundaries of every line of `seg` (sets `Edge::id`); `period` is the
    /// expected stripe period along the lines, pixels.
    pub fn run(&mut self, seg: &mut Segmentation, period: f32) {
        // Every other line is aligned on its own (with threads, chunks of lines at once);
        // the lines between take what the lines either side agree on.
        self.align_lines(seg, period, |line| line % 2 == 0);
        // Inference reads only the aligned even lines, so the odd lines it leaves in
        // doubt are then aligned in full at once, as the even ones were.
        let mut realign = std::mem::take(&mut self.realign);
        realign.clear();
        realign.resize(seg.lines.len(), false);
        for line in (1..seg.lines.len()).step_by(2) {
            let doubtful = match seg.lines.get_mut(line - 1..=line + 1) {
                Some([before, edges, after]) => self.infer_line(before, after, edges),
                _ => usize::MAX,
            };
            realign[line] = doubtful as f32 > INFER_DOUBT_SHARE * seg.lines[line].len() as f32;
        }
        self.align_lines(seg, period, |line| realign[line]);
        self.realign = realign;
        self.check_across_lines(seg);
        for sweep in 0..PROPAGATION_SWEEPS {
            self.propagate(seg, sweep % 2 == 0);
        }
        if self.chains {
            self.label_chains(seg);
        }
        let step = if self.increasing { 1 } else { -1 };
        for edges in seg.lines.iter_mut() {
            settle_repeated_identities(edges, step, &mut self.named);
        }
    }

    /// Align the lines of `seg` that `chosen` picks (by index), each on its own (with
    /// threads, chunks of lines at once).
    fn align_lines(&mut self, seg: &mut Segmentation, period: f32, chosen: impl Fn(usize) -> bool + Sync + Send) {
        let (n_ranks, increasing) = (self.codes.len() as i32, self.increasing);
        for_line_chunks(&mut seg.lines, &mut self.aligners, |start, lines, a| {
            for (k, edges) in lines.iter_mut().enumerate() {
                if chosen(start + k) {
                    a.align_line(edges, increasing, n_ranks, period);
                }
            }
        });
    }

    /// Label boundaries by their chains across lines where no line was sure, after the
    /// lines' own identities, the vote across lines and propagation.
    ///
    /// A stripe boundary continues from line to line, so the edges that continue each
    /// other (nearest on the next line within [`CONTINUATION_TOLERANCE`], both ways,
    /// with a transition both are compatible with) are one boundary with one identity.
    /// Each line's alignment votes for the identity it found best ([`Tentative`]) with
    /// its margin over the runner-up, at most [`CHAIN_EDGE_CAP_BITS`], unless it found
    /// the edge more likely spurious. The chain takes the leading identity where it
    /// leads the next by [`CHAIN_ACCEPT_BITS`], and gives it to its unlabelled edges
    /// that fit its transition. [`Decoder::weak`] lists the pixels whose coordinate
    /// comes from such a label: the merge keeps them only where another family's
    /// depths at or around them agree ([`crate::merge::remove_unconfirmed`]).
    ///
    /// Why: on a saturated dye only one or two channels can be read, and the codes
    /// they show repeat every few boundaries, so a line's best labelling is often right
    /// but only a few bits ahead of one shifted by two stripes; the same boundary on
    /// twenty lines is twenty such readings. They are not independent, though: where a
    /// patch of dye ends on a stripe boundary, every line along the patch's edge reads
    /// the same wrong transition there, and the chain takes the wrong identity with
    /// many votes. On 16 rows of the hard evaluation (default and webcam; sphere,
    /// paper, occluders, colorchecker, sphere-dye, paper-dye, bag, wood), mean coverage
    /// / outliers: 83.99 % / 0.504 % without chains; chains labelling before the vote
    /// across lines, kept without confirmation, 89.69 % / 0.897 %; with a margin of 20
    /// bits, continuations within 0.7 pixels and labels that break their line's order
    /// or spacing removed, 88.44 % / 0.619 %; after propagation and confirmed by
    /// another family, 86.31 % / 0.372 % (with the order check 85.40 % / 0.394 %).
    ///
    /// Tried on 2026-12-05 and not kept: a chain's label taken as the line's own (no
    /// confirmation asked) where the next two identified edges on one side of it, in
    /// its run and not chain-labelled, carry the next two identities and the stripe
    /// between is as wide as the one beyond within [`STRIPE_WIDTH_JUMP`]. The band
    /// beside a depth edge is where this was meant for: on `wood`, the board's first
    /// stripes right of the plank, which only family 0 reads and only by chains. On
    /// the `default`, `webcam`, `world` and `wide` rows of wood, colorchecker, bag,
    /// skin, paper-dye and occluders (24 rows, mean coverage / outliers) it gave 85.75
    /// % / 0.410 % -> 86.17 % / 0.455 %; without extending past such an edge 86.06 % /
    /// 0.438 %; stripes within 1.15 of each other 86.13 % / 0.440 %; with the line's
    /// own best identity agreeing too 86.01 % / 0.442 %: about ten right pixels per
    /// wrong one, at half-lit pixels along depth edges and shadows, and no goal met
    /// (wood/world 93.7 -> 94.1 %, its goal 94.24 %).
    fn label_chains(&mut self, seg: &mut Segmentation) {
        let lines = &mut seg.lines;
        self.line_start.clear();
        let mut total = 0;
        for edges in lines.iter() {
            self.line_start.push(total);
            total += edges.len();
        }
        self.line_start.push(total);
        self.chain_next.clear();
        self.chain_next.resize(total, NO_LINK);
        self.chain_linked.clear();
        self.chain_linked.resize(total, false);
        self.chain_labelled.clear();
        self.chain_labelled.resize(total, false);
        for l in 1..lines.len() {
            let (a, b) = (self.line_start[l - 1], self.line_start[l]);
            link_continuations(&lines[l - 1], &lines[l], a, b, &mut self.chain_next, &mut self.chain_linked);
        }
        let mut l0 = 0;
        for head in 0..total {
            while self.line_start[l0 + 1] <= head {
                l0 += 1;
            }
            if self.chain_linked[head] || self.chain_next[head] == NO_LINK {
                continue;
            }
            // The chain from its first edge, and its lines' votes.
            self.chain.clear();
            self.votes.clear();
            let (mut i, mut l) = (head, l0);
            loop {
                self.chain.push(i as u32);
                let t = lines[l][i - self.line_start[l]].tentative;
                if t.id >= 0 && t.spurious_margin >= 0.0 {
                    let w = t.margin.min(CHAIN_EDGE_CAP_BITS);
                    match self.votes.iter_mut().find(|v| v.0 == t.id) {
                        Some(v) => v.1 += w,
                        None => self.votes.push((t.id, w)),
                    }
                }
                match self.chain_next[i] {
                    NO_LINK => break,
                    next => (i, l) = (next as usize, l + 1),
                }
            }
            let (mut lead, mut runner) = ((-1, 0.0f32), 0.0f32);
            for &(id, w) in &self.votes {
                if w > lead.1 {
                    (runner, lead) = (lead.1, (id, w));
                } else if w > runner {
                    runner = w;
                }
            }
            if lead.0 < 0 || lead.1 - runner < CHAIN_ACCEPT_BITS {
                continue;
            }
            for (k, &i) in self.chain.iter().enumerate() {
                let l = l0 + k;
                let e = &mut lines[l][i as usize - self.line_start[l]];
                if e.id < 0 && self.fits(e.mask, lead.0) {
                    e.id = lead.0;
                    self.chain_labelled[i as usize] = true;
                }
            }
        }
    }

    /// Label the edges of a line from the lines `before` and `after` it, already
    /// aligned, without aligning it: an edge whose continuations on both (the nearest
    /// edges within [`CONTINUATION_TOLERANCE`]) have one identity that fits its own
    /// transition takes it, with the reading of the line before (for the chains'
    /// vote); one whose continuations are both unidentified or missing stays
    /// unidentified. The rest are in doubt and stay unidentified; returns how many.
    fn infer_line(&self, before: &[Edge], after: &[Edge], edges: &mut [Edge]) -> usize {
        let mut near_before = Nearest::new(before, CONTINUATION_TOLERANCE);
        let mut near_after = Nearest::new(after, CONTINUATION_TOLERANCE);
        let mut doubtful = 0;
        for e in edges.iter_mut() {
            let (b, a) = (near_before.at(e.pos), near_after.at(e.pos));
            let id = |o: Option<Edge>| o.map_or(-1, |o| o.id);
            let (id_before, id_after) = (id(b), id(a));
            e.id = -1;
            e.tentative = Tentative::NONE;
            if id_before >= 0 && id_before == id_after && self.fits(e.mask, id_before) {
                e.id = id_before;
                e.tentative = b.map_or(Tentative::NONE, |b| b.tentative);
            } else if id_before >= 0 || id_after >= 0 {
                doubtful += 1;
            }
        }
        doubtful
    }

    /// Remove identities that the neighbouring lines contradict.
    fn check_across_lines(&mut self, seg: &mut Segmentation) {
        let nlines = seg.lines.len();
        for line in 0..nlines {
            // The lines either side, each walked once along this line's edges.
            let mut others: [Option<Nearest>; 2 * VOTE_LINES] = Default::default();
            for d in 1..=VOTE_LINES {
                let tol = CONTINUATION_TOLERANCE * d as f32;
                others[2 * (d - 1)] = line.checked_sub(d).map(|o| Nearest::new(&seg.lines[o], tol));
                others[2 * (d - 1) + 1] = (line + d < nlines).then(|| Nearest::new(&seg.lines[line + d], tol));
            }
            self.dropped.clear();
            for (i, e) in seg.lines[line].iter().enumerate() {
                if e.id < 0 {
                    continue;
                }
                let (mut agree, mut disagree) = (0, 0);
                for o in others.iter_mut().flatten().filter_map(|n| n.at(e.pos)) {
                    if o.id == e.id {
                        agree += 1;
                    } else if o.id >= 0 {
                        disagree += 1;
                    }
                }
                if disagree > agree || agree < MIN_LINE_SUPPORT {
                    self.dropped.push(i as u32);
                }
            }
            // After the line's votes (which read only the other lines), so that the
            // lines below see this line's removals, as they always have.
            for &i in &self.dropped {
                seg.lines[line][i as usize].id = -1;
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
                let mut near = Nearest::new(a, CONTINUATION_TOLERANCE);
                for e in b.iter_mut().filter(|e| e.id < 0) {
                    if let Some(o) = near.at(e.pos) {
                        if o.id >= 0 && self.confirms(e.mask, o.id) {
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
                if e.id < 0 && p.id >= 0 && self.confirms(e.mask, p.id + step) {
                    edges[i].id = p.id + step;
                }
            }
            for i in (0..edges.len().saturating_sub(1)).rev() {
                let (e, nx) = (edges[i], edges[i + 1]);
                if nx.run != e.run {
                    continue;
                }
                if e.id < 0 && nx.id >= 0 && self.confirms(e.mask, nx.id - step) {
                    edges[i].id = nx.id - step;
                }
            }
        }
    }

    /// Refine the position of every identified boundary with the same boundary on the
    /// neighbouring lines: a straight line through its positions on up to
    /// [`SMOOTH_LINES`] lines either side, evaluated on the boundary's own line. The
    /// chain is followed line by line with the same identity, within
    /// [`CONTINUATION_TOLERANCE`] per line. A boundary keeps its own position at the
    /// end of a chain (it needs a continuation on both sides: an occluding edge, a
    /// shadow) and where a position of the chain is further than [`SMOOTH_TOLERANCE`]
    /// from the fitted line (a bend: two surfaces meeting), unless its own position is
    /// the only one: then it takes the line through the others (one line's position
    /// thrown by noise or a JPEG block; on the `webcam` rows of `eval --hard` this took
    /// the mean outliers of 8 scenes from 0.787 % to 0.742 %). Where the chain goes on
    /// straight for [`SMOOTH_LINES_LONG`] lines either side and the line through those
    /// puts the boundary within [`SMOOTH_AGREE`] of the shorter fit, it takes the
    /// longer one, which averages twice the lines.
    ///
    /// Why: a boundary's sub-pixel position comes from three samples of one line's
    /// gradient, and the camera's noise, JPEG's blocks and interpolated 4:2:0 chroma
    /// move it by a few tenths of a pixel, independently enough from line to line that
    /// a fit over seven lines (or fifteen) takes most of that out, while a straight line through
    /// them keeps slanted and gently curved stripes where they are.
    ///
    /// Then each identified boundary whose two neighbours on either side along the line
    /// are the next boundaries of the pattern moves [`ALONG_LINE_SHARE`] of the way to
    /// where those four put it, where the stripes around them change width smoothly
    /// ([`ALONG_LINE_FIT`]): the pattern's stripes are equally wide, so the camera
    /// sees their widths change only with the surface's slant and distance. The
    /// prediction is the cubic through the four neighbours (the midpoint of the two
    /// nearest, less a sixth of how much wider the stripe beyond the next is than the
    /// stripe beyond the previous): exact where the widths change linearly, as they do
    /// on a slanted plane. Why: through JPEG and 4:2:0 chroma, the errors of a
    /// boundary's position are correlated over four lines or so (the chroma blocks),
    /// which the fit along the chain cannot take out, and their tail comes from
    /// transitions with little luma. On `paper` under `webcam`, after the fit along the
    /// chains, 9-11 % of the boundaries where only red or only blue changes were more
    /// than 0.6 px off, against 0.1-0.9 % where green or all three change, and most of
    /// its outliers were those few tenths of a pixel (0.49 of its 0.70 % were within 1.5
    /// times the outlier threshold). The midpoint alone, without the cubic's
    /// correction, took the plane under `wide` from 0.23 to 0.54 mm RMSE: with
    /// 25-pixel stripes, perspective widens each stripe by about 0.3 px over the last.
    pub fn smooth_positions(&mut self, seg: &mut Segmentation) {
        let lines = &seg.lines;
        self.line_start.clear();
        let mut total = 0;
        for edges in lines {
            self.line_start.push(total);
            total += edges.len();
        }
        self.line_start.push(total);
        // Each boundary's continuation on the lines either side, found once.
        for links in [&mut self.up, &mut self.down] {
            links.clear();
            links.resize(total, NO_LINK);
        }
        for l in 1..lines.len() {
            let (a, b) = (self.line_start[l - 1], self.line_start[l]);
            link_lines(&lines[l - 1], &lines[l], b, &mut self.down[a..b]);
            link_lines(&lines[l], &lines[l - 1], a, &mut self.up[b..self.line_start[l + 1]]);
        }
        self.placed.clear();
        self.placed.extend(lines.iter().flatten().map(|e| e.pos));
        let out = &mut self.smoothed;
        out.clear();
        for (flat, e) in lines.iter().flatten().enumerate() {
            out.push(if e.id < 0 { e.pos } else { fit_along_chain(&self.placed, &self.up, &self.down, flat) });
        }
        let mut flat = 0;
        for edges in seg.lines.iter_mut() {
            let fitted = &out[flat..flat + edges.len()];
            flat += edges.len();
            for i in 0..edges.len() {
                let pos = toward_neighbours(edges, fitted, i).unwrap_or(fitted[i]);
                edges[i].pos = pos;
            }
        }
    }

    /// The stripe coordinate (pattern units: boundary j at j) of every pixel that lies
    /// between two identified boundaries of the same run, consecutive on the line and at
    /// most [`MAX_STEP`] stripes apart in the pattern (boundaries between them showed no
    /// edge, or edges just where they are: `misread_boundaries`); NaN elsewhere. A
    /// single stripe wider than `max_width` pixels is not bridged, nor `k` stripes
    /// wider than `max_width · (k + 2) / 3`, nor stripes with a
    /// pixel inside them lit less than [`SHADOW_SHARE`] of their ends, nor a single
    /// stripe darker than the pattern allows beside a neighbour (`Decoder::shadowed`;
    /// `linear`, the frame's linear colour). Then each decoded stretch is extended
    /// into the stripe beyond either end ([`EXTEND_REACH`]); [`Decoder::extended`]
    /// tells which pixels were.
    pub fn stripe_coords_into(&mut self, seg: &Segmentation, linear: &[[f32; 3]], width: usize, max_width: f32, out: &mut [f32]) {
        out.iter_mut().for_each(|q| *q = f32::NAN);
        self.extended.clear();
        self.weak.clear();
        let Some(axis) = seg.axis else { return };
        let step = if self.increasing { 1 } else { -1 };
        let line_len = match axis {
            ScanAxis::Rows => width,
            ScanAxis::Columns => linear.len() / width.max(1),
        };
        // The chains' labels, when they ran on these lines (flat order).
        let chain_labelled = std::mem::take(&mut self.chain_labelled);
        let labelled_by_chains = chain_labelled.len() == seg.lines.iter().map(Vec::len).sum::<usize>();
        let mut chunks = std::mem::take(&mut self.coord_chunks);
        let geometry = LineGeometry { axis, linear, width, line_len, max_width, step };
        // Lines that are rows own their rows of `out`: chunks of them at once with
        // threads. Columns interleave in `out`: one chunk, in order.
        let per_chunk = match axis {
            ScanAxis::Rows => seg.lines.len().div_ceil(LINE_CHUNKS).max(1),
            ScanAxis::Columns => seg.lines.len().max(1),
        };
        let pixels_per_chunk = match axis {
            ScanAxis::Rows => per_chunk * width,
            ScanAxis::Columns => out.len().max(1),
        };
        chunks.resize_with(seg.lines.len().div_ceil(per_chunk).max(1), CoordChunk::default);
        let this = &*self;
        let chunk_work = |(c, ((lines, out), chunk)): (usize, ((&[Vec<Edge>], &mut [f32]), &mut CoordChunk))| {
            chunk.extended.clear();
            chunk.weak.clear();
            let first = c * per_chunk;
            let base = c * pixels_per_chunk;
            let mut flat: usize = seg.lines[..first].iter().map(Vec::len).sum();
            for (k, edges) in lines.iter().enumerate() {
                let weak: &[bool] = if labelled_by_chains { &chain_labelled[flat..flat + edges.len()] } else { &[] };
                flat += edges.len();
                let at = LineOut { line: first + k, base };
                // First the line as it was before the chains labelled any boundary,
                // then, where they did, what their labels add, into the pixels still
                // empty.
                if weak.contains(&true) {
                    let mut masked = std::mem::take(&mut chunk.masked);
                    masked.clear();
                    masked.extend(edges.iter().zip(weak).map(|(e, &w)| if w { Edge { id: -1, ..*e } } else { *e }));
                    this.line_coords(&masked, None, at, &geometry, out, chunk);
                    this.line_coords(edges, Some(weak), at, &geometry, out, chunk);
                    chunk.masked = masked;
                } else {
                    this.line_coords(edges, None, at, &geometry, out, chunk);
                }
            }
        };
        #[cfg(parallel)]
        {
            use rayon::prelude::*;
            seg.lines.par_chunks(per_chunk).zip(out.par_chunks_mut(pixels_per_chunk)).zip(chunks.par_iter_mut()).enumerate().for_each(chunk_work);
        }
        #[cfg(not(parallel))]
        seg.lines.chunks(per_chunk).zip(out.chunks_mut(pixels_per_chunk)).zip(chunks.iter_mut()).enumerate().for_each(chunk_work);
        for chunk in &chunks {
            self.extended.extend_from_slice(&chunk.extended);
            self.weak.extend_from_slice(&chunk.weak);
        }
        self.coord_chunks = chunks;
        self.chain_labelled = chain_labelled;
    }

    /// [`Decoder::stripe_coords_into`] of one line's `edges`, into `out`, the part of
    /// the frame's coordinates from `at.base` on, listing the pixels it extends and,
    /// with `weak` (which edges their chains labelled), those it gives a coordinate in
    /// `chunk`. With `weak`, only the stripes with a weak boundary at either end, into
    /// pixels still empty.
    fn line_coords(&self, edges: &[Edge], weak: Option<&[bool]>, at: LineOut, g: &LineGeometry, out: &mut [f32], chunk: &mut CoordChunk) {
        let (axis, linear, width, line_len, max_width, step) = (g.axis, g.linear, g.width, g.line_len, g.max_width, g.step);
        let line = at.line;
        let is_weak = |k: usize| weak.is_some_and(|w| w[k]);
        // The stripes are between consecutive identified edges (see `Named`).
        let mut named = std::mem::take(&mut chunk.named);
        named_edges(edges, weak, &mut named);
        for (k, pair) in named.windows(2).enumerate() {
            let (a, b) = (pair[0].edge, pair[1].edge);
            if weak.is_some() && !pair[0].weak && !pair[1].weak {
                continue;
            }
            // Stripes between consecutive identities, and across boundaries the
            // alignment skipped (on a saturated dye, those whose transition changes
            // only channels it cannot read), or that a dark band hid (see
            // [`BRIDGE_MAX_SPAN`]).
            let stripes = (b.id - a.id) * step;
            let dark_band = pair[0].before_unnamed
                && (2..=BRIDGE_MAX_STRIPES).contains(&stripes)
                && stripes as f32 * self.stripe_px <= BRIDGE_MAX_SPAN
                && bridges_unnamed(&named, k, step, stripes);
            // Or through edges without an identity that stand where the pattern's
            // boundaries are (misread), with no other edge between or, with others
            // (the surface's own texture), where the stripes either side are as wide.
            let misread = if pair[0].before_unnamed && !dark_band && stripes >= 2 {
                misread_boundaries(edges, pair[0].index, pair[1].index, stripes).filter(|_| {
                    let exact = pair[1].index - pair[0].index == stripes as usize;
                    (exact && stripes <= MISREAD_MAX_STRIPES) || (stripes <= MISREAD_TESTED_MAX_STRIPES && bridges_unnamed(&named, k, step, stripes))
                })
            } else {
                None
            };
            let misread_at = misread.unwrap_or_default();
            let misread = misread.is_some();
            if pair[0].before_unnamed && !dark_band && !misread && !bridges_unnamed(&named, k, step, 1) {
                continue;
            }
            if a.id < 0 || b.id < 0 || !(1..=MAX_STEP as i32).contains(&stripes) || a.run != b.run || b.pos <= a.pos {
                continue;
            }
            if b.pos - a.pos > max_width * (stripes + 2) as f32 / 3.0 {
                continue;
            }
            // Across skipped boundaries only where neither edge could have seen them
            // (a visible boundary without an edge is more often a wrong identity), or
            // where edges without an identity stand just where they are (misread).
            if stripes > 1 && !dark_band && !misread {
                let lit = |j: i32| self.lit.get(j as usize).copied().unwrap_or(0);
                let blind = blind_channels(a.mask) & blind_channels(b.mask) & lit(a.id) & lit(b.id);
                let hidden = |j: i32| {
                    let c = self.seen_code(j);
                    c != NO_CODE && changed_channels(c) & !blind == 0
                };
                if !(1..stripes).all(|k| hidden(a.id + k * step)) {
                    continue;
                }
            }
            // The identified stripes either side of a single stripe ([`widths_beside`]).
            let beside = if stripes == 1 { widths_beside(&named, k, step) } else { (None, None) };
            if stripes == 1 && wider_than_beside(b.pos - a.pos, beside, max_width) {
                continue;
            }
            let index = |s: usize| axis_index(axis, line, s, width);
            let lit = if dark_band { self.band_shows_stripes(linear, index, &a, &b, stripes) } else { lit_between(linear, index, a.pos, b.pos) };
            // Decoded in parts: one stripe a part through misread boundaries, else one.
            let parts = if misread { stripes } else { 1 };
            let boundary = |k: i32| {
                if k == 0 {
                    a
                } else if k == parts {
                    b
                } else {
                    Edge { pos: edges[misread_at[k as usize - 1]].pos, id: a.id + k * step, ..a }
                }
            };
            let shadowed = |k: i32| self.shadowed(linear, index, line_len, max_width / 3.0, &boundary(k), &boundary(k + 1));
            if !lit || ((stripes == 1 || misread) && (0..parts).any(shadowed)) {
                continue;
            }
            // A single stripe bends with the stripes beside it; stretches of several
            // (across skipped or misread boundaries) stay straight.
            let tangents = if stripes == 1 { stripe_tangents(b.pos - a.pos, beside) } else { [1.0; 2] };
            for k in 0..parts {
                let (p, q) = (boundary(k), boundary(k + 1));
                let (across, from, span) = (1.0 / (q.pos - p.pos), p.id as f32, (q.id - p.id) as f32);
                let mut s = p.pos.ceil() as usize;
                while (s as f32) < q.pos {
                    let (i, t) = (axis_index(axis, line, s, width), (s as f32 - p.pos) * across);
                    let v = from + span * across_stripe(t, tangents);
                    let c = &mut out[i - at.base];
                    if weak.is_none() {
                        *c = v;
                    } else if c.is_nan() {
                        *c = v;
                        chunk.weak.push(i as u32);
                    }
                    s += 1;
                }
            }
        }
        chunk.named = named;
        let light_line = LineLight { linear, axis, line, line_len, width, base: at.base };
        let CoordChunk { extended, weak: weak_pixels, .. } = chunk;
        for (i, a) in edges.iter().enumerate() {
            if a.id < 0 {
                continue;
            }
            // Past `a` when the boundary before it is the stripe before it, and
            // before `a` when the one after it is the stripe after it.
            let before = i.checked_sub(1).map(|k| edges[k]);
            let after = edges.get(i + 1).copied();
            let from = extended.len();
            // (Most identified edges lie inside a decoded stretch: whether there is
            // anything to extend is asked before the width.)
            if let Some(first) = extension_start(&light_line, a, 1, out) {
                if let Some(w) = extension_width(edges, i, -1, step) {
                    if weak.is_none() || is_weak(i) || is_weak(i - 1) {
                        extend_stripe(&light_line, a, first, w, 1, after.map(|e| e.pos), step, out, extended);
                    }
                }
            }
            if let Some(first) = extension_start(&light_line, a, -1, out) {
                if let Some(w) = extension_width(edges, i, 1, step) {
                    if weak.is_none() || is_weak(i) || is_weak(i + 1) {
                        extend_stripe(&light_line, a, first, w, -1, before.map(|e| e.pos), step, out, extended);
                    }
                }
            }
            if weak.is_some() {
                weak_pixels.extend_from_slice(&extended[from..]);
            }
        }
    }

    /// The pixels into which the last [`Decoder::stripe_coords_into`] extended a
    /// decoded stretch (each once).
    pub fn extended(&self) -> &[u32] {
        &self.extended
    }

    /// The pixels whose coordinate the last [`Decoder::stripe_coords_into`] took from a
    /// boundary labelled by its chain alone (see `Decoder::label_chains`).
    pub fn weak(&self) -> &[u32] {
        &self.weak
    }
}

/// How far past a decoded stretch's last boundary, in widths of its last stripes
/// (`extension_width`), the stretch is extended into the next stripe (whose far
/// boundary was not identified: seen without an edge, with too little evidence, or cut
/// off by a shadow, an occluding edge or the end of the light). Each pixel of the
/// stretch's last stripe is interpolated between its two boundaries; the pixels beyond,
/// in the next stripe, got nothing, which left the last stripe or two before every gap
/// empty. Extended, they
/// take the coordinate the last stripes' width predicts, up to 0.85 of that width
/// (short of where the unseen boundary is expected), while they keep the light
/// ([`EXTEND_LIGHT_RATIO`]) and the colour ([`EXTEND_CHROMA`]) of the next stripe's
/// second pixel and do not reach another edge. An extension that stops at a change
/// leaves out its last pixel (it may straddle the change). After the merge,
/// [`crate::merge::remove_disputed_extensions`] removes those that a nearby depth
/// contradicts (an extension across an occluding edge that showed no change).
///
/// Tried on 2026-12-07 and not kept: leaving out the last pixel also of an extension
/// that stopped at this reach within 1.6 (or 2.1) pixels of the next edge. On
/// occluders/world 272 of the outliers are one row at the box's top edge that the row
/// family extends into from the wall below (4:2:0 gives the row the wall's colour; the
/// pixel's centre is on the box). The row went (0.57 % -> 0.54 % outliers there), but
/// over 28 rows (`default`, `webcam`, `world`, `wide` of occluders, wood, textured,
/// paper, sphere, colorchecker, skin) mean coverage fell 93.914 % -> 93.846 % and
/// outliers rose 0.3057 % -> 0.3075 % (occluders/default 0.18 % -> 0.20 %).
pub const EXTEND_REACH: f32 = 0.85;

/// Largest ratio, either way, between the light (sum of the linear channels) of an
/// extended pixel and of the second pixel of its stripe: inside one stripe the
/// projector's colour is the same, so only the surface's shading and albedo change it,
/// while another surface seen past an occluding edge shows another stripe.
pub const EXTEND_LIGHT_RATIO: f32 = 1.3;

/// Largest change of any channel's share of the light (chromaticity) from the
/// extended stripe's second pixel to an extended pixel.
pub const EXTEND_CHROMA: f32 = 0.1;

/// Which line [`Decoder::line_coords`] decodes, and the frame index of the first
/// pixel of the part of the coordinates it is given (0: the whole frame).
#[derive(Clone, Copy)]
struct LineOut {
    line: usize,
    base: usize,
}

/// What [`Decoder::line_coords`] reads of every line of a family: the lines' axis, the
/// frame's linear colour and width, the length of a line, the widest stripe that is
/// bridged, and the direction identities grow in along a line.
struct LineGeometry<'a> {
    axis: ScanAxis,
    linear: &'a [[f32; 3]],
    width: usize,
    line_len: usize,
    max_width: f32,
    step: i32,
}

/// A chunk of lines' workspace for [`Decoder::stripe_coords_into`]: one line's edges
/// without the chains' labels, its identified edges ([`Named`]), and the pixels the
/// chunk extended and took from chain labels (frame indices, in line order).
#[derive(Default)]
struct CoordChunk {
    masked: Vec<Edge>,
    named: Vec<Named>,
    extended: Vec<u32>,
    weak: Vec<u32>,
}

/// An identified edge of a line as [`Decoder::line_coords`] pairs them: whether its
/// chain alone labelled it, and whether an edge without an identity lies between it and
/// the next identified edge.
#[derive(Clone, Copy)]
struct Named {
    edge: Edge,
    weak: bool,
    before_unnamed: bool,
    /// Its index among the line's edges.
    index: usize,
}

/// Into `out`, the identified edges of a line in order (see [`Named`]); `weak` as in
/// [`Decoder::line_coords`].
fn named_edges(edges: &[Edge], weak: Option<&[bool]>, out: &mut Vec<Named>) {
    out.clear();
    for (k, e) in edges.iter().enumerate() {
        if e.id >= 0 {
            out.push(Named { edge: *e, weak: weak.is_some_and(|w| w[k]), before_unnamed: false, index: k });
        } else if let Some(last) = out.last_mut() {
            last.before_unnamed = true;
        }
    }
}

/// One scan line of the frame's linear colour.
struct LineLight<'a> {
    linear: &'a [[f32; 3]],
    axis: ScanAxis,
    line: usize,
    line_len: usize,
    width: usize,
    /// The frame index of the first pixel of the coordinates [`extend_stripe`] writes.
    base: usize,
}

impl LineLight<'_> {
    fn inside(&self, s: isize) -> bool {
        s >= 0 && (s as usize) < self.line_len
    }

    fn index(&self, s: isize) -> usize {
        axis_index(self.axis, self.line, s as usize, self.width)
    }

    /// The linear colour at position `s`; black off the line.
    fn pixel(&self, s: isize) -> [f32; 3] {
        if !self.inside(s) {
            return [0.0; 3];
        }
        self.linear.get(self.index(s)).copied().unwrap_or([0.0; 3])
    }
}

/// A pixel's light: the sum of its linear channels.
fn light(p: [f32; 3]) -> f32 {
    p[0] + p[1] + p[2]
}

/// Each channel's share of a pixel's light.
fn chromaticity(p: [f32; 3]) -> [f32; 3] {
    let total = light(p).max(1e-6);
    p.map(|v| v / total)
}

/// The first pixel past the identified boundary `a` in direction `d` (+1 or -1 along
/// the line) when it is on the line and has no coordinate yet: where
/// [`extend_stripe`] starts (None: nothing to extend, the common case inside a
/// decoded stretch, which is told before the extension's width is worked out).
fn extension_start(line: &LineLight, a: &Edge, d: isize, out: &[f32]) -> Option<isize> {
    let first = if d > 0 { a.pos.ceil() } else { a.pos.floor() } as isize;
    (line.inside(first) && out[line.index(first) - line.base].is_nan()).then_some(first)
}

/// Extend the decoded stretch that ends at the identified boundary `a`, whose last
/// stripe is `w` pixels wide, into the stripe beyond it in direction `d` (+1 or -1
/// along the line), from `first`, the pixel [`extension_start`] found, up to
/// [`EXTEND_REACH`] · `w` and short of the next edge at `limit`; `step` is +1 when
/// identities grow along the line. Fills only pixels without a coordinate, and adds
/// them to `extended`.
#[allow(clippy::too_many_arguments)]
fn extend_stripe(line: &LineLight, a: &Edge, first: isize, w: f32, d: isize, limit: Option<f32>, step: i32, out: &mut [f32], extended: &mut Vec<u32>) {
    // The new stripe's light and colour are those of its second pixel: the first lies
    // within a pixel of the boundary and carries some of the blurred light of the
    // stripe before (as the reference it stopped most extensions a pixel or two in, and
    // beside a shadow it passes for lit). The first pixel is taken whenever the second
    // is.
    let second = if line.inside(first + d) { first + d } else { first };
    let reference = line.pixel(second);
    let (level, hue) = (light(reference), chromaticity(reference));
    // The next stripe must not be a shadow: its light against the middle of the
    // stripe decoded before it.
    let known = light(line.pixel((a.pos - d as f32 * 0.5 * w).round() as isize));
    if level < SHADOW_SHARE * known {
        return;
    }
    let mut n = 0;
    let stopped_at_change = loop {
        let s = first + d * n;
        if !line.inside(s) || (s as f32 - a.pos).abs() >= EXTEND_REACH * w {
            break false;
        }
        if limit.is_some_and(|e| (e - s as f32) * d as f32 <= 0.0) {
            break true;
        }
        let p = line.pixel(s);
        let (l, c) = (light(p), chromaticity(p));
        if s != first && (l * EXTEND_LIGHT_RATIO < level || l > EXTEND_LIGHT_RATIO * level || (0..3).any(|k| (c[k] - hue[k]).abs() >= EXTEND_CHROMA)) {
            break true;
        }
        n += 1;
    };
    if stopped_at_change {
        n -= 1;
    }
    for k in 0..n.max(0) {
        let s = first + d * k;
        let i = line.index(s);
        if out[i - line.base].is_nan() {
            out[i - line.base] = a.id as f32 + step as f32 * (s as f32 - a.pos) / w;
            extended.push(i as u32);
        }
    }
}

impl Decoder {
    /// The projector's colour of stripe `j` (the background beyond the pattern).
    fn stripe_color(&self, j: i32) -> [f32; 3] {
        let i = (j + 1).clamp(0, self.colors.len() as i32 - 1) as usize;
        self.colors.get(i).copied().unwrap_or([0.0; 3])
    }

    /// Whether the dark pixels of the stretch from `a` to `b`, `stripes` stripes of the
    /// family (`stripes` > 1) across a dark band (see [`BRIDGE_MAX_SPAN`]), show the
    /// stripes that decoding across it would give them: at each boundary inside the
    /// stretch (placed at equal widths) with pixels under [`SHADOW_SHARE`] of the
    /// brighter end on both sides, the mean colours of those pixels either side change
    /// as its transition does, by at least [`BAND_MIN_STEP`] per changing channel (the
    /// sum over channels of the log change, signed by the transition). Boundaries
    /// without dark pixels on both sides say nothing; a stretch beyond
    /// [`BRIDGE_LIT_STRIPES`] or [`BRIDGE_LIT_SPAN`] needs a dark pixel. `index` maps a
    /// position on the line to a pixel.
    fn band_shows_stripes(&self, linear: &[[f32; 3]], index: impl Fn(usize) -> usize, a: &Edge, b: &Edge, stripes: i32) -> bool {
        let pixel = |s: usize| linear.get(index(s)).copied().unwrap_or([0.0; 3]);
        let Some((lo, hi, floor)) = shadow_floor(linear, &index, a.pos, b.pos) else { return true };
        // The mean colour of the dark pixels from `from` to `to` (within the stretch).
        let mean_dark = |from: f32, to: f32| {
            let (mut sum, mut n) = ([0f32; 3], 0);
            for s in from.ceil().max(lo as f32) as usize..=to.floor().min(hi as f32).max(0.0) as usize {
                let p = pixel(s);
                if light(p) < floor {
                    (0..3).for_each(|c| sum[c] += p[c]);
                    n += 1;
                }
            }
            (n > 0).then(|| sum.map(|v| v / n as f32))
        };
        // Past the limits of a stretch without dark pixels, only a dark band.
        let beyond_lit = stripes > BRIDGE_LIT_STRIPES || stripes as f32 * self.stripe_px > BRIDGE_LIT_SPAN;
        if beyond_lit && (lo..=hi).all(|s| light(pixel(s)) >= floor) {
            return false;
        }
        let step = if self.increasing { 1 } else { -1 };
        let width = (b.pos - a.pos) / stripes as f32;
        (1..stripes).all(|k| {
            let p = a.pos + k as f32 * width;
            let code = self.seen_code(a.id + k * step);
            let (Some(before), Some(after)) = (mean_dark(p - width + 1.0, p - 0.5), mean_dark(p + 0.5, p + width - 1.0)) else { return true };
            if code == NO_CODE {
                return true;
            }
            let t = unpack(code).map(f32::from);
            let changed = t.iter().filter(|&&v| v != 0.0).count() as f32;
            let seen: f32 = (0..3).map(|c| t[c] * ((after[c] + DARK_LEVEL) / (before[c] + DARK_LEVEL)).ln()).sum();
            seen >= BAND_MIN_STEP * changed
        })
    }

    /// Whether the stripe between the consecutive identified boundaries `a` and `b`
    /// (one stripe apart) is darker than the pattern can make it beside a neighbour:
    /// in every channel, its light relative to the middle of the stripe beyond either
    /// boundary (`period` pixels wide) is under [`NEIGHBOUR_SHARE`] of what the
    /// projector's colours give (with [`COLOR_FLOOR`] for the colour mixing and the
    /// room's light). A cast shadow or an unlit gap is bounded by two edges that the
    /// alignment can take for a stripe's (under 25-pixel stripes a 60-pixel shadow was
    /// bridged as one stripe); the test fails only where the surface's albedo drops
    /// to under half in every channel from one stripe to the next. `line_len` is the
    /// line's length, `index` maps a position on it to a pixel.
    fn shadowed(&self, linear: &[[f32; 3]], index: impl Fn(usize) -> usize, line_len: usize, period: f32, a: &Edge, b: &Edge) -> bool {
        let (lo, hi) = ((a.pos + 1.0).ceil(), (b.pos - 1.0).floor());
        if hi < lo || lo < 0.0 {
            return false;
        }
        let pixel = |s: usize| linear.get(index(s)).copied().unwrap_or([0.0; 3]);
        let (lo, hi) = (lo as usize, (hi as usize).min(line_len.saturating_sub(1)));
        let mut inside = [0f32; 3];
        for s in lo..=hi {
            let p = pixel(s);
            (0..3).for_each(|c| inside[c] += p[c]);
        }
        let n = (hi + 1).saturating_sub(lo).max(1) as f32;
        let inside = inside.map(|v| v / n);
        let color = self.stripe_color(a.id.min(b.id));
        let (beyond_a, beyond_b) = if self.increasing { (a.id - 1, b.id) } else { (a.id, b.id - 1) };
        // The middle of each neighbouring stripe (the blur of the boundary is in the
        // pixel beside it).
        let out = max_f32(1.5, 0.5 * period);
        let before = (a.pos - out).round();
        let after = (b.pos + out).round();
        let neighbours = [(before >= 0.0).then(|| (pixel(before as usize), beyond_a)), ((after as usize) < line_len).then(|| (pixel(after as usize), beyond_b))];
        let darker = |(light, j): ([f32; 3], i32)| {
            let other = self.stripe_color(j);
            (0..3).all(|c| {
                let seen = (inside[c] + DARK_LEVEL) / (light[c] + DARK_LEVEL);
                let expected = (color[c] + COLOR_FLOOR) / (other[c] + COLOR_FLOOR);
                seen < NEIGHBOUR_SHARE * expected
            })
        };
        neighbours.iter().flatten().any(|&n| darker(n))
    }
}

/// What the colour mixing and the room's light add to a projector colour channel (full
/// scale 1) when comparing the light of neighbouring stripes (see
/// `Decoder::shadowed`).
pub const COLOR_FLOOR: f32 = 0.1;

/// Share of the light the pattern's colours give a stripe beside its neighbour below
/// which the stripe is taken for a shadow (see `Decoder::shadowed`).
pub const NEIGHBOUR_SHARE: f32 = 0.5;

/// Most a stripe may be wider than the identified stripe beside it on its line (the
/// wider of the two where both are), for the pixels between its boundaries to be
/// decoded. The pattern's stripes are equally wide, so the camera sees neighbours'
/// widths differ only by the surface's slant and curvature, a few per cent; a stretch
/// of ambient light (a cast shadow, the edge of the projector's light) between two
/// edges that the alignment took for consecutive boundaries is as wide as the shadow.
/// Such a stretch passes the light tests (`lit_between`, `Decoder::shadowed`)
/// where the room's light on the wall is as bright as a dark stripe there, and a
/// grey stripe between two white ones drops every channel as a shadow does. Measured
/// on the `default`, `webcam`, `world`, `wide` and `narrow` rows of ten scenes (sphere,
/// paper, occluders, colorchecker, sphere-dye, paper-dye, bag, wood, textured, skin;
/// mean coverage / outliers, a lone stripe held to the same multiple of the predicted
/// period): without the test 85.57 % / 0.534 % (occluders/wide 4.22 % outliers, 3.5
/// points of them in its cast shadows); 2.0 85.59 % / 0.464 %; 1.6 85.58 % / 0.450 %;
/// 1.35 85.56 % / 0.433 % (occluders/wide 0.76 %); 1.2 85.49 % / 0.425 %. A stripe
/// with no identified stripe beside it is held to [`LONE_STRIPE_SHARE`] instead.
pub const STRIPE_WIDTH_JUMP: f32 = 1.35;

/// Most a stripe with no identified stripe beside it on its line may be wide, as a share
/// of the widest stretch a decoded stripe may span (three predicted periods): two
/// predicted periods, so that a surface nearer than the rig's working distance keeps
/// its wider stripes. Without a limit for lone stripes (the neighbour test at 1.6),
/// occluders/wide still had 2.9 % outliers. At 1.35 periods, the rows measured for
/// [`STRIPE_WIDTH_JUMP`] had the same coverage as at two (85.56 %) and outliers 0.433 %
/// instead of 0.439 % (occluders/wide 0.76 % instead of 0.94 %); none of those scenes
/// is nearer than the working distance, so that is no measure of what two periods
/// keep.
pub const LONE_STRIPE_SHARE: f32 = 2.0 / 3.0;

/// The width of the stripe from `p` to `q` where they are consecutive identified
/// boundaries (`step` apart) of one run, in order along the line; None elsewhere.
fn stripe_width(p: &Edge, q: &Edge, step: i32) -> Option<f32> {
    (p.id >= 0 && q.id >= 0 && (q.id - p.id) * step == 1 && p.run == q.run && q.pos > p.pos).then(|| q.pos - p.pos)
}

/// The width a stretch is extended with past its identified edge `edges[i]`
/// ([`extend_stripe`]): the mean width of up to [`EXTEND_WIDTH_STRIPES`] consecutive
/// identified stripes on its other side, `d` = -1 for those before it (to extend past
/// it), 1 for those after it, each within [`EXTEND_WIDTH_AGREE`] of the nearest one;
/// None where the nearest is not identified. Where only the nearest is taken (wide
/// stripes, whose three would span more than [`EXTEND_WIDTH_SPAN`], or a next stripe
/// unlike it) and the next is identified and within [`BEND_WIDTH_RATIO`], the width at
/// the boundary instead: the nearest's plus half its change from the next, scaled by
/// [`bend_share`] as the stripes' own bend is. On a curved surface the stripes widen or
/// narrow from one to the next, and an extension with the nearest's width runs on at
/// the slope of that stripe's middle. Measured on the 60 `wide`, `default`, `webcam`,
/// `soft` and `world` rows of `eval --hard` (mean coverage / outliers / RMSE): 89.655 %
/// / 0.3452 % / 0.534 mm without, 89.640 % / 0.3433 % / 0.530 mm with (skin/wide 0.23 ->
/// 0.13 % outliers, 0.543 -> 0.496 mm; sphere/wide 0.468 -> 0.439 mm; paper in 1 % dyes
/// under `wide` 84.8 -> 84.3 %); with the whole change instead of half, sphere/wide
/// 0.446 mm, wood/wide 0.414 mm against 0.402 mm.
fn extension_width(edges: &[Edge], i: usize, d: isize, step: i32) -> Option<f32> {
    let edge = |k: isize| usize::try_from(k).ok().and_then(|k| edges.get(k));
    let width = |k: isize| {
        // The stripe between edges k and k + d (in line order).
        let (p, q) = (edge(k)?, edge(k + d)?);
        if d < 0 { stripe_width(q, p, step) } else { stripe_width(p, q, step) }
    };
    let nearest = width(i as isize)?;
    let (mut sum, mut n) = (nearest, 1);
    let mut k = i as isize + d;
    // The width of the first stripe the mean left out, if identified.
    let mut left_out = None;
    while n < EXTEND_WIDTH_STRIPES {
        match width(k) {
            Some(w) if (w - nearest).abs() <= EXTEND_WIDTH_AGREE * nearest && sum + w <= EXTEND_WIDTH_SPAN => {
                sum += w;
                n += 1;
                k += d;
            }
            other => {
                left_out = other;
                break;
            }
        }
    }
    // The nearest stripe alone (too wide for a mean, or unlike the next): the width at
    // the boundary, where the next stripe's trend puts it.
    if n == 1 {
        if let Some(next) = left_out.filter(|&next| bends_with(nearest, next)) {
            return Some(nearest + 0.5 * bend_share(nearest) * (nearest - next));
        }
    }
    Some(sum / n as f32)
}

/// Stripes whose mean width a stretch is extended with (`extension_width`): 3.
///
/// Why: an extension's coordinates are its last boundary's plus the pixels past it over
/// a width, so the width's error grows with the reach. One stripe's width carries the
/// error of both its boundaries (on 7-pixel stripes about 2 %, a fiftieth of a stripe
/// at the reach's end); the mean of three carries the two outer boundaries' over three
/// widths. Measured on the 60 `soft`, `default`, `webcam`, `world` and `wide` rows of
/// `eval --hard` (mean coverage / outliers / RMSE): with the nearest stripe alone
/// 89.632 % / 0.3715 % / 0.545 mm; with three and no bound on their span 89.650 % /
/// 0.3692 %, but the `wide` rows' RMSE up by 0.06-0.15 mm (skin/wide 0.24 % -> 0.41 %
/// outliers): three 26-pixel stripes span 78 pixels, over which perspective changes the
/// width; bounded to 20 pixels 89.657 % / 0.3590 % / 0.539 mm, the `wide` rows as
/// before; to 24 (three 7-pixel stripes) 89.660 % / 0.3582 %.
pub const EXTEND_WIDTH_STRIPES: usize = 3;

/// Most pixels the stripes whose mean width `extension_width` takes may span: 24
/// (see [`EXTEND_WIDTH_STRIPES`]).
pub const EXTEND_WIDTH_SPAN: f32 = 24.0;

/// Largest difference, as a share of the nearest stripe's width, of a further stripe
/// whose width `extension_width` takes into its mean.
pub const EXTEND_WIDTH_AGREE: f32 = 0.15;

/// Whether a stripe `width` pixels wide between two consecutive identified edges is
/// wider than [`STRIPE_WIDTH_JUMP`] times the identified stripe beside it on either side
/// (`beside`, [`widths_beside`]), or with none, than [`LONE_STRIPE_SHARE`] of
/// `max_width`.
fn wider_than_beside(width: f32, (before, after): (Option<f32>, Option<f32>), max_width: f32) -> bool {
    match (before, after) {
        (None, None) => width > LONE_STRIPE_SHARE * max_width,
        (x, y) => width > STRIPE_WIDTH_JUMP * max_f32(x.unwrap_or(0.0), y.unwrap_or(0.0)),
    }
}

/// The widths of the identified stripes either side of the one between `named[k]` and
/// `named[k + 1]` (see [`stripe_width`]).
fn widths_beside(named: &[Named], k: usize, step: i32) -> (Option<f32>, Option<f32>) {
    let (a, b) = (&named[k].edge, &named[k + 1].edge);
    let before = k.checked_sub(1).and_then(|j| stripe_width(&named[j].edge, a, step));
    let after = named.get(k + 2).and_then(|n| stripe_width(b, &n.edge, step));
    (before, after)
}

/// Most a stripe beside a decoded stripe may differ from it in width, as a factor
/// either way, for `stripe_tangents` to bend the decoded stripe's coordinates with
/// it; past that, the neighbour is taken for another surface (across a depth edge or
/// a crease sharper than a stripe can follow) and that side stays straight.
pub const BEND_WIDTH_RATIO: f32 = 1.5;

/// The stripe width, camera pixels, at which `stripe_tangents` bends a stripe's
/// coordinates half as much as the widths beside it say: the error of a straight line
/// across a curved surface grows with the square of the stripe's width, the noise of
/// its two boundaries does not, so narrow stripes stay nearly straight (a 7-pixel
/// stripe takes a tenth of the bend, a 25-pixel one 95 %).
pub const BEND_HALF_WIDTH: f32 = 12.0;

/// The tangents of the stripe coordinate at the two boundaries of a stripe `w` pixels
/// wide between two consecutive identified edges, with the identified stripes beside it
/// `(before, after)` ([`widths_beside`]), in stripes per stripe width, for
/// [`across_stripe`]. Between two boundaries the coordinate used to
/// be a straight line; on a surface that curves, or creases, inside a stripe, the
/// stripes beside it are wider or narrower than it, and a straight line through 25
/// camera pixels is several millimetres off in its middle (crumpled paper under
/// `wide`: most of its 2.7 % outliers, rising from the boundaries to the stripe's
/// middle). Each boundary's tangent is that of the line through the boundaries either
/// side of it (Catmull-Rom: twice the width over the sum of the two widths), where the
/// stripe beside is identified in the same run and within [`BEND_WIDTH_RATIO`], else 1
/// (straight); then drawn toward 1 for narrow stripes ([`BEND_HALF_WIDTH`]).
fn stripe_tangents(w: f32, (before, after): (Option<f32>, Option<f32>)) -> [f32; 2] {
    let bend = bend_share(w);
    let tangent = |beside: Option<f32>| match beside {
        Some(x) if bends_with(w, x) => 1.0 + bend * (2.0 * w / (x + w) - 1.0),
        _ => 1.0,
    };
    [tangent(before), tangent(after)]
}

/// How much of what the widths beside it say a stripe `w` pixels wide bends by:
/// `w⁴ / (w⁴ + h⁴)` with `h` = [`BEND_HALF_WIDTH`].
fn bend_share(w: f32) -> f32 {
    let (w4, h4) = ((w * w) * (w * w), BEND_HALF_WIDTH.powi(4));
    w4 / (w4 + h4)
}

/// Whether two neighbouring stripes' widths are within [`BEND_WIDTH_RATIO`] of each
/// other, so that one says how the other bends.
fn bends_with(w: f32, x: f32) -> bool {
    x <= BEND_WIDTH_RATIO * w && w <= BEND_WIDTH_RATIO * x
}

/// How far across a stripe (0 at its first boundary, 1 at its second) the pixel at
/// fraction `t` of its width is: the cubic Hermite curve with the boundaries'
/// `tangents` ([`stripe_tangents`]); with both 1, `t` itself. With tangents in (0, 2),
/// as Catmull-Rom's are, the curve rises monotonically.
fn across_stripe(t: f32, [m0, m1]: [f32; 2]) -> f32 {
    // t + (m0 - 1) t (1 - t)² - (m1 - 1) t² (1 - t): exactly t with both tangents 1.
    let u = 1.0 - t;
    t * (1.0 + u * ((m0 - 1.0) * u - (m1 - 1.0) * t))
}

/// Most the width of a stripe with edges without an identity inside it may differ from
/// each identified stripe beside it, as a share of that stripe's width, for the pixels
/// between its boundaries to be decoded across those edges.
///
/// An edge between two identified boundaries that the alignment took for spurious is
/// most often the surface's own texture (under 25-pixel stripes on the `textured`
/// scene's checks there were more such edges than boundaries), and the stripe across
/// it was left to the extension from its ends ([`EXTEND_REACH`]), which stops at
/// the first edge. It can also be a fold or an occluding edge, where a straight line
/// between the boundaries is wrong by millimetres: a crease of the `wall` scene, the
/// box edges of `occluders`, the folds of `paper`. Where the surface is smooth, the
/// stripes beside are as wide as this one; at a fold or a depth step they differ.
/// Measured on the `wide` rows of the `textured`, `occluders`, `paper` and `wall`
/// scenes (pixels decoded within the outlier threshold gained / lost against not
/// bridging): both neighbours within 0.1: 12741 / 17, 474 / 24, 3276 / 1544, 67 / 0;
/// within 0.2: 12770 / 17, 476 / 35, 4608 / 1979, 75 / 787; either neighbour within
/// 0.1: 22925 / 32, 630 / 298, 6032 / 1891, 82 / 787; no test: 24033 / 239, 667 /
/// 4394, 6920 / 3826, 82 / 787.
///
/// On `paper` under `wide` (2026-12-05) the identified boundaries lie 0.13-0.17 pixels
/// RMS from their true places, and its 2.75 % outliers are the pixels between them:
/// clusters of 100-400 pixels 4-8 mm off, where a straight line across a 26-pixel
/// stripe misses a fold (each family alone has 8.6-8.9 % outliers; the merge drops
/// where they disagree). Not bridging at all left 2.66 %; not bridging edges that
/// change every lit channel's log alike (shading) 2.65 %, at 4300 correct pixels of
/// textured/wide. Blending each family's depth with the other's between both families'
/// boundaries (a Coons patch) left 2.56 % but adds both families' noise (mean RMSE of
/// sphere, paper, textured, occluders, skin and wood under default, webcam and wide
/// 0.548 -> 0.575 mm).
pub const BRIDGE_WIDTH_TOLERANCE: f32 = 0.1;

/// Whether the `stripes` stripes between `named[k]` and `named[k + 1]`, with edges
/// without an identity between them, are decoded across those edges: both identified
/// stripes beside them are within [`BRIDGE_WIDTH_TOLERANCE`] of their mean width.
fn bridges_unnamed(named: &[Named], k: usize, step: i32, stripes: i32) -> bool {
    let width = (named[k + 1].edge.pos - named[k].edge.pos) / stripes as f32;
    let fits = |w: Option<f32>| w.is_some_and(|w| (width - w).abs() <= BRIDGE_WIDTH_TOLERANCE * w);
    let (before, after) = widths_beside(named, k, step);
    fits(before) && fits(after)
}

/// The edges between `edges[i]` and `edges[j]`, identified boundaries `stripes` apart
/// (at most [`MAX_STEP`]), that stand where the `stripes - 1` boundaries between them
/// are: for each, the edge nearest to where equal stripes put it, within
/// [`MISREAD_POSITION`] of a stripe's width; `None` where a boundary has none, or an edge
/// between is in another run. Such boundaries were seen where the pattern has them but
/// read as other transitions (a surface's colour changing under a wide stripe reads as
/// a step of its own); the stripes between are decoded from one of them to the next,
/// as if they had been identified. Other edges between them may be the surface's own
/// texture ([`MISREAD_MAX_STRIPES`] says when they are allowed).
fn misread_boundaries(edges: &[Edge], i: usize, j: usize, stripes: i32) -> Option<[usize; MAX_STEP - 1]> {
    let inner = stripes.checked_sub(1).filter(|&n| (1..MAX_STEP as i32).contains(&n))? as usize;
    if j <= i || j - i <= inner || edges.len() <= j {
        return None;
    }
    let (a, b) = (&edges[i], &edges[j]);
    let between = &edges[i + 1..j];
    if between.iter().any(|e| e.run != a.run) {
        return None;
    }
    let width = (b.pos - a.pos) / stripes as f32;
    let mut at = [0; MAX_STEP - 1];
    for (k, slot) in at.iter_mut().enumerate().take(inner) {
        let expected = a.pos + (k + 1) as f32 * width;
        let (n, e) = between.iter().enumerate().min_by(|(_, e), (_, f)| (e.pos - expected).abs().total_cmp(&(f.pos - expected).abs()))?;
        if (e.pos - expected).abs() > MISREAD_POSITION * width {
            return None;
        }
        *slot = i + 1 + n;
    }
    Some(at)
}

/// How far from where equal stripes put it, as a share of a stripe's width, an edge
/// without an identity between two identified boundaries may lie for
/// `misread_boundaries` to take it for the boundary the pattern has there.
///
/// Why: between two identified boundaries two or more stripes apart, a stripe was
/// decoded only where the boundaries skipped change no channel either edge can read
/// (hidden on a saturated dye); a skipped boundary that the frame does show, with an
/// edge, is more often a sign of a wrong identity. But the edge can be that boundary,
/// misread: on a coloured surface a patch's own edge near the boundary, or a channel
/// the patch hardly reflects, turns its transition into another, and the alignment
/// leaves it without an identity (on the `sphere` scene under `wide`, row 160 of
/// family 0: boundaries 12 and 14 at 292.5 and 346.9 px, and an edge read as another
/// transition at 319.3 px, 0.4 px from the midpoint). Measured on the `default`,
/// `webcam` and `wide` rows of sphere, colorchecker, skin, wood, paper, textured,
/// occluders and sphere-dye (`eval --hard`; coverage / outliers), across up to
/// [`MAX_STEP`] stripes: 0.08 gained 0.1 to 1.4 points of coverage on 17 of the 24 rows
/// (textured/wide 85.5 -> 86.9 %, sphere-dye/webcam 87.7 -> 88.4 %, wood/webcam 93.3 ->
/// 93.8 %, sphere/wide 89.0 -> 89.5 %), with outliers within 0.03 points but
/// sphere/wide's, 0.31 -> 0.40 %; 0.15 gained up to 0.2 points more, with more
/// outliers (skin/wide 0.25 -> 0.33 %, occluders 0.14 -> 0.19 %, wood 0.10 -> 0.13 %).
/// Interpolated straight from one identified boundary to the other instead of through
/// the misread ones, the RMSE grew (skin/wide 0.627 -> 0.648 mm at 0.15). Each stripe
/// between misread boundaries is then tested for a shadow as a single stripe is
/// (`Decoder::shadowed`): without, the wall's RMSE grew (0.223 -> 0.239 mm under
/// `default`). See [`MISREAD_MAX_STRIPES`] for how many stripes.
pub const MISREAD_POSITION: f32 = 0.08;

/// Most stripes between two identified boundaries decoded through misread boundaries
/// (`misread_boundaries`) with no test of their neighbours: two, through one edge
/// halfway between and no other. Across more stripes (up to
/// [`MISREAD_TESTED_MAX_STRIPES`]), or with other edges between (the surface's texture),
/// the identified stripes either side must be within [`BRIDGE_WIDTH_TOLERANCE`] of the
/// stripes' mean width, as for a stripe bridged across edges without an identity
/// (`bridges_unnamed`): at a fold or an occluding edge they differ.
///
/// Why: across up to [`MAX_STEP`] stripes the full evaluation (`eval --hard`, 114 rows)
/// lost the outlier goal of occluders under `partial` (0.46 -> 0.54 %): a row along the
/// top edge of a box, whose pixels blend the box and the wall behind it, got a few
/// hundred more wrong depths, and asking that each misread boundary be identified on
/// a line beside it did not keep them out (it kept half the gains elsewhere). With two
/// stripes at most, on occluders, bag, sphere and textured under `default`, `partial`
/// and `wide`: occluders/partial 0.49 % outliers, bag 65.6 -> 66.6 % coverage
/// (67.4 % with six), bag/partial 64.6 -> 66.4 % (67.5 %), sphere/wide and textured/wide
/// as with six.
pub const MISREAD_MAX_STRIPES: i32 = 2;

/// Most stripes between two identified boundaries decoded through misread boundaries
/// where the identified stripes either side are as wide as theirs (see
/// [`MISREAD_MAX_STRIPES`]): four.
///
/// Why: under 25-pixel stripes a patch's border often stands inside a stripe beside a
/// misread boundary (colorchecker under `wide`, row 250: boundaries 12 and 14 with
/// edges at 312.1, halfway, and 320.6), and such a gap was left empty. With the
/// neighbours' widths tested and texture edges allowed among the misread boundaries, on
/// the `default`, `partial`, `wide`, `webcam` and `world` rows of sphere, colorchecker,
/// textured, occluders, bag, skin, wood, sphere-dye and paper-dye (`eval --hard`), mean
/// coverage / outliers 89.002 % / 0.2827 % became 89.020 % / 0.2824 % across two
/// stripes at most, 89.031 % / 0.2829 % across four (textured/wide 86.9 -> 87.4 %,
/// wood/wide 85.9 -> 86.4 %) and 89.040 % / 0.2829 % across six ([`MAX_STEP`]), where
/// occluders under `partial` went from 0.49 % to 0.50 % outliers (over its goal of
/// 0.5 %).
pub const MISREAD_TESTED_MAX_STRIPES: i32 = 4;

/// Most stripes decoded at once across a dark band (see [`BRIDGE_MAX_SPAN`]): six, the
/// longest step of the alignment ([`MAX_STEP`]); six stripes of the default 10
/// projector pixels are the span's limit too.
///
/// Why: under 3-pixel stripes (the `narrow` condition, 4.6 projector pixels) the
/// ColorChecker's black bands between its patches span four stripes, and the band's
/// edges with the stripe beside each take no identity, so the identified boundaries
/// either side were five or six stripes apart and the bands stayed empty with four
/// at most. With six (2026-12-07, the whole `eval --hard` table, then with the span
/// of 40): colorchecker/narrow 83.9 % -> 85.0 % coverage, outliers 0.06 % as before;
/// the 8 MP rows, decoded at a third of the scale, colorchecker/8mp 95.9 % -> 96.1 %
/// and bag/8mp 76.9 % -> 77.1 %; no other row's coverage or outliers moved (mean of the
/// 114 rows 91.643 % -> 91.656 %). The tingck wall (3 projector pixels a stripe;
/// `scripts/real-data.sh`) 44.15 % -> 47.75 % with its stripe coordinates 97.62 % ->
/// 97.76 % within a quarter of a stripe of the cubic through them and none a stripe
/// off; the hand 15.13 % -> 15.20 %.
pub const BRIDGE_MAX_STRIPES: i32 = 6;

/// Widest part of the projector's image, in its pixels across the stripes, that is
/// decoded at once across a dark band: two to [`BRIDGE_MAX_STRIPES`] stripes between
/// identified boundaries, with edges without an identity between them and with as
/// wide stripes on either side (`bridges_unnamed`, by their mean width), are decoded
/// across boundaries that were not identified or not seen, where the band's dark
/// pixels show the stripes (`Decoder::band_shows_stripes`) instead of where every
/// pixel is lit (`lit_between`).
///
/// Why: the ColorChecker's black card (about 3 % reflectance) shows between its
/// patches as 10-pixel bands at a twentieth of the patches' light, which
/// `lit_between` takes for a shadow. The boundary inside such a band is readable,
/// but it lies a few pixels from the band's own edges, whose log steps are twenty
/// times stronger; the band's edges (the whole albedo step and a boundary merged
/// into it) take no identity, and the gaps stayed empty: a tenth of the chart. On
/// 45 rows of the hard evaluation (`eval --hard --scenes sphere,occluders,textured,
/// paper,wood,colorchecker,bag,skin,paper-dye --conditions
/// default,webcam,wide,clipped,world`), mean coverage / outliers 88.50 % / 0.376 %
/// before; across two or three stripes with no limit on the span 89.03 % / 0.402 %:
/// under 25-pixel stripes (38 projector pixels) three stripes span a cast shadow,
/// whose ambient-lit pixels are as bright as the black card (occluders/wide 0.41 % to
/// 0.88 % outliers, 1155 pixels in the shadow); within 32 projector pixels 88.87 % /
/// 0.371 %, colorchecker/default 87.6 % to 90.7 % coverage and no row worse by 0.02
/// points of outliers. A test of the light's floor instead (every pixel at least 1-3 %
/// of the brighter end) did not tell the card from that shadow.
///
/// Up to four stripes within 40 projector pixels where the dark pixels show the
/// stripes (`Decoder::band_shows_stripes`, [`BAND_MIN_STEP`]) and, beyond three stripes
/// or 32 pixels, some pixel is dark ([`BRIDGE_LIT_SPAN`]): on the same 45 rows 88.87 % /
/// 0.371 % -> 88.93 % / 0.370 %, colorchecker/webcam 88.7 % -> 89.4 %,
/// colorchecker/world 90.4 % -> 91.2 %. Without the test of the dark pixels, four
/// stripes spanned the shadow of the occluders' rod (occluders/default 0.19 % -> 0.23 %
/// outliers, 69 pixels more where no projector light falls).
///
/// Within 60 projector pixels (2026-12-07, with [`BRIDGE_MAX_STRIPES`] six): five and
/// six stripes of the default width too, where the edges beside the black card's band
/// lost their identities with the boundary merged into them. On 36 rows (`eval --hard
/// --scenes bag,colorchecker,occluders,sphere-dye,paper-dye,textured --conditions
/// default,webcam,world,clipped,partial,wide`), mean coverage / outliers 87.214 % /
/// 0.2936 % -> 87.311 % / 0.2944 %: the ColorChecker 0.3-0.8 points up on the five
/// rows of default-width stripes (webcam 89.9 % -> 90.7 %, world 93.4 % -> 94.0 %),
/// bag 0.1-0.2 points (bag/default 0.12 % -> 0.14 % outliers), the occluders' shadows
/// not bridged. Over the whole table also colorchecker/soft 81.7 % -> 82.6 % and
/// colorchecker/shoulder 94.9 % -> 95.2 %; the 114 rows 91.656 % / 0.2263 % -> 91.703 %
/// / 0.2268 %, the same goals met. Within 80 pixels two stripes of the `wide` condition (38 projector
/// pixels) fit too: colorchecker/wide 79.3 % -> 82.4 %, but textured/wide 87.3 % ->
/// 86.9 % with 0.42 % -> 0.45 % outliers and paper-dye/wide 3.00 % -> 3.05 %.
pub const BRIDGE_MAX_SPAN: f32 = 60.0;

/// Most stripes decoded at once across edges without an identity where no pixel
/// between is dark (under
/// [`SHADOW_SHARE`] of the brighter end): four stripes without a dark band mostly
/// bridged the texture's edges and missed boundaries, which helped direct estimation
/// more than `loggrad` (textured, correct pixels, loggrad / direct 1.021 -> 1.018;
/// `tests/scan.rs` asks for 1.02), and with a dark pixel required everywhere the
/// 45 rows fell to 88.75 % (the textures' missed boundaries).
pub const BRIDGE_LIT_STRIPES: i32 = 3;

/// Widest part of the projector's image, its pixels, decoded at once across edges
/// without an identity where no pixel between is dark (see [`BRIDGE_LIT_STRIPES`]).
pub const BRIDGE_LIT_SPAN: f32 = 32.0;

/// Least log change per changing channel that the dark pixels either side of a
/// boundary inside a dark band must show, in the direction of its transition, for the
/// band to be decoded across ([`BRIDGE_MAX_SPAN`]). Through the ColorChecker's black
/// card a boundary changed its channels by 0.36-0.56 (one row measured); in a shadow
/// the room's light shows no change, and the noise of a few pixels' mean at that level
/// is about 0.15.
pub const BAND_MIN_STEP: f32 = 0.2;

/// Share of the light at a stripe's ends below which a pixel inside it is taken for a
/// shadow or the edge of the projector's light: an ambient-lit gap between two
/// boundaries shows no edge, and without this test wide stripes (25 camera pixels)
/// were bridged across cast shadows of up to three periods. Inside one stripe the
/// projector's colour is the same, so only the surface's albedo changes the light, and
/// a drop to under a quarter is rare on the simulated scenes' textures.
///
/// What the test costs (2026-12-05, the 45 rows of `eval --hard --scenes sphere,
/// occluders,textured,paper,wood,colorchecker,bag,skin,paper-dye --conditions
/// default,webcam,wide,clipped,world`): without it for a single stripe, mean coverage
/// 88.96 % -> 89.05 %, outliers 0.366 % -> 0.384 %; colorchecker/wide 78.9 % -> 81.8 %
/// (its black card between the patches, 10 pixels wide inside 25-pixel stripes) and
/// textured/wide 85.5 % -> 86.4 %, but paper/wide 2.75 % -> 3.22 % and paper-dye/wide
/// 3.57 % -> 3.84 % outliers (the dark side of a fold, where a straight line between
/// the boundaries is millimetres off). Leaving it out only where both ends are lit
/// alike (a dip, not a step; the darker end at least half the brighter) kept about two
/// fifths of both (colorchecker/wide 80.1 %, paper/wide 2.92 %).
pub const SHADOW_SHARE: f32 = 0.25;

/// Whether every pixel strictly inside the span from `a` to `b` (a pixel's margin from
/// each, for the blur of the boundaries) is lit at least [`SHADOW_SHARE`] of the
/// brighter end of the span (an end can be in the shadow already), by the sum of its
/// linear channels; `index` maps a position on the line to a pixel.
fn lit_between(linear: &[[f32; 3]], index: impl Fn(usize) -> usize, a: f32, b: f32) -> bool {
    let Some((lo, hi, floor)) = shadow_floor(linear, &index, a, b) else { return true };
    (lo + 1..hi).all(|s| linear.get(index(s)).copied().map_or(0.0, light) >= floor)
}

/// The pixels of the span from `a` to `b` a pixel's margin from each end, `lo..=hi`,
/// and the light under which one of them is taken for a shadow: [`SHADOW_SHARE`] of the
/// brighter of `lo` and `hi` (an end can be in the shadow already). None where the
/// span holds fewer than two such pixels. `index` maps a position on the line to a
/// pixel of `linear`.
fn shadow_floor(linear: &[[f32; 3]], index: &impl Fn(usize) -> usize, a: f32, b: f32) -> Option<(usize, usize, f32)> {
    let (lo, hi) = ((a + 1.0).ceil(), (b - 1.0).floor());
    if hi <= lo || lo < 0.0 {
        return None;
    }
    let light_at = |s: usize| linear.get(index(s)).copied().map_or(0.0, light);
    let (lo, hi) = (lo as usize, hi as usize);
    Some((lo, hi, SHADOW_SHARE * light_at(lo).max(light_at(hi))))
}

#[inline]
fn axis_index(axis: ScanAxis, line: usize, s: usize, width: usize) -> usize {
    axis.index(line, s, width)
}

/// The edge of a line nearest to a position within a tolerance, for positions asked in
/// increasing order: one walk along the line instead of a search per position.
struct Nearest<'a> {
    edges: &'a [Edge],
    tol: f32,
    /// The first edge at or after the last position asked.
    next: usize,
}

impl<'a> Nearest<'a> {
    /// For `edges` sorted by position.
    fn new(edges: &'a [Edge], tol: f32) -> Self {
        Nearest { edges, tol, next: 0 }
    }

    /// The edge nearest to `pos` within the tolerance (the earlier of two as near);
    /// `pos` is at least the last position asked.
    fn at(&mut self, pos: f32) -> Option<Edge> {
        let edges = self.edges;
        while self.next < edges.len() && edges[self.next].pos < pos {
            self.next += 1;
        }
        let mut best: Option<Edge> = None;
        for j in [self.next.wrapping_sub(1), self.next] {
            if let Some(e) = edges.get(j) {
                let d = (e.pos - pos).abs();
                if d <= self.tol && best.is_none_or(|b| d < (b.pos - pos).abs()) {
                    best = Some(*e);
                }
            }
        }
        best
    }
}

/// Link the edges of line `from` (flat indices from `from_start`) to their
/// continuations on the next line `to` (from `to_start`): the nearest edge within
/// [`CONTINUATION_TOLERANCE`] with a transition both are compatible with, where each
/// is the other's nearest such edge. Sets `next` of the one and `linked` of the other.
fn link_continuations(from: &[Edge], to: &[Edge], from_start: usize, to_start: usize, next: &mut [u32], linked: &mut [bool]) {
    let tol = CONTINUATION_TOLERANCE;
    // The nearest compatible edge of `b` to edge `e`, by index; `lo` moves along `b`.
    let nearest = |e: &Edge, b: &[Edge], lo: &mut usize| {
        while *lo < b.len() && b[*lo].pos < e.pos - tol {
            *lo += 1;
        }
        let mut best: Option<(usize, f32)> = None;
        for (j, o) in b[*lo..].iter().enumerate().take_while(|(_, o)| o.pos <= e.pos + tol) {
            let d = (o.pos - e.pos).abs();
            if o.mask & e.mask != 0 && best.is_none_or(|(_, bd)| d < bd) {
                best = Some((*lo + j, d));
            }
        }
        best.map(|(j, _)| j)
    };
    let (mut lo, mut back) = (0, 0);
    for (i, e) in from.iter().enumerate() {
        let Some(j) = nearest(e, to, &mut lo) else { continue };
        // `lo` and `back` only move on, except where a nearest edge lies behind the
        // last one's window.
        while back > 0 && from[back - 1].pos >= to[j].pos - tol {
            back -= 1;
        }
        if nearest(&to[j], from, &mut back) == Some(i) {
            next[from_start + i] = (to_start + j) as u32;
            linked[to_start + j] = true;
        }
    }
}

/// For every identified edge of line `from`, the flat index (line `to` starts at
/// `to_start`) of the edge of line `to` with the same identity nearest to it within
/// [`CONTINUATION_TOLERANCE`]: both lines are sorted by position, so one sweep.
fn link_lines(from: &[Edge], to: &[Edge], to_start: usize, links: &mut [u32]) {
    let tol = CONTINUATION_TOLERANCE;
    let mut lo = 0;
    for (e, link) in from.iter().zip(links.iter_mut()) {
        if e.id < 0 {
            continue;
        }
        while lo < to.len() && to[lo].pos < e.pos - tol {
            lo += 1;
        }
        let mut best: Option<(usize, f32)> = None;
        for (j, o) in to[lo..].iter().enumerate().take_while(|(_, o)| o.pos <= e.pos + tol) {
            let d = (o.pos - e.pos).abs();
            if o.id == e.id && best.is_none_or(|(_, bd)| d < bd) {
                best = Some((lo + j, d));
            }
        }
        if let Some((j, _)) = best {
            *link = (to_start + j) as u32;
        }
    }
}

/// The position on its own line of the straight line fitted through the edge at flat
/// index `flat` and its boundary's positions on up to [`SMOOTH_LINES`] lines either side
/// (or [`SMOOTH_LINES_LONG`], where that fit agrees), followed through the `up` and
/// `down` links (see [`Decoder::smooth_positions`]; `placed` holds every edge's
/// position by flat index); its own position when a side has none.
fn fit_along_chain(placed: &[f32], up: &[u32], down: &[u32], flat: usize) -> f32 {
    let pos = placed[flat];
    // The samples: (line offset d, position p), the edge's own first.
    let mut samples = [(0f32, 0f32); 2 * SMOOTH_LINES_LONG + 1];
    samples[0] = (0.0, pos);
    let mut n = 1;
    let mut sides = [false; 2];
    for (side, sign, links) in [(0, -1f32, up), (1, 1f32, down)] {
        let mut i = flat;
        for dl in 1..=SMOOTH_LINES_LONG {
            let next = links[i];
            if next == NO_LINK {
                break;
            }
            i = next as usize;
            samples[n] = (sign * dl as f32, placed[i]);
            n += 1;
            sides[side] = true;
        }
    }
    if !(sides[0] && sides[1]) {
        return pos;
    }
    // The sums of the samples within [`SMOOTH_LINES`] and of all of them, in one pass.
    let is_near = |&(d, _): &(f32, f32)| d.abs() <= SMOOTH_LINES as f32;
    let (mut near, mut all) = (LineSums::default(), LineSums::default());
    for sample in &samples[..n] {
        if is_near(sample) {
            near.add(*sample);
        }
        all.add(*sample);
    }
    // The line through the near samples; where the edge's own position is what keeps
    // it from being straight, the line through its neighbours alone.
    let fit = near
        .line()
        .filter(|&line| straight_within(samples[..n].iter().filter(|s| is_near(s)), line))
        .map(|(intercept, _)| intercept)
        .or_else(|| straight_line(samples[1..n].iter().filter(|s| is_near(s))))
        .unwrap_or(pos);
    if near.n == all.n {
        return fit;
    }
    // The line through all of them, where it puts the edge near there and is straight.
    match all.line() {
        Some(line) if (line.0 - fit).abs() <= SMOOTH_AGREE && straight_within(samples[..n].iter(), line) => line.0,
        _ => fit,
    }
}

/// Edge `i` of a line moved [`ALONG_LINE_SHARE`] of the way toward where its four
/// neighbours put it, at `pos` (the line's positions after the fit along the chains),
/// where the two edges either side are identified as the next boundaries of the
/// pattern in the same run and the stripes around them fit [`ALONG_LINE_FIT`]; None
/// elsewhere (see [`Decoder::smooth_positions`]).
fn toward_neighbours(edges: &[Edge], pos: &[f32], i: usize) -> Option<f32> {
    if i < 2 || i + 2 >= edges.len() {
        return None;
    }
    let (e, p) = (&edges[i - 2..=i + 2], &pos[i - 2..=i + 2]);
    let step = e[1].id - e[0].id;
    let consecutive = e.windows(2).all(|w| w[1].id - w[0].id == step && w[1].run == w[0].run);
    if step.abs() != 1 || !consecutive || e.iter().any(|x| x.id < 0) {
        return None;
    }
    // The stripes beyond the neighbours, and the two around the edge together.
    let (before, after, around) = (p[1] - p[0], p[4] - p[3], p[3] - p[1]);
    if (around - (before + after)).abs() > ALONG_LINE_FIT || (before - after).abs() > ALONG_LINE_FIT {
        return None;
    }
    // The cubic through the four neighbours at the edge: (4 (p1 + p3) - p0 - p4) / 6.
    let off = p[2] - (0.5 * (p[1] + p[3]) - (after - before) / 6.0);
    // An edge within a tenth of the two stripes of a neighbour is no noise of position.
    if off.abs() > 0.4 * around {
        return None;
    }
    Some(p[2] - ALONG_LINE_SHARE * off)
}

/// The value at line offset 0 of the least-squares line through `samples` (line
/// offset, position), or None where a sample is further than [`SMOOTH_TOLERANCE`]
/// from it (a chain that bends more than noise does: two surfaces meeting, a
/// boundary that jumps) or the offsets do not fix a line.
fn straight_line<'a>(samples: impl Iterator<Item = &'a (f32, f32)> + Clone) -> Option<f32> {
    let mut sums = LineSums::default();
    samples.clone().for_each(|&s| sums.add(s));
    let line = sums.line()?;
    straight_within(samples, line).then_some(line.0)
}

/// The sums of the least-squares line through (line offset, position) samples.
#[derive(Default)]
struct LineSums {
    n: usize,
    sd: f32,
    sdd: f32,
    sp: f32,
    sdp: f32,
}

impl LineSums {
    fn add(&mut self, (d, p): (f32, f32)) {
        self.n += 1;
        (self.sd, self.sdd, self.sp, self.sdp) = (self.sd + d, self.sdd + d * d, self.sp + p, self.sdp + d * p);
    }

    /// The line's value at offset 0 and its slope, or None where the offsets do not
    /// fix a line.
    fn line(&self) -> Option<(f32, f32)> {
        let LineSums { n, sd, sdd, sp, sdp } = *self;
        let nf = n as f32;
        let den = nf * sdd - sd * sd;
        if den <= 0.0 {
            return None;
        }
        Some(((sp * sdd - sd * sdp) / den, (nf * sdp - sd * sp) / den))
    }
}

/// Whether every sample lies within [`SMOOTH_TOLERANCE`] of the line `(intercept, slope)`.
fn straight_within<'a>(mut samples: impl Iterator<Item = &'a (f32, f32)>, (intercept, slope): (f32, f32)) -> bool {
    samples.all(|&(d, p)| (p - intercept - slope * d).abs() <= SMOOTH_TOLERANCE)
}


#[cfg(test)]
mod tests {
    use super::*;
    use crate::segment::ANY_BOUNDARY;

    fn edge(pos: f32, id: i32) -> Edge {
        Edge { pos, code: NO_CODE, mask: ANY_BOUNDARY, run: 0, id, tentative: Tentative::NONE }
    }

    /// [`wider_than_beside`] of the stripe between `named[k]` and `named[k + 1]`.
    fn wider(named: &[Named], k: usize, step: i32, max_width: f32) -> bool {
        wider_than_beside(named[k + 1].edge.pos - named[k].edge.pos, widths_beside(named, k, step), max_width)
    }

    /// [`stripe_tangents`] of the stripe between `named[k]` and `named[k + 1]`.
    fn tangents_of(named: &[Named], k: usize, step: i32) -> [f32; 2] {
        stripe_tangents(named[k + 1].edge.pos - named[k].edge.pos, widths_beside(named, k, step))
    }

    /// The identified edges of a line, as [`Decoder::line_coords`] pairs them.
    fn named(edges: &[Edge]) -> Vec<Named> {
        let mut out = Vec::new();
        named_edges(edges, None, &mut out);
        out
    }

    /// A segmentation whose scan lines are the rows `lines`.
    fn rows(lines: Vec<Vec<Edge>>) -> Segmentation {
        let mut seg = Segmentation::default();
        (seg.axis, seg.lines) = (Some(ScanAxis::Rows), lines);
        seg
    }

    /// An identified edge (or -1) whose evidence reads red rising and nothing else, so
    /// that no boundary between two of them is hidden from both.
    fn red(pos: f32, id: i32) -> Edge {
        Edge { mask: 1 << crate::segment::pack([1, 0, 0]), ..edge(pos, id) }
    }

    /// The stripe coordinates [`Decoder::stripe_coords_into`] gives the rows `lines`, each
    /// `w` pixels of one grey, for family 0 of `spec` (identities increasing).
    fn coords_of_rows(spec: &PatternSpec, w: usize, lines: Vec<Vec<Edge>>) -> Vec<f32> {
        let n = lines.len();
        let mut decoder = Decoder::new(spec, 0, true);
        let mut out = vec![0.0; w * n];
        decoder.stripe_coords_into(&rows(lines), &vec![[0.3f32; 3]; w * n], w, 100.0, &mut out);
        out
    }

    /// A slanted boundary with alternating errors of ±0.25 px is pulled onto its
    /// straight line (where neighbours exist on both sides), a boundary ending at a line
    /// keeps its position there, another identity at the same place takes no part, and
    /// unidentified edges do not move.
    #[test]
    fn smoothing_fits_a_line_along_each_boundary() {
        let spec = PatternSpec::generate(1, 64, 16, 8.0).unwrap();
        let mut decoder = Decoder::new(&spec, 0, true);
        let truth = |l: usize| 10.0 + 0.4 * l as f32;
        let mut seg = Segmentation::default();
        seg.axis = Some(ScanAxis::Rows);
        for l in 0..12 {
            let noise = if l % 2 == 0 { 0.25 } else { -0.25 };
            let mut line = vec![edge(truth(l) + noise, 5), edge(30.0 + noise, -1)];
            if l == 6 {
                // Another boundary half a pixel away: a different identity.
                line.insert(1, edge(truth(l) + 0.5, 9));
            }
            seg.lines.push(line);
        }
        let before = seg.lines.clone();
        decoder.smooth_positions(&mut seg);
        for (l, line) in seg.lines.iter().enumerate() {
            let err = (line[0].pos - truth(l)).abs();
            if l == 0 || l == 11 {
                assert_eq!(line[0].pos, before[l][0].pos, "line {l}: the chain ends here");
            } else {
                // Seven lines (fewer near the ends) with errors alternating in sign.
                assert!(err < 0.13, "line {l}: error {err}");
            }
            assert_eq!(line.last().unwrap().pos, before[l].last().unwrap().pos, "line {l}: unidentified");
        }
        assert_eq!(seg.lines[6][1].pos, before[6][1].pos, "a lone boundary has no chain");
    }

    /// One line's position thrown 0.8 px off a straight chain takes the line through
    /// the others; a chain that bends (a kink of 1.5 px from line 6 on) keeps its own.
    #[test]
    fn smoothing_mends_one_thrown_position_and_keeps_a_bend() {
        let spec = PatternSpec::generate(1, 64, 16, 8.0).unwrap();
        let mut decoder = Decoder::new(&spec, 0, true);
        let straight = |l: usize| 10.0 + 0.3 * l as f32;
        let bent = |l: usize| 40.0 + if l >= 6 { 1.5 } else { 0.0 };
        let mut seg = Segmentation::default();
        seg.axis = Some(ScanAxis::Rows);
        for l in 0..12 {
            let thrown = if l == 5 { 0.8 } else { 0.0 };
            seg.lines.push(vec![edge(straight(l) + thrown, 5), edge(bent(l), 9)]);
        }
        decoder.smooth_positions(&mut seg);
        let mended = seg.lines[5][0].pos;
        assert!((mended - straight(5)).abs() < 0.01, "thrown position became {mended}, the line gives {}", straight(5));
        for l in 3..9 {
            assert_eq!(seg.lines[l][1].pos, bent(l), "line {l}: the bend moved");
        }
    }

    /// A boundary that goes on straight for fifteen lines is fitted over all of them
    /// (alternating errors of ±0.25 px average to a sixtieth of a pixel, not the
    /// thirtieth of seven lines); one that curves gently (0.01 px per line², within
    /// the tolerance of a straight line over fifteen lines, whose fit would put it
    /// 0.15 px off the shorter one's) keeps the fit over seven.
    #[test]
    fn a_long_straight_chain_is_fitted_over_more_lines_and_a_curved_one_is_not() {
        let spec = PatternSpec::generate(1, 64, 16, 8.0).unwrap();
        let mut decoder = Decoder::new(&spec, 0, true);
        let straight = |l: usize| 10.0 + 0.3 * l as f32;
        let curved = |l: usize| 40.0 + 0.01 * (l as f32 - 10.0).powi(2);
        let mut seg = Segmentation::default();
        seg.axis = Some(ScanAxis::Rows);
        for l in 0..21 {
            let noise = if l % 2 == 0 { 0.25 } else { -0.25 };
            seg.lines.push(vec![edge(straight(l) + noise, 5), edge(curved(l), 9)]);
        }
        decoder.smooth_positions(&mut seg);
        let err = seg.lines[10][0].pos - straight(10);
        assert!(err.abs() < 0.02, "straight chain: {err} off");
        // The fit over seven lines: the mean of 0.01 d² over d in -3..=3.
        let got = seg.lines[10][1].pos;
        assert!((got - (curved(10) + 0.04)).abs() < 1e-4, "curved chain: {got}");
    }

    /// Along a line of boundaries 6 px apart, one thrown 0.6 px off moves half the way
    /// back to where its neighbours put it, and they a third of the throw its way (the
    /// first and last two, without two neighbours either side, stay). Stripes widening
    /// by 0.3 px each, as on a slanted plane, stay where they are; so does a boundary
    /// beside a depth edge (the stripe beyond one neighbour 12 px wide) and one where
    /// an identity breaks the sequence. Each line is alone, so the fit along the chains
    /// leaves it as it is.
    #[test]
    fn a_boundary_moves_toward_where_its_neighbours_put_it() {
        let spec = PatternSpec::generate(1, 64, 16, 8.0).unwrap();
        let mut decoder = Decoder::new(&spec, 0, true);
        let mut seg = Segmentation::default();
        seg.axis = Some(ScanAxis::Rows);
        let line = |positions: &[f32], ids: &[i32]| positions.iter().zip(ids).map(|(&p, &id)| edge(p, id)).collect::<Vec<_>>();
        let ids = [3, 4, 5, 6, 7, 8, 9];
        let slanted = [310.0, 316.0, 322.3, 328.9, 335.8, 343.0, 350.5];
        // Far apart, so that no boundary continues from one line to the next.
        seg.lines = vec![
            line(&[10.0, 16.0, 22.0, 28.6, 34.0, 40.0, 46.0], &ids),
            line(&[110.0, 116.0, 122.0, 128.6, 134.0, 146.0, 152.0], &ids),
            line(&[210.0, 216.0, 222.0, 228.6, 234.0, 240.0, 246.0], &[3, 4, 5, 6, 7, 12, 13]),
            line(&slanted, &ids),
        ];
        decoder.smooth_positions(&mut seg);
        let got: Vec<f32> = seg.lines[0].iter().map(|e| e.pos).collect();
        let want = [10.0, 16.0, 22.2, 28.3, 34.2, 40.0, 46.0];
        assert!(got.iter().zip(&want).all(|(g, w)| (g - w).abs() < 1e-4), "{got:?}, not {want:?}");
        for (e, &p) in seg.lines[3].iter().zip(&slanted) {
            assert!((e.pos - p).abs() < 1e-3, "slanted: {} moved to {}", p, e.pos);
        }
        assert_eq!(seg.lines[1][3].pos, 128.6, "beside a depth edge");
        assert_eq!(seg.lines[2][3].pos, 228.6, "where the sequence of identities breaks");
    }

    /// Two identified boundaries one stripe (8 px) apart and an unidentified edge far
    /// beyond: the stripe between them is interpolated, and the decoded stretch is
    /// extended into the stripes either side, up to 0.85 of a stripe's width, with
    /// the coordinates the stripe's width predicts. On a second line a shadow begins 3
    /// px past the stretch: the extension stops short of it, less the pixel beside it.
    #[test]
    fn a_decoded_stretch_is_extended_into_the_next_stripes() {
        let spec = PatternSpec::generate(1, 64, 16, 8.0).unwrap();
        let mut decoder = Decoder::new(&spec, 0, true);
        let (w, len) = (50, 50);
        let seg = rows(vec![vec![edge(10.3, 5), edge(18.3, 6), edge(40.5, -1)]; 3]);
        let mut linear = vec![[0.3f32; 3]; w * 3];
        for p in &mut linear[w + 21..w + len] {
            *p = [0.05; 3];
        }
        // The third line's shadow starts right past the boundary, its first pixel half
        // lit by the blur.
        linear[2 * w + 19] = [0.15; 3];
        for p in &mut linear[2 * w + 20..2 * w + len] {
            *p = [0.05; 3];
        }
        let mut out = vec![0.0; w * 3];
        decoder.stripe_coords_into(&seg, &linear, w, 100.0, &mut out);
        let ext: Vec<bool> = (0..out.len()).map(|i| decoder.extended().contains(&(i as u32))).collect();
        for s in 11..=18 {
            assert!(!ext[s] && (out[s] - (5.0 + (s as f32 - 10.3) / 8.0)).abs() < 1e-5, "pixel {s}: {}", out[s]);
        }
        for s in (4..=10).chain(19..=25) {
            let want = 5.0 + (s as f32 - 10.3) / 8.0;
            assert!(ext[s] && (out[s] - want).abs() < 1e-5, "pixel {s}: {} (extended {}), want {want}", out[s], ext[s]);
        }
        for s in [3, 26] {
            assert!(out[s].is_nan(), "pixel {s}: {} is past the reach", out[s]);
        }
        assert!(ext[w + 19], "the shadowed line's first extended pixel");
        for s in 20..len {
            assert!(out[w + s].is_nan(), "pixel {s} of the shadowed line: {}", out[w + s]);
        }
        for s in 19..len {
            assert!(out[2 * w + s].is_nan(), "pixel {s} of the line shadowed from the boundary: {}", out[2 * w + s]);
        }
    }

    /// A stretch is extended with the mean width of the stripes beside its end that are
    /// as wide as the nearest (within 15 %) and span at most 24 pixels together. Where
    /// only the nearest is taken, with the width at the boundary that its trend from the
    /// one beyond gives; with the nearest alone where the one beyond is not identified or
    /// is over 1.5 times as wide.
    #[test]
    fn a_stretch_is_extended_with_the_mean_width_of_the_stripes_beside_its_end() {
        let line = [edge(10.0, 3), edge(17.0, 4), edge(24.2, 5), edge(31.0, 6)];
        // Past the last edge: 6.8, 7.2 and 7.0.
        let w = extension_width(&line, 3, -1, 1).unwrap();
        assert!((w - 7.0).abs() < 1e-5, "{w}");
        // Before the first: 7.0, 7.2 and 6.8.
        let w = extension_width(&line, 0, 1, 1).unwrap();
        assert!((w - 7.0).abs() < 1e-5, "{w}");
        // A 10-pixel stripe ends the mean there (6.8 and 7.2 taken, 10 not).
        let uneven = [edge(7.0, 3), edge(17.0, 4), edge(24.2, 5), edge(31.0, 6)];
        let w = extension_width(&uneven, 3, -1, 1).unwrap();
        assert!((w - 7.0).abs() < 1e-5, "{w}");
        // An unidentified edge: the nearest stripe alone.
        let broken = [edge(10.0, 3), edge(17.0, 4), edge(24.2, -1), edge(31.0, 6), edge(37.6, 7)];
        assert_eq!(extension_width(&broken, 4, -1, 1), Some(37.6 - 31.0));
        // 26- and 30-pixel stripes: the width at the boundary from their trend.
        let wide = [edge(10.0, 3), edge(36.0, 4), edge(66.0, 5)];
        let w = extension_width(&wide, 2, -1, 1).unwrap();
        assert!((w - (30.0 + 2.0 * bend_share(30.0))).abs() < 1e-4 && w > 31.9, "{w}");
        let w = extension_width(&wide, 0, 1, 1).unwrap();
        assert!((w - (26.0 - 2.0 * bend_share(26.0))).abs() < 1e-4 && w < 24.2, "{w}");
        // A next stripe over 1.5 times as wide is another surface: the nearest alone.
        let step_up = [edge(10.0, 3), edge(50.0, 4), edge(75.0, 5)];
        assert_eq!(extension_width(&step_up, 2, -1, 1), Some(25.0));
        // No identified stripe beside the end: no extension.
        assert_eq!(extension_width(&broken, 3, -1, 1), None);
        assert_eq!(extension_width(&line, 3, 1, 1), None);
    }

    /// Across a wide stripe on a curved surface the coordinate bends with the widths of
    /// the stripes beside it: where the boundaries lie on a smooth curve, the curve
    /// through them is several times closer than the straight line between two, and it
    /// rises monotonically. A narrow stripe stays nearly straight; a neighbour more
    /// than [`BEND_WIDTH_RATIO`] wider or narrower, or none, leaves its side straight.
    #[test]
    fn a_wide_stripe_s_coordinate_bends_with_the_stripes_beside_it() {
        // Boundary j at x = 100 + 25 j + 3 j²: the stripes widen by 6 px each.
        let at = |q: f32| 100.0 + 25.0 * q + 3.0 * q * q;
        let line = named(&(0..6).map(|j| edge(at(j as f32), j)).collect::<Vec<_>>());
        let k = 2;
        let (a, b) = (line[k].edge.pos, line[k + 1].edge.pos);
        let tangents = tangents_of(&line, k, 1);
        let (mut straight, mut bent, mut last) = (0.0f32, 0.0f32, 0.0f32);
        for s in (a.ceil() as usize)..(b.ceil() as usize) {
            let t = (s as f32 - a) / (b - a);
            // The true coordinate at pixel s: the root of at(q) = s.
            let truth = (-25.0 + (625.0 + 12.0 * (s as f32 - 100.0)).sqrt()) / 6.0 - k as f32;
            let v = across_stripe(t, tangents);
            assert!(v >= last, "monotonic at {s}");
            last = v;
            straight = straight.max((t - truth).abs());
            bent = bent.max((v - truth).abs());
        }
        assert!(straight > 0.015, "the straight line is off by {straight} of a stripe");
        assert!(bent < straight / 4.0, "bent {bent} against straight {straight}");
        // Both tangents 1: the straight line.
        assert!((across_stripe(0.3, [1.0, 1.0]) - 0.3).abs() < 1e-6);
        // 7-pixel stripes: about a tenth of Catmull-Rom's bend.
        let narrow = named(&[edge(100.0, 0), edge(106.5, 1), edge(113.5, 2), edge(121.0, 3)]);
        let [m0, m1] = tangents_of(&narrow, 1, 1);
        assert!(m0 > 1.0 && m0 - 1.0 < 0.15 * (2.0 * 7.0 / 13.5 - 1.0), "{m0}");
        assert!(m1 < 1.0 && 1.0 - m1 < 0.15 * (1.0 - 2.0 * 7.0 / 14.5), "{m1}");
        // A neighbour twice as wide (another surface), and none: straight on that side.
        let broken = named(&[edge(100.0, 0), edge(150.0, 1), edge(175.0, 2), edge(203.0, 3)]);
        let [m0, m1] = tangents_of(&broken, 1, 1);
        assert_eq!(m0, 1.0);
        assert!(m1 < 1.0, "{m1}");
        assert_eq!(tangents_of(&broken, 0, 1)[0], 1.0);
    }

    /// A line between two aligned lines takes the identities they agree on where its
    /// own transition fits them; an edge whose neighbours both are unidentified stays
    /// so; an edge whose neighbours disagree, or where only one is identified, or
    /// whose transition does not fit, is in doubt and unidentified.
    #[test]
    fn a_line_takes_the_identities_the_lines_either_side_agree_on() {
        let spec = PatternSpec::generate(2, 64, 48, 8.0).unwrap();
        let decoder = Decoder::new(&spec, 0, true);
        let before = [edge(10.0, 5), edge(18.0, 6), edge(26.0, -1), edge(34.0, 8), edge(42.0, 9), edge(50.0, 10)];
        let after = [edge(10.8, 5), edge(18.8, 6), edge(26.8, -1), edge(34.8, 7), edge(42.8, -1)];
        let misfit = decoder.seen_code(5);
        let mut line: Vec<Edge> = [10.4, 18.4, 26.4, 34.4, 42.4, 50.4, 60.0].iter().map(|&p| edge(p, 3)).collect();
        line[1].mask = 1 << decoder.seen_code(6);
        line[0].mask = ANY_BOUNDARY & !(1 << misfit);
        let doubtful = decoder.infer_line(&before, &after, &mut line);
        let ids: Vec<i32> = line.iter().map(|e| e.id).collect();
        assert_eq!(ids, [-1, 6, -1, -1, -1, -1, -1]);
        // The misfit, the disagreement, and the two identified on one side only.
        assert_eq!(doubtful, 4);
    }

    /// A stripe much wider than the identified stripe beside it (a cast shadow between
    /// two edges taken for consecutive boundaries) is not decoded; one as wide as its
    /// neighbour, or a little wider (slant), is; a stripe with no identified stripe
    /// beside it is held to two thirds of the widest stretch.
    #[test]
    fn a_stripe_much_wider_than_its_neighbour_is_not_decoded() {
        let line = named(&[edge(10.0, 3), edge(20.0, 4), edge(31.0, 5), edge(55.0, 6), edge(66.0, -1), edge(80.0, 9), edge(100.0, 10)]);
        assert!(!wider(&line, 0, 1, 30.0), "a little narrower than its neighbour");
        assert!(!wider(&line, 1, 1, 30.0), "narrower than the wider of its neighbours");
        assert!(wider(&line, 2, 1, 30.0), "more than twice its neighbour");
        assert!(!wider(&line, 4, 1, 30.0), "alone, under two thirds of the widest");
        assert!(wider(&line, 4, 1, 29.0), "alone, over two thirds of the widest");
        let falling: Vec<Named> = line.iter().map(|n| Named { edge: Edge { id: 20 - n.edge.id, ..n.edge }, ..*n }).collect();
        assert!(wider(&falling, 2, -1, 30.0), "identities falling along the line");
    }

    /// Of two consecutive edges with one identity, the one that leaves the stripes
    /// either side as wide as each other keeps it; where neither does, or a neighbour
    /// one stripe away is missing, both keep it.
    #[test]
    fn of_a_boundary_identified_twice_the_edge_that_fits_its_stripes_keeps_it() {
        let ids = |edges: &[Edge]| -> Vec<i32> {
            let mut edges = edges.to_vec();
            settle_repeated_identities(&mut edges, 1, &mut Vec::new());
            edges.iter().map(|e| e.id).collect()
        };
        // A dye edge 12 pixels before the boundary of a 30-pixel stripe.
        let line = [edge(125.0, 6), edge(155.3, 7), edge(175.3, 8), edge(187.6, 8), edge(216.5, 9), edge(245.0, 10)];
        assert_eq!(ids(&line), [6, 7, -1, 8, 9, 10], "the dye edge loses it");
        let after = [edge(155.3, 7), edge(187.6, 8), edge(199.0, 8), edge(216.5, 9)];
        assert_eq!(ids(&after), [7, 8, -1, 9], "an edge after the boundary loses it");
        let uneven = [edge(100.0, 7), edge(110.0, 8), edge(150.0, 8), edge(160.0, 9)];
        assert_eq!(ids(&uneven), [7, 8, 8, 9], "neither fits: both keep it");
        let alone = [edge(175.3, 8), edge(187.6, 8), edge(216.5, 9), edge(245.0, 10)];
        assert_eq!(ids(&alone), [8, 8, 9, 10], "no boundary one stripe before");
        let falling: Vec<Edge> = line.iter().map(|e| Edge { id: 20 - e.id, ..*e }).collect();
        let mut settled = falling.clone();
        settle_repeated_identities(&mut settled, -1, &mut Vec::new());
        assert_eq!(settled.iter().map(|e| e.id).collect::<Vec<_>>(), [14, 13, -1, 12, 11, 10], "identities falling along the line");
    }

    /// A stripe with an edge inside it that the alignment left without an identity
    /// (the surface's texture) is decoded from boundary to boundary where the stripes
    /// either side are as wide as it; where one of them is not (a fold, a depth step),
    /// only the extensions from its ends reach into it, each up to a pixel short of that
    /// edge.
    #[test]
    fn a_stripe_is_decoded_across_an_unidentified_edge_where_its_neighbours_are_as_wide() {
        let spec = PatternSpec::generate(1, 64, 16, 8.0).unwrap();
        let mut decoder = Decoder::new(&spec, 0, true);
        let w = 60;
        let seg = rows(vec![
            vec![edge(10.0, 3), edge(20.0, 4), edge(24.5, -1), edge(30.5, 5), edge(40.5, 6)],
            vec![edge(10.0, 3), edge(20.0, 4), edge(26.5, -1), edge(33.4, 5), edge(46.4, 6)],
        ]);
        let linear = vec![[0.3f32; 3]; w * 2];
        let mut out = vec![0.0; w * 2];
        decoder.stripe_coords_into(&seg, &linear, w, 100.0, &mut out);
        let ext: Vec<bool> = (0..out.len()).map(|i| decoder.extended().contains(&(i as u32))).collect();
        // Stripe 4 to 5, bent as wide stripes are (see `stripe_tangents`).
        let tangents = tangents_of(&named(&seg.lines[0]), 1, 1);
        for s in 21..=30 {
            let want = 4.0 + across_stripe((s as f32 - 20.0) / 10.5, tangents);
            assert!(!ext[s] && (out[s] - want).abs() < 1e-5, "texture, pixel {s}: {} (extended {}), want {want}", out[s], ext[s]);
        }
        for s in (21..=25).chain(28..=33) {
            let i = w + s;
            let want = if s < 26 { 4.0 + (s as f32 - 20.0) / 10.0 } else { 5.0 - (33.4 - s as f32) / 13.0 };
            assert!(ext[i] && (out[i] - want).abs() < 1e-5, "fold, pixel {s}: {} (extended {}), want {want}", out[i], ext[i]);
        }
        // Each extension stops a pixel short of the edge.
        assert!(out[w + 26].is_nan() && out[w + 27].is_nan());
    }

    /// Two stripes between identified boundaries 3 and 5 are decoded through an edge
    /// without an identity where boundary 4 should be (from one edge to the next), not
    /// where that edge is two pixels (a fifth of a stripe) off, nor where a second
    /// edge lies between, nor three stripes through two such edges
    /// ([`MISREAD_MAX_STRIPES`]). The identified edges read every channel, so no
    /// boundary between them is hidden from both.
    #[test]
    fn stripes_are_decoded_through_a_misread_boundary_where_it_should_be() {
        let spec = PatternSpec::generate(1, 64, 16, 8.0).unwrap();
        let w = 40;
        let out = coords_of_rows(&spec, w, vec![
            vec![red(10.0, 3), edge(20.3, -1), red(30.0, 5)],
            vec![red(10.0, 3), edge(22.0, -1), red(30.0, 5)],
            vec![red(10.0, 3), edge(20.0, -1), edge(24.0, -1), red(30.0, 5)],
            vec![red(0.0, 2), edge(10.0, -1), edge(20.0, -1), red(30.0, 5)],
        ]);
        for s in 11..30 {
            let want = if (s as f32) < 20.3 { 3.0 + (s as f32 - 10.0) / 10.3 } else { 4.0 + (s as f32 - 20.3) / 9.7 };
            assert!((out[s] - want).abs() < 1e-5, "misread, pixel {s}: {}, want {want}", out[s]);
            assert!(out[w + s].is_nan(), "two pixels off, pixel {s}: {}", out[w + s]);
            assert!(out[2 * w + s].is_nan(), "two edges, pixel {s}: {}", out[2 * w + s]);
            assert!(out[3 * w + s].is_nan(), "three stripes, pixel {s}: {}", out[3 * w + s]);
        }
    }

    /// Between identified stripes as wide as theirs, stripes are decoded through edges
    /// halfway between their boundaries with another edge beside them (a patch of the
    /// surface), two stripes and three; not where a stripe beside is narrower by three
    /// tenths (a fold or an occluding edge), nor where the misread edge is a fifth of a
    /// stripe off.
    #[test]
    fn stripes_are_decoded_through_misread_boundaries_among_texture_edges_between_stripes_as_wide() {
        // Stripes of 32 projector pixels: two are wider than a dark band is bridged.
        let spec = PatternSpec::generate(1, 320, 16, 32.0).unwrap();
        let w = 60;
        let out = coords_of_rows(&spec, w, vec![
            vec![red(0.0, 2), red(10.0, 3), edge(20.3, -1), edge(25.0, -1), red(30.0, 5), red(40.0, 6)],
            vec![red(0.0, 2), red(10.0, 3), edge(20.3, -1), edge(25.0, -1), red(30.0, 5), red(37.0, 6)],
            vec![red(0.0, 2), red(10.0, 3), edge(22.0, -1), edge(25.0, -1), red(30.0, 5), red(40.0, 6)],
            vec![red(0.0, 2), red(10.0, 3), edge(14.0, -1), edge(20.2, -1), edge(29.9, -1), red(40.0, 6), red(50.0, 7)],
        ]);
        let through = |s: usize, knots: &[(f32, f32)]| {
            let k = knots.windows(2).find(|p| (s as f32) < p[1].0).unwrap_or(&knots[knots.len() - 2..]);
            k[0].1 + (s as f32 - k[0].0) / (k[1].0 - k[0].0) * (k[1].1 - k[0].1)
        };
        for s in 11..30 {
            let want = through(s, &[(10.0, 3.0), (20.3, 4.0), (30.0, 5.0)]);
            assert!((out[s] - want).abs() < 1e-5, "two stripes, pixel {s}: {}, want {want}", out[s]);
        }
        // Beyond what the stretches either side are extended into (up to 18.5, and back
        // to the edge at 25).
        for s in 19..=25 {
            assert!(out[w + s].is_nan(), "a narrower neighbour, pixel {s}: {}", out[w + s]);
            assert!(out[2 * w + s].is_nan(), "two pixels off, pixel {s}: {}", out[2 * w + s]);
        }
        for s in 11..40 {
            let want = through(s, &[(10.0, 3.0), (20.2, 4.0), (29.9, 5.0), (40.0, 6.0)]);
            assert!((out[3 * w + s] - want).abs() < 1e-5, "three stripes, pixel {s}: {}, want {want}", out[3 * w + s]);
        }
    }

    /// Three stripes of 8 projector pixels (24, within `BRIDGE_MAX_SPAN`) across a band
    /// at a thirtieth of the light, with two edges without an identity in it, are
    /// decoded as one stretch where the stripes either side are as wide as their mean
    /// and the band shows the stripes' colours; not where a neighbour is a fifth
    /// narrower, nor across seven stripes, nor where the band is one grey (a shadow).
    /// Four, five and six stripes (32, 40 and 48 pixels) are decoded across a dark
    /// band, four not across lit edges.
    #[test]
    fn stripes_across_a_dark_band_are_decoded_where_their_neighbours_are_as_wide() {
        let spec = PatternSpec::generate(1, 96, 16, 8.0).unwrap();
        let mut decoder = Decoder::new(&spec, 0, true);
        let w = 80;
        let band = [edge(14.5, -1), edge(25.5, -1)];
        let (start, even) = (vec![edge(4.0, 2), edge(12.0, 3)], vec![edge(36.0, 6), edge(44.0, 7)]);
        let four = vec![edge(44.0, 7), edge(52.0, 8)];
        let five = vec![edge(52.0, 8), edge(60.0, 9)];
        let lines = vec![
            [start.clone(), band.to_vec(), even.clone()].concat(),
            [start.clone(), band.to_vec(), vec![edge(36.0, 6), edge(42.4, 7)]].concat(),
            // Seven stripes: past BRIDGE_MAX_STRIPES.
            [start.clone(), band.to_vec(), vec![edge(68.0, 10), edge(76.0, 11)]].concat(),
            [start.clone(), band.to_vec(), even].concat(),
            [start.clone(), band.to_vec(), four.clone()].concat(),
            [start.clone(), band.to_vec(), four].concat(),
            [start.clone(), band.to_vec(), five].concat(),
            // Six stripes, 48 projector pixels.
            [start, band.to_vec(), vec![edge(60.0, 9), edge(68.0, 10)]].concat(),
        ];
        let n = lines.len();
        let seg = rows(lines);
        // The band: 3 % of each stripe's colour (stripe j from 12 + 8 (j - 3)); one
        // grey on line 3; none on line 5 (lit throughout).
        let mut linear = vec![[0.3f32; 3]; w * n];
        for line in (0..n).filter(|&l| l != 5) {
            for s in 15..26 {
                let j = 3 + (s as i64 - 12) / 8;
                let c = spec.stripe_color(0, j).map(|v| 0.03 * v as f32 + 0.002);
                linear[line * w + s] = if line == 3 { [0.01; 3] } else { c };
            }
        }
        let mut out = vec![0.0; w * n];
        decoder.stripe_coords_into(&seg, &linear, w, 100.0, &mut out);
        for (line, end) in [(0, 36), (4, 44), (6, 52), (7, 60)] {
            for s in 13..end {
                let want = 3.0 + (s as f32 - 12.0) / 8.0;
                let q = out[line * w + s];
                assert!((q - want).abs() < 1e-5, "line {line}, pixel {s}: {q}, want {want}");
            }
        }
        for line in [1, 2, 3, 5] {
            assert!(out[line * w + 15..line * w + 26].iter().all(|q| q.is_nan()), "line {line}: the band was decoded");
        }
    }

    /// An edge whose line read it as `id` by `margin` bits over `alt`, not taken.
    fn read(pos: f32, id: i32, alt: i32, margin: f32) -> Edge {
        Edge { tentative: Tentative { id, alt, margin, spurious_margin: 5.0 }, ..edge(pos, -1) }
    }

    /// Twelve lines read one boundary as 6, each only 3 bits ahead of 8 (too few to
    /// take on a line): its chain labels it 6 on every line. A second boundary, half
    /// its lines reading 11 and half 13, stays empty; so does a third read as 15 on
    /// three lines and as nothing on the rest (9 bits, short of 12). An edge taken on
    /// its own line keeps its identity, and with one family there are no chains.
    #[test]
    fn chains_label_the_boundaries_their_lines_agree_on() {
        let spec = PatternSpec::generate(2, 64, 48, 4.0).unwrap();
        let mut decoder = Decoder::new(&spec, 0, true);
        let mut seg = Segmentation::default();
        seg.axis = Some(ScanAxis::Rows);
        for l in 0..12 {
            let drift = 0.2 * l as f32;
            let split = if l % 2 == 0 { read(30.0 + drift, 11, 13, 3.0) } else { read(30.0 + drift, 13, 11, 3.0) };
            let sparse = if l < 3 { read(50.0 - drift, 15, 17, 3.0) } else { read(50.0 - drift, -1, -1, 0.0) };
            let mut first = read(10.0 + drift, 6, 8, 3.0);
            if l == 4 {
                first.id = 7;
            }
            seg.lines.push(vec![first, split, sparse]);
        }
        let mut one = Segmentation::default();
        (one.axis, one.lines) = (seg.axis, seg.lines.clone());
        decoder.label_chains(&mut seg);
        for (l, line) in seg.lines.iter().enumerate() {
            assert_eq!(line[0].id, if l == 4 { 7 } else { 6 }, "line {l}: the first boundary");
            assert_eq!(line[1].id, -1, "line {l}: a split vote");
            assert_eq!(line[2].id, -1, "line {l}: too few votes");
            assert_eq!(decoder.chain_labelled[3 * l], l != 4, "line {l}: labelled by its chain");
        }
        let single = PatternSpec::generate(1, 64, 48, 4.0).unwrap();
        let mut decoder = Decoder::new(&single, 0, true);
        decoder.run(&mut one, 4.0);
        assert!(decoder.chain_labelled.is_empty(), "one family: no chains");
    }

    /// Stripes that reach a boundary its chain labelled are listed as weak, and only
    /// where the line without the chains' labels left them empty: the stretch of two
    /// boundaries taken on the line and its extension keep their coordinates unlisted.
    #[test]
    fn stripes_from_chain_labels_are_weak_where_nothing_else_reached() {
        let spec = PatternSpec::generate(2, 64, 48, 8.0).unwrap();
        let mut decoder = Decoder::new(&spec, 0, true);
        let w = 50;
        let seg = rows(vec![vec![edge(10.3, 5), edge(18.3, 6), edge(26.3, 7), edge(34.3, 8)]]);
        decoder.chain_labelled = vec![false, false, true, true];
        let linear = vec![[0.3f32; 3]; w];
        let mut out = vec![0.0; w];
        decoder.stripe_coords_into(&seg, &linear, w, 100.0, &mut out);
        let weak: Vec<bool> = (0..w).map(|i| decoder.weak().contains(&(i as u32))).collect();
        for s in 4..=41 {
            let want = 5.0 + (s as f32 - 10.3) / 8.0;
            assert!((out[s] - want).abs() < 1e-5, "pixel {s}: {}, want {want}", out[s]);
            assert_eq!(weak[s], s >= 26, "pixel {s}: weak");
        }
        assert!(out[3].is_nan() && out[42].is_nan());
    }
}
