//! Analytic shapes and their ray intersections.
//!
//! Everything is in the camera frame (x right, y down, z forward, millimetres). A ray
//! is `o + t·d` with `d` not necessarily of unit length; intersections report the ray
//! parameter `t`, so for a camera ray with `d.z = 1` the parameter *is* the depth Z.
//!
//! Every shape also gives, at a surface point, its unit normal and its *surface
//! coordinates* `(s, t)` in millimetres, the 2-D coordinates that textures are laid out
//! in (documented per variant of [`Shape`]).

use crate::error::{Error, Result};
use glam::{DMat3, DVec2, DVec3};

/// Marching never steps less than this along a ray through a height field, mm. A fold
/// thinner than this along the ray (a grazing sliver well under a tenth of a camera
/// pixel at the demo rig's working distance) may be stepped over.
const HEIGHT_FIELD_MIN_STEP_MM: f64 = 0.25;

/// Height-field roots are refined until the bracket or the Newton step is below this,
/// mm: far below the 0.05 mm the ground truth is checked to.
const HEIGHT_FIELD_TOLERANCE_MM: f64 = 1e-6;

/// Iteration cap of the root refinement (bisection alone would need about 22 steps to
/// go from [`HEIGHT_FIELD_MIN_STEP_MM`] to [`HEIGHT_FIELD_TOLERANCE_MM`]).
const HEIGHT_FIELD_REFINE_ITERATIONS: usize = 60;

/// An analytic surface in the camera frame. Lengths are millimetres.
#[derive(Clone, Debug)]
pub enum Shape {
    /// The infinite plane through `point` with normal `normal` (either orientation, any
    /// non-zero length). Surface coordinates: `s` along the camera's x axis projected
    /// into the plane, `t` along the in-plane direction closest to the camera's y axis
    /// (so on a plane facing the camera `s` runs right and `t` down), origin at `point`.
    Plane {
        /// A point on the plane, mm.
        point: DVec3,
        /// The plane's normal.
        normal: DVec3,
    },
    /// A sphere. Surface coordinates: `s = radius · longitude`, `t = radius · latitude`,
    /// with the poles on the camera's y axis through the centre, longitude 0 facing the
    /// camera (−z) and increasing towards +x, latitude increasing downwards (+y).
    Sphere {
        /// Centre, mm.
        center: DVec3,
        /// Radius, mm.
        radius: f64,
    },
    /// An oriented box. Surface coordinates on a face: the two box-frame coordinates
    /// across the face (in axis order), measured from the box centre.
    Cuboid {
        /// Centre, mm.
        center: DVec3,
        /// Columns are the box's three orthonormal axes in the camera frame.
        axes: DMat3,
        /// Half the box's extent along each of its axes, mm.
        half: DVec3,
    },
    /// A capped cylinder. Surface coordinates on the side: `s` = arc length around the
    /// axis from the side facing the camera, `t` = position along the axis from the
    /// centre; on a cap: the two cap-plane coordinates along the same reference directions.
    Cylinder {
        /// Centre of the axis segment, mm.
        center: DVec3,
        /// Unit direction of the axis.
        axis: DVec3,
        /// Radius, mm.
        radius: f64,
        /// Half the length of the axis segment, mm.
        half_length: f64,
    },
    /// A sheet `z = z0 + h(x, y)` over a rectangle, see [`HeightField`]. Surface
    /// coordinates: `(x, y)` of the camera frame.
    HeightField(HeightField),
    /// A rectangular sheet (a card, a chart, a board) bent around one axis: a piece of
    /// a cylinder's side, or flat when `curvature` is 0. In the sheet's own frame
    /// (`axes` columns: across the bend, along the bend axis, the normal at the
    /// centre pointing away from the side it faces) the sheet is
    /// `(sin(κs)/κ, t, (1 − cos(κs))/κ)` for `|s| <= half_size.x`, `|t| <= half_size.y`,
    /// κ = `curvature`: with κ > 0 its sides curl away along the third axis (convex
    /// towards a viewer on the −z side), with κ < 0 towards it. Surface coordinates:
    /// `(s, t)`, arc length across the bend and distance along it, from the centre.
    BentSheet {
        /// Centre of the sheet, mm.
        center: DVec3,
        /// Columns: the sheet's across, along and normal axes in the camera frame.
        axes: DMat3,
        /// 1 / bend radius, 1/mm (0 for a flat sheet).
        curvature: f64,
        /// Half the sheet's width (arc length) and height, mm.
        half_size: DVec2,
    },
}

/// The point of a bent sheet (own frame) at surface coordinates (s, t), and the angle
/// κs; flat sheets have angle 0.
fn bent_point(curvature: f64, s: f64, t: f64) -> DVec3 {
    if curvature == 0.0 {
        return DVec3::new(s, t, 0.0);
    }
    let (sin, cos) = (curvature * s).sin_cos();
    DVec3::new(sin / curvature, t, (1.0 - cos) / curvature)
}

/// Surface coordinates (s, t) of a point on (or near) a bent sheet, own frame.
fn bent_coords(curvature: f64, q: DVec3) -> DVec2 {
    if curvature == 0.0 {
        return DVec2::new(q.x, q.y);
    }
    let angle = (curvature * q.x).atan2(1.0 - curvature * q.z);
    DVec2::new(angle / curvature, q.y)
}

/// A sheet `z = z0 + h(x, y)` over the rectangle `x_range × y_range` of the camera frame.
///
/// `h` is sampled once on a square grid and the surface *is* the bilinear interpolation
/// of those samples (continuous, with creases along grid lines no steeper than the
/// samples), so ray intersections are exact up to the refinement tolerance and need no
/// further calls of `h`. Shading uses normals from central differences at the grid
/// nodes, interpolated bilinearly, so the facets of the grid do not show.
///
/// Rays are intersected by marching with steps that cannot cross the surface (the
/// distance along z to the sheet divided by a Lipschitz bound of that distance along
/// the ray, computed exactly from the samples), never shorter than a quarter
/// millimetre, then a bracketed Newton-bisection refinement to 1e-6 mm.
#[derive(Clone, Debug)]
pub struct HeightField {
    x0: f64,
    y0: f64,
    x1: f64,
    y1: f64,
    spacing: f64,
    inv_spacing: f64,
    nx: usize,
    ny: usize,
    z0: f64,
    heights: Vec<f64>,
    normals: Vec<[f32; 3]>,
    h_min: f64,
    h_max: f64,
    /// Upper bound of |∇h| over the bilinear surface.
    slope: f64,
    /// Blocks of `BLOCK_CELLS` x `BLOCK_CELLS` cells, `bx` across, `by` down.
    blocks: Vec<Block>,
    bx: usize,
    by: usize,
}

/// Height range and slope bound of a square block of grid cells, for skipping the
/// parts of a ray that cannot meet the sheet and marching the rest with local bounds.
#[derive(Clone, Copy, Debug)]
struct Block {
    h_min: f64,
    h_max: f64,
    slope: f64,
}

/// Cells per block side: 8 mm blocks on the paper scene, where a camera ray's
/// footprint through the sheet's height range spans a few blocks.
const BLOCK_CELLS: usize = 8;

impl HeightField {
    /// Sample `h` (mm, as a function of camera-frame x and y in mm) every `spacing` mm
    /// over `x_range × y_range`; the sheet is `z = z0 + h(x, y)`. The ranges are
    /// widened to a whole number of grid cells. Fails on empty or non-finite ranges, a
    /// spacing that is not positive, more than 16 million samples, or non-finite heights.
    pub fn new(
        x_range: (f64, f64),
        y_range: (f64, f64),
        spacing: f64,
        z0: f64,
        h: impl Fn(f64, f64) -> f64,
    ) -> Result<Self> {
        let finite = [x_range.0, x_range.1, y_range.0, y_range.1, spacing, z0].iter().all(|x| x.is_finite());
        if !finite || !(spacing > 0.0) || !(x_range.1 > x_range.0) || !(y_range.1 > y_range.0) {
            return Err(Error::Scene(format!(
                "height field: ranges {x_range:?} x {y_range:?}, spacing {spacing}, z0 {z0} must be finite, non-empty and positive"
            )));
        }
        let cells = |r: (f64, f64)| ((r.1 - r.0) / spacing).ceil().max(1.0);
        let (cx, cy) = (cells(x_range), cells(y_range));
        if (cx + 1.0) * (cy + 1.0) > 16e6 {
            return Err(Error::Scene(format!("height field: {cx} x {cy} cells is too many")));
        }
        let (nx, ny) = (cx as usize + 1, cy as usize + 1);
        let (x0, y0) = (x_range.0, y_range.0);
        let mut heights = Vec::with_capacity(nx * ny);
        for j in 0..ny {
            for i in 0..nx {
                let value = h(x0 + i as f64 * spacing, y0 + j as f64 * spacing);
                if !value.is_finite() {
                    return Err(Error::Scene(format!("height field: h is {value} at node ({i}, {j})")));
                }
                heights.push(value);
            }
        }
        let at = |i: usize, j: usize| heights[j * nx + i];
        // Node normals from central differences (one-sided at the border), facing −z.
        let mut normals = Vec::with_capacity(nx * ny);
        for j in 0..ny {
            for i in 0..nx {
                let (il, ir) = (i.saturating_sub(1), (i + 1).min(nx - 1));
                let (ju, jd) = (j.saturating_sub(1), (j + 1).min(ny - 1));
                let hx = (at(ir, j) - at(il, j)) / ((ir - il).max(1) as f64 * spacing);
                let hy = (at(i, jd) - at(i, ju)) / ((jd - ju).max(1) as f64 * spacing);
                let n = DVec3::new(hx, hy, -1.0).normalize();
                normals.push([n.x as f32, n.y as f32, n.z as f32]);
            }
        }
        // Within a cell hx is linear in y and hy linear in x, so |∇h|² is bounded by the
        // largest hx² on the two x-edges plus the largest hy² on the two y-edges.
        let (bx, by) = ((nx - 1).div_ceil(BLOCK_CELLS), (ny - 1).div_ceil(BLOCK_CELLS));
        let mut blocks = vec![
            Block {
                h_min: f64::INFINITY,
                h_max: f64::NEG_INFINITY,
                slope: 0.0
            };
            bx * by
        ];
        for j in 0..ny - 1 {
            for i in 0..nx - 1 {
                let (h00, h10, h01, h11) = (at(i, j), at(i + 1, j), at(i, j + 1), at(i + 1, j + 1));
                let hx = (h10 - h00).abs().max((h11 - h01).abs()) / spacing;
                let hy = (h01 - h00).abs().max((h11 - h10).abs()) / spacing;
                let b = &mut blocks[(j / BLOCK_CELLS) * bx + i / BLOCK_CELLS];
                b.slope = b.slope.max((hx * hx + hy * hy).sqrt());
                b.h_min = b.h_min.min(h00.min(h10).min(h01).min(h11));
                b.h_max = b.h_max.max(h00.max(h10).max(h01).max(h11));
            }
        }
        let slope = blocks.iter().fold(0f64, |m, b| m.max(b.slope));
        let h_min = blocks.iter().fold(f64::INFINITY, |m, b| m.min(b.h_min));
        let h_max = blocks.iter().fold(f64::NEG_INFINITY, |m, b| m.max(b.h_max));
        Ok(HeightField {
            x0,
            y0,
            x1: x0 + (nx - 1) as f64 * spacing,
            y1: y0 + (ny - 1) as f64 * spacing,
            spacing,
            inv_spacing: 1.0 / spacing,
            nx,
            ny,
            z0,
            heights,
            normals,
            h_min,
            h_max,
            slope,
            blocks,
            bx,
            by,
        })
    }

    /// The covered rectangle, `((x_min, x_max), (y_min, y_max))`, mm.
    pub fn extent(&self) -> ((f64, f64), (f64, f64)) {
        ((self.x0, self.x1), (self.y0, self.y1))
    }

    /// Lowest and highest `h` over the sheet, mm.
    pub fn height_range(&self) -> (f64, f64) {
        (self.h_min, self.h_max)
    }

    /// The sheet's base depth `z0`, mm.
    pub fn base_depth(&self) -> f64 {
        self.z0
    }

    /// Largest slope |∇h| of the surface.
    pub fn max_slope(&self) -> f64 {
        self.slope
    }

    /// Cell index and fractions of a point. Points outside the grid use the nearest
    /// border cell (the fractions then extrapolate it, which only happens by rounding
    /// errors: callers clip rays to the sheet first).
    #[inline]
    fn locate(&self, x: f64, y: f64) -> (usize, usize, f64, f64) {
        let gx = (x - self.x0) * self.inv_spacing;
        let gy = (y - self.y0) * self.inv_spacing;
        // Truncation is the floor for the non-negative values kept; the cast through
        // i64 is much cheaper than a direct f64 -> usize one on x86-64.
        let i = (gx.max(0.0) as i64).min(self.nx as i64 - 2);
        let j = (gy.max(0.0) as i64).min(self.ny as i64 - 2);
        (i as usize, j as usize, gx - i as f64, gy - j as f64)
    }

    /// The four heights of the cell holding (x, y), `[h00, h10, h01, h11]`, and the
    /// fractions (fx, fy) within it.
    #[inline(always)]
    fn cell(&self, x: f64, y: f64) -> ([f64; 4], f64, f64) {
        let (i, j, fx, fy) = self.locate(x, y);
        let k = j * self.nx + i;
        let h = [self.heights[k], self.heights[k + 1], self.heights[k + self.nx], self.heights[k + self.nx + 1]];
        (h, fx, fy)
    }

    /// `h` of the bilinear surface and its gradient at (x, y) (clamped into the sheet).
    #[inline]
    pub fn height(&self, x: f64, y: f64) -> (f64, DVec2) {
        let ([h00, h10, h01, h11], fx, fy) = self.cell(x, y);
        let top = h00 + (h10 - h00) * fx;
        let bottom = h01 + (h11 - h01) * fx;
        let h = top + (bottom - top) * fy;
        let hx = ((h10 - h00) * (1.0 - fy) + (h11 - h01) * fy) * self.inv_spacing;
        let hy = (bottom - top) * self.inv_spacing;
        (h, DVec2::new(hx, hy))
    }

    /// `h` alone, as [`HeightField::height`] (the marching loop needs no gradient).
    #[inline(always)]
    fn height_only(&self, x: f64, y: f64) -> f64 {
        let ([h00, h10, h01, h11], fx, fy) = self.cell(x, y);
        let top = h00 + (h10 - h00) * fx;
        let bottom = h01 + (h11 - h01) * fx;
        top + (bottom - top) * fy
    }

    /// The interpolated shading normal at (x, y), unit, facing −z.
    fn shading_normal(&self, x: f64, y: f64) -> DVec3 {
        let (i, j, fx, fy) = self.locate(x, y);
        let k = j * self.nx + i;
        let n = |k: usize| DVec3::new(self.normals[k][0] as f64, self.normals[k][1] as f64, self.normals[k][2] as f64);
        let top = n(k).lerp(n(k + 1), fx);
        let bottom = n(k + self.nx).lerp(n(k + self.nx + 1), fx);
        top.lerp(bottom, fy).normalize_or(DVec3::NEG_Z)
    }

    /// Nearest `t` in `[t_min, t_max]` where `o + t·d` meets the sheet: a walk
    /// through the blocks the ray's footprint crosses (Amanatides-Woo), marching only
    /// where the ray is within a block's height range.
    fn intersect(&self, o: DVec3, d: DVec3, t_min: f64, t_max: f64) -> Option<f64> {
        let ((x0, x1), (y0, y1)) = self.extent();
        let lo = DVec3::new(x0, y0, self.z0 + self.h_min);
        let hi = DVec3::new(x1, y1, self.z0 + self.h_max);
        let (ta, tb) = clip_to_box(o, d, lo, hi, t_min, t_max)?;
        let len = d.length();
        // A non-finite ray (from a pathological lens model) would march forever.
        if !(len > 0.0 && len.is_finite() && o.is_finite() && tb.is_finite()) {
            return None;
        }
        let ray = MarchRay {
            o,
            d,
            dxy_len: d.truncate().length(),
            min_step: HEIGHT_FIELD_MIN_STEP_MM / len,
            tolerance: HEIGHT_FIELD_TOLERANCE_MM / len,
        };
        let size = self.spacing * BLOCK_CELLS as f64;
        let start = o.truncate() + d.truncate() * ta;
        let cell = |p: f64, origin: f64, n: usize| (((p - origin) / size).max(0.0) as i64 as usize).min(n - 1);
        let (mut bi, mut bj) = (cell(start.x, self.x0, self.bx), cell(start.y, self.y0, self.by));
        // Ray parameter of the next block boundary along x and y, and between boundaries.
        let next = |b: usize, origin: f64, o: f64, d: f64| -> (f64, f64) {
            let b = b as i64;
            if d > 0.0 {
                ((origin + (b + 1) as f64 * size - o) / d, size / d)
            } else if d < 0.0 {
                ((origin + b as f64 * size - o) / d, -size / d)
            } else {
                (f64::INFINITY, f64::INFINITY)
            }
        };
        let (mut next_x, delta_x) = next(bi, self.x0, o.x, d.x);
        let (mut next_y, delta_y) = next(bj, self.y0, o.y, d.y);
        let mut t = ta;
        loop {
            let t_exit = next_x.min(next_y).min(tb).max(t);
            if let Some(root) = self.march_block(&self.blocks[bj * self.bx + bi], &ray, t, t_exit) {
                return Some(root);
            }
            if t_exit >= tb {
                return None;
            }
            if next_x < next_y {
                bi = match (d.x > 0.0, bi) {
                    (true, b) if b + 1 < self.bx => b + 1,
                    (false, b) if b > 0 => b - 1,
                    _ => return None,
                };
                next_x += delta_x;
            } else {
                bj = match (d.y > 0.0, bj) {
                    (true, b) if b + 1 < self.by => b + 1,
                    (false, b) if b > 0 => b - 1,
                    _ => return None,
                };
                next_y += delta_y;
            }
            t = t_exit;
        }
    }

    /// The first root of F(t) = z(t) - z0 - h(x(t), y(t)) in `[t0, t1]`, where the ray
    /// is over `block`: only the part within the block's height range is marched,
    /// with steps `|F| / K` that cannot cross a root (K bounds |dF/dt| there), never
    /// shorter than the minimum step, and a sign change is refined.
    fn march_block(&self, block: &Block, ray: &MarchRay, t0: f64, t1: f64) -> Option<f64> {
        let (o, d) = (ray.o, ray.d);
        let (zl, zh) = (self.z0 + block.h_min, self.z0 + block.h_max);
        let (s0, s1) = if d.z != 0.0 {
            let (a, b) = ((zl - o.z) / d.z, (zh - o.z) / d.z);
            (t0.max(a.min(b)), t1.min(a.max(b)))
        } else if o.z >= zl && o.z <= zh {
            (t0, t1)
        } else {
            return None;
        };
        if s0 > s1 {
            return None;
        }
        let lipschitz = d.z.abs() + block.slope * ray.dxy_len;
        let f = |t: f64| {
            let p = o + d * t;
            p.z - self.z0 - self.height_only(p.x, p.y)
        };
        let f_and_slope = |t: f64| {
            let p = o + d * t;
            let (h, grad) = self.height(p.x, p.y);
            (p.z - self.z0 - h, d.z - grad.dot(d.truncate()))
        };
        let mut t = s0;
        let mut ft = f(t);
        if ft == 0.0 {
            return Some(t);
        }
        while t < s1 {
            let step = (ft.abs() / lipschitz).max(ray.min_step);
            let tn = (t + step).min(s1);
            let fnext = f(tn);
            if fnext == 0.0 {
                return Some(tn);
            }
            if (fnext > 0.0) != (ft > 0.0) {
                return Some(refine(&f_and_slope, t, ft, tn, fnext, ray.tolerance));
            }
            t = tn;
            ft = fnext;
        }
        None
    }
}

/// A ray being marched through a height field.
struct MarchRay {
    o: DVec3,
    d: DVec3,
    /// |d.xy|.
    dxy_len: f64,
    /// Minimum and final step, in units of t.
    min_step: f64,
    tolerance: f64,
}

/// A root of `f` in `[lo, hi]` where `f(lo) = f_lo` and `f(hi) = f_hi` have opposite
/// signs: starting from the secant point, Newton steps kept inside the bracket
/// (bisection when a step would leave it).
fn refine(f: &impl Fn(f64) -> (f64, f64), mut lo: f64, mut f_lo: f64, mut hi: f64, f_hi: f64, tolerance: f64) -> f64 {
    let mut t = lo - f_lo * (hi - lo) / (f_hi - f_lo);
    if !(t > lo && t < hi) {
        t = 0.5 * (lo + hi);
    }
    for _ in 0..HEIGHT_FIELD_REFINE_ITERATIONS {
        let (ft, slope) = f(t);
        if ft == 0.0 {
            return t;
        }
        if (ft > 0.0) == (f_lo > 0.0) {
            lo = t;
            f_lo = ft;
        } else {
            hi = t;
        }
        let newton = t - ft / slope;
        if hi - lo < tolerance {
            return 0.5 * (lo + hi);
        }
        if newton > lo && newton < hi {
            if (newton - t).abs() < tolerance {
                return newton;
            }
            t = newton;
        } else {
            t = 0.5 * (lo + hi);
        }
    }
    t
}

/// The part `[ta, tb]` of `[t_min, t_max]` where `o + t·d` is inside the box `lo..hi`.
#[inline]
fn clip_to_box(o: DVec3, d: DVec3, lo: DVec3, hi: DVec3, t_min: f64, t_max: f64) -> Option<(f64, f64)> {
    let (ta, tb) = clip_axis(o.x, d.x, lo.x, hi.x, t_min, t_max)?;
    let (ta, tb) = clip_axis(o.y, d.y, lo.y, hi.y, ta, tb)?;
    let (ta, tb) = clip_axis(o.z, d.z, lo.z, hi.z, ta, tb)?;
    (ta <= tb).then_some((ta, tb))
}

/// `[ta, tb]` narrowed to where `o + t·d` lies in `lo..=hi` (one axis).
#[inline]
fn clip_axis(o: f64, d: f64, lo: f64, hi: f64, ta: f64, tb: f64) -> Option<(f64, f64)> {
    if d == 0.0 {
        return (o >= lo && o <= hi).then_some((ta, tb));
    }
    let inv = 1.0 / d;
    let (a, b) = ((lo - o) * inv, (hi - o) * inv);
    let (a, b) = if a <= b { (a, b) } else { (b, a) };
    let (ta, tb) = (ta.max(a), tb.min(b));
    (ta <= tb).then_some((ta, tb))
}

/// The smallest of the candidates that lies in `(t_min, t_max)`.
#[inline]
fn nearest(candidates: &[f64], t_min: f64, t_max: f64) -> Option<f64> {
    candidates.iter().copied().filter(|&t| t > t_min && t < t_max).fold(None, |best: Option<f64>, t| {
        Some(best.map_or(t, |b| b.min(t)))
    })
}

/// Unit vector perpendicular to `axis` closest to `preferred` (or to x when parallel).
fn perpendicular(axis: DVec3, preferred: DVec3) -> DVec3 {
    let p = preferred - axis * axis.dot(preferred);
    if p.length_squared() > 1e-12 {
        p.normalize()
    } else {
        let q = DVec3::X - axis * axis.x;
        q.try_normalize().unwrap_or(DVec3::Y)
    }
}

impl Shape {
    /// Nearest ray parameter `t` in the open interval `(t_min, t_max)` where `o + t·d`
    /// meets the surface.
    pub fn intersect(&self, o: DVec3, d: DVec3, t_min: f64, t_max: f64) -> Option<f64> {
        match self {
            Shape::Plane { point, normal } => {
                let denom = normal.dot(d);
                if denom * denom <= 1e-24 * normal.length_squared() * d.length_squared() {
                    return None;
                }
                let t = normal.dot(*point - o) / denom;
                (t > t_min && t < t_max).then_some(t)
            }
            Shape::Sphere { center, radius } => {
                let oc = o - *center;
                let a = d.dot(d);
                let b = oc.dot(d);
                let c = oc.dot(oc) - radius * radius;
                let disc = b * b - a * c;
                if !(disc >= 0.0) || a == 0.0 {
                    return None;
                }
                let sq = disc.sqrt();
                // The numerically stable pair of roots.
                let q = -(b + sq.copysign(b));
                if q == 0.0 {
                    return None;
                }
                nearest(&[q / a, c / q], t_min, t_max)
            }
            Shape::Cuboid { center, axes, half } => {
                let ol = axes.transpose() * (o - *center);
                let dl = axes.transpose() * d;
                let (ta, tb) = clip_to_box(ol, dl, -*half, *half, f64::NEG_INFINITY, f64::INFINITY)?;
                nearest(&[ta, tb], t_min, t_max)
            }
            Shape::Cylinder {
                center,
                axis,
                radius,
                half_length,
            } => {
                let oc = o - *center;
                let (oa, da) = (oc.dot(*axis), d.dot(*axis));
                let (op, dp) = (oc - *axis * oa, d - *axis * da);
                let mut cand = [f64::NAN; 4];
                let a = dp.dot(dp);
                if a > 0.0 {
                    let b = op.dot(dp);
                    let c = op.dot(op) - radius * radius;
                    let disc = b * b - a * c;
                    if disc >= 0.0 {
                        let sq = disc.sqrt();
                        let q = -(b + sq.copysign(b));
                        if q != 0.0 {
                            for (slot, t) in cand.iter_mut().take(2).zip([q / a, c / q]) {
                                if (oa + t * da).abs() <= *half_length {
                                    *slot = t;
                                }
                            }
                        }
                    }
                }
                if da != 0.0 {
                    for (slot, end) in cand.iter_mut().skip(2).zip([-*half_length, *half_length]) {
                        let t = (end - oa) / da;
                        if (op + dp * t).length_squared() <= radius * radius {
                            *slot = t;
                        }
                    }
                }
                nearest(&cand, t_min, t_max)
            }
            Shape::HeightField(field) => field.intersect(o, d, t_min, t_max),
            Shape::BentSheet { center, axes, curvature, half_size } => {
                let ol = axes.transpose() * (o - *center);
                let dl = axes.transpose() * d;
                let k = *curvature;
                let on_sheet = |t: f64| {
                    let st = bent_coords(k, ol + dl * t);
                    st.x.abs() <= half_size.x && st.y.abs() <= half_size.y
                };
                let mut cand = [f64::NAN; 2];
                if k == 0.0 {
                    if dl.z != 0.0 {
                        cand[0] = -ol.z / dl.z;
                    }
                } else {
                    // The cylinder x² + (z − 1/κ)² = 1/κ², times κ: κ(x² + z²) − 2z = 0.
                    let a = k * (dl.x * dl.x + dl.z * dl.z);
                    let b = k * (ol.x * dl.x + ol.z * dl.z) - dl.z;
                    let c = k * (ol.x * ol.x + ol.z * ol.z) - 2.0 * ol.z;
                    let disc = b * b - a * c;
                    if disc >= 0.0 && a != 0.0 {
                        let q = -(b + disc.sqrt().copysign(b));
                        if q != 0.0 {
                            cand = [q / a, c / q];
                        }
                    } else if a == 0.0 && b != 0.0 {
                        cand[0] = -c / (2.0 * b);
                    }
                }
                for slot in cand.iter_mut() {
                    if !slot.is_nan() && !on_sheet(*slot) {
                        *slot = f64::NAN;
                    }
                }
                nearest(&cand, t_min, t_max)
            }
        }
    }

    /// Unit normal (outward for solids, −z-facing for sheets; the caller turns it
    /// towards the viewer) and surface coordinates (mm) at a point on the surface.
    pub fn surface(&self, p: DVec3) -> (DVec3, DVec2) {
        match self {
            Shape::Plane { point, normal } => {
                let n = normal.normalize_or(DVec3::NEG_Z);
                let s_axis = perpendicular(n, DVec3::X);
                let t_axis = {
                    let y = DVec3::Y - n * n.y - s_axis * s_axis.y;
                    y.try_normalize().unwrap_or_else(|| n.cross(s_axis))
                };
                let q = p - *point;
                (n, DVec2::new(q.dot(s_axis), q.dot(t_axis)))
            }
            Shape::Sphere { center, radius } => {
                let q = p - *center;
                let n = q.normalize_or(DVec3::NEG_Z);
                let lon = n.x.atan2(-n.z);
                let lat = n.y.clamp(-1.0, 1.0).asin();
                (n, DVec2::new(radius * lon, radius * lat))
            }
            Shape::Cuboid { center, axes, half } => {
                let q = axes.transpose() * (p - *center);
                let r = q / *half;
                let k = if r.x.abs() >= r.y.abs() && r.x.abs() >= r.z.abs() {
                    0
                } else if r.y.abs() >= r.z.abs() {
                    1
                } else {
                    2
                };
                let n = axes.col(k) * q[k].signum();
                let coords = match k {
                    0 => DVec2::new(q.y, q.z),
                    1 => DVec2::new(q.x, q.z),
                    _ => DVec2::new(q.x, q.y),
                };
                (n, coords)
            }
            Shape::Cylinder {
                center,
                axis,
                radius,
                half_length,
            } => {
                let q = p - *center;
                let along = q.dot(*axis);
                let radial = q - *axis * along;
                let front = perpendicular(*axis, DVec3::NEG_Z);
                let side = axis.cross(front);
                let (x, y) = (radial.dot(front), radial.dot(side));
                let to_side = (radial.length() - radius).abs();
                let to_cap = (along.abs() - half_length).abs();
                if to_cap < to_side {
                    (*axis * along.signum(), DVec2::new(x, y))
                } else {
                    let n = radial.normalize_or(front);
                    (n, DVec2::new(radius * y.atan2(x), along))
                }
            }
            Shape::HeightField(field) => (field.shading_normal(p.x, p.y), DVec2::new(p.x, p.y)),
            Shape::BentSheet { center, axes, curvature, .. } => {
                let st = bent_coords(*curvature, axes.transpose() * (p - *center));
                let (sin, cos) = (curvature * st.x).sin_cos();
                (*axes * DVec3::new(sin, 0.0, -cos), st)
            }
        }
    }

    /// The camera-frame point of a bent sheet at surface coordinates `st`; `None` for
    /// other shapes or outside the sheet.
    pub fn sheet_point(&self, st: DVec2) -> Option<DVec3> {
        match self {
            Shape::BentSheet { center, axes, curvature, half_size } => {
                (st.x.abs() <= half_size.x && st.y.abs() <= half_size.y)
                    .then(|| *center + *axes * bent_point(*curvature, st.x, st.y))
            }
            _ => None,
        }
    }

    /// Refuse shapes with non-finite or degenerate parameters.
    pub fn validate(&self) -> Result<()> {
        let bad = |what: &str| Err(Error::Scene(format!("scene: {what}")));
        let finite = |v: DVec3| v.is_finite();
        match self {
            Shape::Plane { point, normal } => {
                if !finite(*point) || !finite(*normal) || normal.length() < 1e-12 {
                    return bad("a plane needs a finite point and a non-zero normal");
                }
            }
            Shape::Sphere { center, radius } => {
                if !(finite(*center) && radius.is_finite() && *radius > 0.0) {
                    return bad("a sphere needs a finite centre and a positive radius");
                }
            }
            Shape::Cuboid { center, axes, half } => {
                let dev = (*axes * axes.transpose() - DMat3::IDENTITY)
                    .to_cols_array()
                    .iter()
                    .fold(0f64, |m, x| m.max(x.abs()));
                if !(finite(*center) && dev < 1e-6 && half.is_finite() && half.min_element() > 0.0) {
                    return bad("a box needs a finite centre, orthonormal axes and positive half-extents");
                }
            }
            Shape::Cylinder {
                center,
                axis,
                radius,
                half_length,
            } => {
                let ok = finite(*center)
                    && finite(*axis)
                    && (axis.length() - 1.0).abs() < 1e-6
                    && radius.is_finite()
                    && *radius > 0.0
                    && half_length.is_finite()
                    && *half_length > 0.0;
                if !ok {
                    return bad("a cylinder needs a finite centre, a unit axis, and positive radius and length");
                }
            }
            Shape::HeightField(_) => {}
            Shape::BentSheet { center, axes, curvature, half_size } => {
                let dev = (*axes * axes.transpose() - DMat3::IDENTITY)
                    .to_cols_array()
                    .iter()
                    .fold(0f64, |m, x| m.max(x.abs()));
                let ok = finite(*center)
                    && dev < 1e-6
                    && curvature.is_finite()
                    && half_size.is_finite()
                    && half_size.min_element() > 0.0
                    // Less than half a turn each way, so that (s, t) is unique.
                    && curvature.abs() * half_size.x < std::f64::consts::PI;
                if !ok {
                    return bad(
                        "a bent sheet needs a finite centre, orthonormal axes, a positive size and under half a turn each way",
                    );
                }
            }
        }
        Ok(())
    }
}


