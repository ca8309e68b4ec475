//! Merging the range images of the stripe families (paper section 5: "merged into one
//! by removing erroneous points and by averaging multiple reliable points").
//!
//! Where several families measured a pixel, their depths must agree within
//! [`agree_tolerance`]; then the merged depth is their average weighted by
//! `1 / (dz/dq)²` (the least-squares point on the camera ray for the families' light
//! planes, so the family that triangulates with more of the baseline counts more).
//! Where they disagree, at least one identity is wrong and the pixel is dropped. A
//! pixel measured by one family only is kept as it is. Finally points without enough
//! support from their neighbours are removed (an isolated depth is almost always a
//! wrong identity).

/// Two depths (mm) of one pixel agree within max(2 mm, 0.4 % of the depth): about a
/// sixth of a stripe on the demo rig, far above the measurement noise and far below
/// the error of a wrong stripe identity (a whole stripe).
pub fn agree_tolerance(z: f32) -> f32 {
    (0.004 * z).max(2.0)
}

/// Neighbouring pixels (mm) belong to one surface within max(4 mm, 1 % of the depth),
/// which allows surfaces slanted up to about 75 degrees at the demo rig's resolution.
pub fn neighbour_tolerance(z: f32) -> f32 {
    (0.01 * z).max(4.0)
}

/// Of the 8 neighbours, at least this many must be on the same surface.
pub const MIN_SUPPORT: usize = 3;

/// Merge per-family depth maps (NaN = none) with their weights into `out`, and the
/// bit mask of contributing families into `families`.
pub fn merge_into<D: AsRef<[f32]>>(depths: &[D], weights: &[Vec<f32>], out: &mut [f32], families: &mut [u8]) {
    for i in 0..out.len() {
        let (mut sum, mut wsum, mut mask) = (0.0f64, 0.0f64, 0u8);
        for (k, (d, w)) in depths.iter().zip(weights).enumerate() {
            let z = d.as_ref()[i];
            if z.is_nan() {
                continue;
            }
            sum += z as f64 * w[i] as f64;
            wsum += w[i] as f64;
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

/// Remove depths with fewer than [`MIN_SUPPORT`] of their 8 neighbours on the same
/// surface. `scratch` is resized to the image and overwritten.
pub fn remove_isolated(depth: &mut [f32], width: usize, height: usize, scratch: &mut Vec<f32>) -> usize {
    scratch.clear();
    scratch.extend_from_slice(depth);
    let mut removed = 0;
    for y in 0..height {
        for x in 0..width {
            let z = scratch[y * width + x];
            if z.is_nan() {
                continue;
            }
            let tol = neighbour_tolerance(z);
            let mut support = 0;
            for dy in -1i32..=1 {
                for dx in -1i32..=1 {
                    let (xx, yy) = (x as i32 + dx, y as i32 + dy);
                    if (dx, dy) == (0, 0) || xx < 0 || yy < 0 || xx >= width as i32 || yy >= height as i32 {
                        continue;
                    }
                    let n = scratch[yy as usize * width + xx as usize];
                    if !n.is_nan() && (n - z).abs() <= tol {
                        support += 1;
                    }
                }
            }
            if support < MIN_SUPPORT {
                depth[y * width + x] = f32::NAN;
                removed += 1;
            }
        }
    }
    removed
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
