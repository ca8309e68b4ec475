//! Depth from stripe coordinates with the calibrated projector-camera pair.
//!
//! A stripe family's coordinate `q = a·u_p + b·v_p + c` (projector pixels, see
//! [`crate::pattern::Family::stripe_coord`]) is constant on a plane of light through
//! the projector's centre (for an undistorted projector). With the camera ray
//! `X_c = z·r` (r = undistorted normalized pixel, `r.z = 1`) and `X_p = R·X_c + t`
//! (`proj_from_cam`), the plane `n(q)·X_p = 0`, `n(q) = (a·fx, b·fy, a·cx + b·cy + c - q)`
//! in normalized projector coordinates, gives
//!
//! `z(q) = (q·t_z - n0·t) / (n0·(R r) - q·(R r)_z)`, `n0 = n(0)`.
//!
//! With `k = Rᵀ·n0`, `n0·(R r) = k·r` and `(R r)_z = R_z·r` (R's last row), so a
//! depth costs a few multiplications and one division per pixel. A distorted
//! projector bends the light planes; there each depth is refined by Newton steps on
//! the true projection ([`Calibration::depth_on_stripe`]).
//!
//! Depth `z` is Z in the camera frame, mm. `dz/dq` (mm per stripe) is returned with it:
//! its inverse square weighs families when they are merged.

use crate::calib::Calibration;
use crate::pattern::PatternSpec;
use glam::DVec3;

/// Depths outside this range (mm) are rejected as impossible for the rig: nearer than
/// a tenth of a metre or further than ten metres.
pub const DEPTH_RANGE_MM: (f64, f64) = (100.0, 10_000.0);

/// One family's light planes in the camera frame.
#[derive(Clone, Copy)]
struct FamilyPlanes {
    abc: (f64, f64, f64),
    /// `Rᵀ·n0`: `n0·(R r) = k·r`.
    k: DVec3,
    /// `n0·t`.
    n0_t: f64,
}

/// Per-pixel rays and per-family planes for one (calibration, pattern) pair.
pub struct Triangulator {
    width: usize,
    /// Undistorted camera rays `r` (z = 1), per pixel, for a distorted camera (whose
    /// undistortion is iterative); empty for an undistorted one, whose rays cost two
    /// multiplications (8 bytes a pixel saved, 64 MB at 8 megapixels).
    rays: Vec<[f32; 2]>,
    /// `R_z`, the last row of `R` (camera to projector).
    rotation_z: DVec3,
    t: DVec3,
    /// Per family: (a, b, c), `k = Rᵀ·n0` and `n0·t`.
    families: Vec<FamilyPlanes>,
    projector_distorted: bool,
    calib: Calibration,
}

impl Triangulator {
    /// Make the per-pixel tables for the calibration's camera size.
    pub fn new(calib: &Calibration, spec: &PatternSpec) -> Self {
        let (w, h) = (calib.camera.width as usize, calib.camera.height as usize);
        let r = calib.proj_from_cam_rotation();
        let mut rays = Vec::new();
        if calib.camera.dist != [0.0; 5] {
            rays.reserve_exact(w * h);
            for v in 0..h {
                for u in 0..w {
                    let ray = calib.camera.ray(u as f64, v as f64);
                    rays.push([ray.x as f32, ray.y as f32]);
                }
            }
        }
        let p = &calib.projector;
        let families = (0..spec.families.len())
            .map(|k| {
                let (a, b, c) = spec.families[k].stripe_coord(spec.width, spec.height);
                let n0 = DVec3::new(a * p.fx, b * p.fy, a * p.cx + b * p.cy + c);
                FamilyPlanes { abc: (a, b, c), k: r.transpose() * n0, n0_t: n0.dot(calib.proj_from_cam_translation()) }
            })
            .collect();
        Triangulator {
            width: w,
            rays,
            rotation_z: r.row(2),
            t: calib.proj_from_cam_translation(),
            families,
            projector_distorted: p.dist != [0.0; 5],
            calib: calib.clone(),
        }
    }

    /// Depth (mm) and `dz/dq` (mm per stripe) of pixel index `i` on stripe coordinate
    /// `q` of `family`; `None` when the ray misses the plane or the depth is outside
    /// [`DEPTH_RANGE_MM`].
    pub fn depth(&self, family: usize, i: usize, q: f64) -> Option<(f64, f64)> {
        self.depth_at(family, i, (i % self.width, i / self.width), q)
    }

    /// [`Triangulator::depth`] of pixel index `i` at column and row `(u, v)`.
    #[inline]
    fn depth_at(&self, family: usize, i: usize, (u, v): (usize, usize), q: f64) -> Option<(f64, f64)> {
        let FamilyPlanes { abc, k, n0_t } = self.families[family];
        let [x, y] = self.ray_at(i, (u, v));
        let (x, y) = (x as f64, y as f64);
        let rz = self.rotation_z.x * x + self.rotation_z.y * y + self.rotation_z.z;
        let num = q * self.t.z - n0_t;
        let den = (k.x * x + k.y * y + k.z) - q * rz;
        if den.abs() < 1e-12 {
            return None;
        }
        let mut z = num / den;
        // dz/dq of the quotient.
        let dzdq = (self.t.z * den + rz * num) / (den * den);
        if self.projector_distorted {
            z = self.calib.depth_on_stripe(u as f64, v as f64, abc.0, abc.1, abc.2, q)?;
        }
        (z.is_finite() && z > DEPTH_RANGE_MM.0 && z < DEPTH_RANGE_MM.1).then_some((z, dzdq))
    }

    /// The camera-frame point at depth `z` on pixel index `i`'s ray, mm.
    pub fn point(&self, i: usize, z: f32) -> [f32; 3] {
        self.point_at(i, (i % self.width, i / self.width), z)
    }

    /// [`Triangulator::point`] of pixel index `i` at column and row `(u, v)`.
    #[inline]
    pub fn point_at(&self, i: usize, (u, v): (usize, usize), z: f32) -> [f32; 3] {
        let [x, y] = self.ray_at(i, (u, v));
        [x * z, y * z, z]
    }

    /// The undistorted ray (x, y; z = 1) of pixel index `i` at `(u, v)`.
    #[inline]
    fn ray_at(&self, i: usize, (u, v): (usize, usize)) -> [f32; 2] {
        if let Some(r) = self.rays.get(i) {
            return *r;
        }
        let c = &self.calib.camera;
        [((u as f64 - c.cx) / c.fx) as f32, ((v as f64 - c.cy) / c.fy) as f32]
    }

    /// Depth of every pixel with a stripe coordinate (NaN elsewhere) into `depth`, and
    /// its merge weight `1 / (dz/dq)²` into `weight` unless that is empty (a single
    /// family is not merged).
    ///
    /// Tried on 2026-12-07 and not kept: weighing each family also by how far inside its
    /// stripe the pixel lies (a variance `0.05² + (c·f)²` in stripes, `f` the distance
    /// to the nearer boundary), since an interpolated coordinate is further off in a
    /// stripe's middle (crumpled paper under 25-pixel stripes: mean error 0.13 of the
    /// outlier threshold beside a boundary, 0.36 in the middle). On the pixels where both
    /// families agree the weighted mean had a smaller RMS error (paper/wide 0.312 ->
    /// 0.297 of the threshold) but more pixels past the threshold (1.22 % -> 1.38 %):
    /// the plain mean halves each family's tail. With the merge's agreement test on
    /// that weighted mean, 24 rows (`wide`, `default`, `webcam`, `soft` of paper,
    /// paper-dye, skin, wood, sphere, textured) lost 1.5 points of coverage.
    pub fn family_depth_into(&self, family: usize, q: &[f32], depth: &mut [f32], weight: &mut [f32]) {
        self.family_depth_rows_into(family, 0, q, depth, weight);
    }

    /// [`Triangulator::family_depth_into`] for a band of whole rows starting at row
    /// `first_row`: `q`, `depth` and `weight` (empty: no weights) hold the band's
    /// pixels only, so that bands can be triangulated at once.
    pub fn family_depth_rows_into(&self, family: usize, first_row: usize, q: &[f32], depth: &mut [f32], weight: &mut [f32]) {
        let weigh = !weight.is_empty();
        depth.fill(f32::NAN);
        weight.fill(0.0);
        // Row by row, so that a pixel's column and row come without a division.
        for (dv, row) in q.chunks(self.width).enumerate() {
            let (v, band_first) = (first_row + dv, dv * self.width);
            for (u, &qi) in row.iter().enumerate() {
                if qi.is_nan() {
                    continue;
                }
                let i = band_first + u;
                if let Some((z, dzdq)) = self.depth_at(family, v * self.width + u, (u, v), qi as f64) {
                    depth[i] = z as f32;
                    if weigh {
                        weight[i] = (1.0 / crate::num::max_f64(dzdq * dzdq, 1e-9)) as f32;
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Triangulated in bands of rows, a family's depth and weights are the whole
    /// frame's bit for bit.
    #[test]
    fn bands_of_rows_triangulate_as_the_whole_frame() {
        let calib = Calibration::demo();
        let spec = PatternSpec::generate(2, calib.projector.width, calib.projector.height, 10.0).unwrap();
        let t = Triangulator::new(&calib, &spec);
        let (w, h) = (calib.camera.width as usize, calib.camera.height as usize);
        // A stripe coordinate that grows across the frame, with holes.
        let q: Vec<f32> = (0..w * h).map(|i| if i % 7 == 3 { f32::NAN } else { 20.0 + (i % w) as f32 / 6.6 + (i / w) as f32 * 0.01 }).collect();
        let (mut whole, mut whole_w) = (vec![0.0; w * h], vec![0.0; w * h]);
        t.family_depth_into(0, &q, &mut whole, &mut whole_w);
        assert!(whole.iter().filter(|z| z.is_finite()).count() > w * h / 2);
        let rows = 37;
        let (mut banded, mut banded_w) = (vec![0.0; w * h], vec![0.0; w * h]);
        for (b, (qb, (d, wt))) in q.chunks(w * rows).zip(banded.chunks_mut(w * rows).zip(banded_w.chunks_mut(w * rows))).enumerate() {
            t.family_depth_rows_into(0, b * rows, qb, d, wt);
        }
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&banded), bits(&whole));
        assert_eq!(bits(&banded_w), bits(&whole_w));
    }
}
