//! Score a scan of a known shape: how much of the object decoded, and how well the points
//! fit a sphere (or a plane) by least squares.
//!
//! ```text
//! cargo run --release --example fit_sphere -- CLOUD.ply [--mask MASK.png]
//!     [--image FRAME.png (--circle CX,CY,R | --polygon X,Y,X,Y,...) --threshold T [--spread N]
//!      [--write-mask OUT.png]]
//!     [--shape sphere|plane] [--tolerance MM] [--trim MM] [--expect-radius MM]
//! ```
//!
//! - `CLOUD.ply` is what `stripelight scan --ply` writes (`conventions.md`: x y z in mm in
//!   the camera frame, the camera pixel u v each point came from); binary little-endian
//!   or ASCII.
//! - The object's pixels come from `--mask` (a PNG of the camera's size, non-zero = object),
//!   or are made from the camera frame: the pixels inside the circle `CX,CY,R` (or the
//!   polygon of corners `X,Y,...`, camera pixels) whose
//!   brightest channel, maximised over `N` pixels to the left and right (default 12, so
//!   the dark gaps between stripes count as lit), exceeds `T` (0..255). `--write-mask`
//!   saves that mask for inspection.
//! - Coverage = object pixels with a point / object pixels. Only points on object pixels
//!   are fitted (all points when no mask is given).
//! - The fit is geometric least squares over all those points (RMS distance to the
//!   surface, share of points more than `--tolerance` mm off, default 2), then again
//!   over the points within `--trim` mm of the previous fit (default 10, repeated until
//!   the number kept settles), which shows the shape without wrongly identified stripes.
//! - `--correspondence CORR.pfm --stripe-width W` (what `stripelight scan --correspondence`
//!   writes, and the spec's stripe width in projector pixels), for a flat target: on a
//!   plane the projector coordinate of the first family is a smooth function of the camera
//!   pixel, so a cubic in the pixel's x and y is fitted to it over the object's pixels
//!   (again trimmed, down to half a stripe), and the shares of those pixels within a
//!   quarter and half a stripe of it, and more than one stripe off (a wrong identity), are
//!   printed. Unlike the plane fit of the points, this does not depend on how well the
//!   rig is calibrated.

// Small fixed-size matrices read best with index loops.
#![allow(clippy::needless_range_loop)]

use std::collections::HashSet;
use std::process::ExitCode;

fn main() -> ExitCode {
    match run() {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("fit_sphere: {e}");
            ExitCode::FAILURE
        }
    }
}

#[derive(Clone, Copy, PartialEq)]
enum Shape {
    Sphere,
    Plane,
}

struct Options {
    ply: String,
    mask: Option<String>,
    image: Option<String>,
    region: Option<Region>,
    threshold: Option<f64>,
    spread: usize,
    write_mask: Option<String>,
    shape: Shape,
    tolerance: f64,
    trim: f64,
    expect_radius: Option<f64>,
    correspondence: Option<String>,
    stripe_width: Option<f64>,
}

/// The part of the frame the object can be in.
#[derive(Clone)]
enum Region {
    Circle([f64; 3]),
    Polygon(Vec<[f64; 2]>),
}

impl Region {
    fn contains(&self, x: f64, y: f64) -> bool {
        match self {
            Region::Circle([cx, cy, r]) => (x - cx).hypot(y - cy) <= *r,
            Region::Polygon(p) => {
                // Even-odd rule.
                let mut inside = false;
                for i in 0..p.len() {
                    let (a, b) = (p[i], p[(i + 1) % p.len()]);
                    if (a[1] > y) != (b[1] > y) && x < a[0] + (y - a[1]) / (b[1] - a[1]) * (b[0] - a[0]) {
                        inside = !inside;
                    }
                }
                inside
            }
        }
    }
}

const USAGE: &str = "usage: fit_sphere CLOUD.ply [--mask MASK.png] [--image FRAME.png (--circle CX,CY,R | --polygon X,Y,X,Y,...) --threshold T [--spread N] [--write-mask OUT.png]] [--shape sphere|plane] [--tolerance MM] [--trim MM] [--expect-radius MM] [--correspondence CORR.pfm --stripe-width W]";

fn parse_args() -> Result<Options, String> {
    let mut args = std::env::args().skip(1);
    let mut o = Options {
        ply: String::new(),
        mask: None,
        image: None,
        region: None,
        threshold: None,
        spread: 12,
        write_mask: None,
        shape: Shape::Sphere,
        tolerance: 2.0,
        trim: 10.0,
        expect_radius: None,
        correspondence: None,
        stripe_width: None,
    };
    let number = |name: &str, v: Option<String>| -> Result<f64, String> {
        let v = v.ok_or_else(|| format!("{name} needs a value"))?;
        let x: f64 = v.trim().parse().map_err(|_| format!("{name}: {v:?} is not a number"))?;
        if x.is_finite() { Ok(x) } else { Err(format!("{name}: {v:?} is not finite")) }
    };
    while let Some(a) = args.next() {
        match a.as_str() {
            "--mask" => o.mask = Some(args.next().ok_or("--mask needs a path")?),
            "--image" => o.image = Some(args.next().ok_or("--image needs a path")?),
            "--write-mask" => o.write_mask = Some(args.next().ok_or("--write-mask needs a path")?),
            "--circle" => {
                let v = args.next().ok_or("--circle needs CX,CY,R")?;
                let p: Vec<f64> = v.split(',').map(|t| t.trim().parse::<f64>()).collect::<Result<_, _>>().map_err(|_| format!("--circle: {v:?} is not CX,CY,R"))?;
                match p[..] {
                    [cx, cy, r] if p.iter().all(|x| x.is_finite()) && r > 0.0 => o.region = Some(Region::Circle([cx, cy, r])),
                    _ => return Err(format!("--circle: {v:?} is not CX,CY,R with R > 0")),
                }
            }
            "--polygon" => {
                let v = args.next().ok_or("--polygon needs X,Y,X,Y,...")?;
                let p: Vec<f64> = v.split(',').map(|t| t.trim().parse::<f64>()).collect::<Result<_, _>>().map_err(|_| format!("--polygon: {v:?} is not X,Y,X,Y,..."))?;
                if p.len() < 6 || !p.len().is_multiple_of(2) || p.iter().any(|x| !x.is_finite()) {
                    return Err(format!("--polygon: {v:?} needs at least 3 corners X,Y"));
                }
                o.region = Some(Region::Polygon(p.chunks(2).map(|c| [c[0], c[1]]).collect()));
            }
            "--threshold" => o.threshold = Some(number("--threshold", args.next())?),
            "--spread" => o.spread = number("--spread", args.next())?.max(0.0) as usize,
            "--tolerance" => o.tolerance = number("--tolerance", args.next())?,
            "--trim" => o.trim = number("--trim", args.next())?,
            "--expect-radius" => o.expect_radius = Some(number("--expect-radius", args.next())?),
            "--correspondence" => o.correspondence = Some(args.next().ok_or("--correspondence needs a path")?),
            "--stripe-width" => o.stripe_width = Some(number("--stripe-width", args.next())?),
            "--shape" => {
                o.shape = match args.next().as_deref() {
                    Some("sphere") => Shape::Sphere,
                    Some("plane") => Shape::Plane,
                    other => return Err(format!("--shape must be sphere or plane, got {other:?}")),
                }
            }
            "-h" | "--help" => return Err(USAGE.into()),
            s if s.starts_with("--") => return Err(format!("unknown option {s}\n{USAGE}")),
            s if o.ply.is_empty() => o.ply = s.to_string(),
            s => return Err(format!("unexpected argument {s:?}\n{USAGE}")),
        }
    }
    if o.ply.is_empty() {
        return Err(USAGE.into());
    }
    if o.mask.is_some() && o.image.is_some() {
        return Err("give either --mask or --image with --circle/--polygon and --threshold, not both".into());
    }
    if o.image.is_some() != (o.region.is_some() && o.threshold.is_some()) || (o.image.is_none() && (o.region.is_some() || o.threshold.is_some())) {
        return Err("--image, --circle (or --polygon) and --threshold go together".into());
    }
    if o.correspondence.is_some() != o.stripe_width.is_some() || o.stripe_width.is_some_and(|w| w <= 0.0) {
        return Err("--correspondence and a positive --stripe-width go together".into());
    }
    if o.tolerance <= 0.0 || o.trim <= 0.0 {
        return Err("--tolerance and --trim must be positive".into());
    }
    Ok(o)
}

/// The object's pixels, row-major, with the image size.
struct Mask {
    width: usize,
    height: usize,
    inside: Vec<bool>,
}

fn load_mask(path: &str) -> Result<Mask, String> {
    let img = image::open(path).map_err(|e| format!("mask {path}: {e}"))?.to_luma8();
    let (width, height) = (img.width() as usize, img.height() as usize);
    Ok(Mask { width, height, inside: img.pixels().map(|p| p.0[0] > 0).collect() })
}

fn mask_from_frame(path: &str, region: &Region, threshold: f64, spread: usize) -> Result<Mask, String> {
    let img = image::open(path).map_err(|e| format!("frame {path}: {e}"))?.to_rgb8();
    let (width, height) = (img.width() as usize, img.height() as usize);
    let bright: Vec<u8> = img.pixels().map(|p| p.0.iter().copied().max().unwrap_or(0)).collect();
    let mut inside = vec![false; width * height];
    for y in 0..height {
        let row = &bright[y * width..(y + 1) * width];
        for x in 0..width {
            if !region.contains(x as f64, y as f64) {
                continue;
            }
            let (a, b) = (x.saturating_sub(spread), (x + spread).min(width - 1));
            let peak = row[a..=b].iter().copied().max().unwrap_or(0);
            inside[y * width + x] = peak as f64 > threshold;
        }
    }
    Ok(Mask { width, height, inside })
}

fn save_mask(m: &Mask, path: &str) -> Result<(), String> {
    let pixels: Vec<u8> = m.inside.iter().map(|&b| if b { 255 } else { 0 }).collect();
    let img = image::GrayImage::from_raw(m.width as u32, m.height as u32, pixels).ok_or("mask buffer has the wrong size")?;
    img.save(path).map_err(|e| format!("writing {path}: {e}"))
}

/// Points (x, y, z in mm) and the camera pixel (u, v) each came from.
struct Points {
    xyz: Vec<[f64; 3]>,
    uv: Vec<[f64; 2]>,
}

fn read_ply(path: &str) -> Result<Points, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read {path}: {e}"))?;
    let end = find(&bytes, b"end_header").ok_or_else(|| format!("{path}: not a PLY file (no end_header)"))?;
    let mut body = end + b"end_header".len();
    // The header ends with "end_header" and one line break (\n or \r\n).
    if bytes.get(body) == Some(&b'\r') {
        body += 1;
    }
    if bytes.get(body) == Some(&b'\n') {
        body += 1;
    }
    let header = std::str::from_utf8(&bytes[..end]).map_err(|_| format!("{path}: the PLY header is not text"))?;
    let mut lines = header.lines().map(str::trim);
    if lines.next() != Some("ply") {
        return Err(format!("{path}: not a PLY file (no 'ply' first line)"));
    }
    let mut format = None;
    let mut count = None;
    let mut props: Vec<(String, String)> = Vec::new();
    let mut in_vertex = false;
    let mut seen_other_before = false;
    for line in lines {
        let w: Vec<&str> = line.split_whitespace().collect();
        match w.as_slice() {
            ["format", f, _] => format = Some(f.to_string()),
            ["element", "vertex", n] => {
                count = Some(n.parse::<usize>().map_err(|_| format!("{path}: bad vertex count {n:?}"))?);
                in_vertex = true;
            }
            ["element", ..] => {
                if count.is_none() {
                    seen_other_before = true;
                }
                in_vertex = false;
            }
            ["property", "list", ..] if in_vertex => return Err(format!("{path}: list properties on vertices are not supported")),
            ["property", t, name] if in_vertex => props.push((t.to_string(), name.to_string())),
            _ => {}
        }
    }
    let count = count.ok_or_else(|| format!("{path}: no 'element vertex' in the header"))?;
    if seen_other_before {
        return Err(format!("{path}: elements before 'vertex' are not supported"));
    }
    let index = |name: &str| props.iter().position(|(_, n)| n == name).ok_or_else(|| format!("{path}: the vertices have no property {name:?}"));
    let (ix, iy, iz, iu, iv) = (index("x")?, index("y")?, index("z")?, index("u")?, index("v")?);
    let size = |t: &str| -> Result<usize, String> {
        Ok(match t {
            "char" | "uchar" | "int8" | "uint8" => 1,
            "short" | "ushort" | "int16" | "uint16" => 2,
            "int" | "uint" | "float" | "int32" | "uint32" | "float32" => 4,
            "double" | "float64" => 8,
            _ => return Err(format!("{path}: unknown property type {t:?}")),
        })
    };
    let mut values = vec![vec![0f64; props.len()]; count];
    match format.as_deref() {
        Some("ascii") => {
            let text = std::str::from_utf8(&bytes[body..]).map_err(|_| format!("{path}: the ASCII body is not text"))?;
            let mut rows = text.lines().filter(|l| !l.trim().is_empty());
            for (i, vals) in values.iter_mut().enumerate() {
                let row = rows.next().ok_or_else(|| format!("{path}: {count} vertices announced, {i} found"))?;
                let fields: Vec<&str> = row.split_whitespace().collect();
                if fields.len() < props.len() {
                    return Err(format!("{path}: vertex {i} has {} values, expected {}", fields.len(), props.len()));
                }
                for (k, f) in fields.iter().take(props.len()).enumerate() {
                    vals[k] = f.parse().map_err(|_| format!("{path}: vertex {i}: {f:?} is not a number"))?;
                }
            }
        }
        Some("binary_little_endian") => {
            let sizes: Vec<usize> = props.iter().map(|(t, _)| size(t)).collect::<Result<_, _>>()?;
            let stride: usize = sizes.iter().sum();
            let need = count.checked_mul(stride).ok_or_else(|| format!("{path}: vertex count too large"))?;
            if bytes.len() - body < need {
                return Err(format!("{path}: truncated: {count} vertices of {stride} bytes need {need} bytes, {} present", bytes.len() - body));
            }
            for (i, vals) in values.iter_mut().enumerate() {
                let mut at = body + i * stride;
                for (k, (t, _)) in props.iter().enumerate() {
                    let b = &bytes[at..at + sizes[k]];
                    vals[k] = match t.as_str() {
                        "char" | "int8" => b[0] as i8 as f64,
                        "uchar" | "uint8" => b[0] as f64,
                        "short" | "int16" => i16::from_le_bytes([b[0], b[1]]) as f64,
                        "ushort" | "uint16" => u16::from_le_bytes([b[0], b[1]]) as f64,
                        "int" | "int32" => i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                        "uint" | "uint32" => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                        "float" | "float32" => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                        _ => f64::from_le_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]]),
                    };
                    at += sizes[k];
                }
            }
        }
        other => return Err(format!("{path}: PLY format {other:?} is not supported (ascii or binary_little_endian)")),
    }
    let mut p = Points { xyz: Vec::with_capacity(count), uv: Vec::with_capacity(count) };
    for v in values {
        let xyz = [v[ix], v[iy], v[iz]];
        if xyz.iter().all(|c| c.is_finite()) {
            p.xyz.push(xyz);
            p.uv.push([v[iu], v[iv]]);
        }
    }
    Ok(p)
}

fn find(hay: &[u8], needle: &[u8]) -> Option<usize> {
    hay.windows(needle.len()).position(|w| w == needle)
}

/// Solve the symmetric positive system `a x = b` (Gaussian elimination with pivoting).
fn solve<const N: usize>(mut a: [[f64; N]; N], mut b: [f64; N]) -> Option<[f64; N]> {
    for c in 0..N {
        let p = (c..N).max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs()))?;
        if a[p][c].abs() < 1e-300 {
            return None;
        }
        a.swap(c, p);
        b.swap(c, p);
        for r in c + 1..N {
            let f = a[r][c] / a[c][c];
            for k in c..N {
                a[r][k] -= f * a[c][k];
            }
            b[r] -= f * b[c];
        }
    }
    let mut x = [0f64; N];
    for r in (0..N).rev() {
        let s: f64 = (r + 1..N).map(|k| a[r][k] * x[k]).sum();
        x[r] = (b[r] - s) / a[r][r];
    }
    Some(x)
}

/// A fitted surface: sphere (centre, radius) or plane (unit normal n, offset d: n·x = d).
#[derive(Clone, Copy)]
enum Fit {
    Sphere { c: [f64; 3], r: f64 },
    Plane { n: [f64; 3], d: f64 },
}

impl Fit {
    fn residual(&self, p: &[f64; 3]) -> f64 {
        match *self {
            Fit::Sphere { c, r } => ((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2) + (p[2] - c[2]).powi(2)).sqrt() - r,
            Fit::Plane { n, d } => n[0] * p[0] + n[1] * p[1] + n[2] * p[2] - d,
        }
    }
}

/// Geometric least-squares sphere: an algebraic fit, then Gauss-Newton on the distances.
fn fit_sphere(pts: &[[f64; 3]]) -> Option<Fit> {
    if pts.len() < 4 {
        return None;
    }
    // Centre the data for conditioning.
    let m = mean(pts);
    let q: Vec<[f64; 3]> = pts.iter().map(|p| [p[0] - m[0], p[1] - m[1], p[2] - m[2]]).collect();
    // |p|² = 2 c·p + k, unknowns (c, k).
    let mut a = [[0f64; 4]; 4];
    let mut b = [0f64; 4];
    for p in &q {
        let row = [2.0 * p[0], 2.0 * p[1], 2.0 * p[2], 1.0];
        let rhs = p[0] * p[0] + p[1] * p[1] + p[2] * p[2];
        for i in 0..4 {
            for j in 0..4 {
                a[i][j] += row[i] * row[j];
            }
            b[i] += row[i] * rhs;
        }
    }
    let s = solve(a, b)?;
    let mut c = [s[0], s[1], s[2]];
    let mut r = (s[3] + c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).max(0.0).sqrt();
    for _ in 0..50 {
        let mut jtj = [[0f64; 4]; 4];
        let mut jtr = [0f64; 4];
        for p in &q {
            let d = [p[0] - c[0], p[1] - c[1], p[2] - c[2]];
            let dist = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt().max(1e-12);
            let res = dist - r;
            let j = [-d[0] / dist, -d[1] / dist, -d[2] / dist, -1.0];
            for i in 0..4 {
                for k in 0..4 {
                    jtj[i][k] += j[i] * j[k];
                }
                jtr[i] -= j[i] * res;
            }
        }
        let step = solve(jtj, jtr)?;
        c = [c[0] + step[0], c[1] + step[1], c[2] + step[2]];
        r += step[3];
        if step.iter().map(|x| x.abs()).fold(0.0, f64::max) < 1e-9 {
            break;
        }
    }
    Some(Fit::Sphere { c: [c[0] + m[0], c[1] + m[1], c[2] + m[2]], r: r.abs() })
}

/// Total least-squares plane: the normal is the covariance's least eigenvector (Jacobi).
fn fit_plane(pts: &[[f64; 3]]) -> Option<Fit> {
    if pts.len() < 3 {
        return None;
    }
    let m = mean(pts);
    let mut a = [[0f64; 3]; 3];
    for p in pts {
        let d = [p[0] - m[0], p[1] - m[1], p[2] - m[2]];
        for i in 0..3 {
            for j in 0..3 {
                a[i][j] += d[i] * d[j];
            }
        }
    }
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _ in 0..100 {
        let (mut p, mut q, mut big) = (0, 1, 0.0);
        for i in 0..3 {
            for j in i + 1..3 {
                if a[i][j].abs() > big {
                    (p, q, big) = (i, j, a[i][j].abs());
                }
            }
        }
        if big < 1e-15 * (a[0][0].abs() + a[1][1].abs() + a[2][2].abs() + 1e-300) {
            break;
        }
        let theta = 0.5 * (2.0 * a[p][q]).atan2(a[q][q] - a[p][p]);
        let (s, c) = theta.sin_cos();
        let mut g = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        g[p][p] = c;
        g[q][q] = c;
        g[p][q] = s;
        g[q][p] = -s;
        // a = gᵀ a g, v = v g
        let mul = |x: &[[f64; 3]; 3], y: &[[f64; 3]; 3]| {
            let mut z = [[0f64; 3]; 3];
            for i in 0..3 {
                for j in 0..3 {
                    z[i][j] = (0..3).map(|k| x[i][k] * y[k][j]).sum();
                }
            }
            z
        };
        let gt = [[g[0][0], g[1][0], g[2][0]], [g[0][1], g[1][1], g[2][1]], [g[0][2], g[1][2], g[2][2]]];
        a = mul(&mul(&gt, &a), &g);
        v = mul(&v, &g);
    }
    let k = (0..3).min_by(|&i, &j| a[i][i].total_cmp(&a[j][j]))?;
    let n = [v[0][k], v[1][k], v[2][k]];
    Some(Fit::Plane { n, d: n[0] * m[0] + n[1] * m[1] + n[2] * m[2] })
}

fn mean(pts: &[[f64; 3]]) -> [f64; 3] {
    let mut m = [0f64; 3];
    for p in pts {
        for i in 0..3 {
            m[i] += p[i];
        }
    }
    m.map(|x| x / pts.len().max(1) as f64)
}

fn fit(shape: Shape, pts: &[[f64; 3]]) -> Result<Fit, String> {
    match shape {
        Shape::Sphere => fit_sphere(pts),
        Shape::Plane => fit_plane(pts),
    }
    .ok_or_else(|| format!("cannot fit a {} to {} points", if shape == Shape::Sphere { "sphere" } else { "plane" }, pts.len()))
}

fn report(label: &str, f: &Fit, pts: &[[f64; 3]], tol: f64, expect: Option<f64>) {
    let res: Vec<f64> = pts.iter().map(|p| f.residual(p)).collect();
    let rms = (res.iter().map(|r| r * r).sum::<f64>() / res.len().max(1) as f64).sqrt();
    let off = res.iter().filter(|r| r.abs() > tol).count();
    let mut abs: Vec<f64> = res.iter().map(|r| r.abs()).collect();
    abs.sort_by(f64::total_cmp);
    let median = abs.get(abs.len() / 2).copied().unwrap_or(f64::NAN);
    match *f {
        Fit::Sphere { c, r } => {
            print!("{label}: {} points, radius {r:.2} mm, centre ({:.1}, {:.1}, {:.1}) mm", pts.len(), c[0], c[1], c[2]);
            if let Some(e) = expect {
                print!(" ({:+.2} mm against {e})", r - e);
            }
        }
        Fit::Plane { n, d } => print!("{label}: {} points, plane n = ({:.4}, {:.4}, {:.4}), n·x = {d:.1} mm", pts.len(), n[0], n[1], n[2]),
    }
    println!(
        "; RMS {rms:.3} mm, median |residual| {median:.3} mm, {:.2}% of points more than {tol} mm off",
        100.0 * off as f64 / pts.len().max(1) as f64
    );
}

fn run() -> Result<(), String> {
    let o = parse_args()?;
    let points = read_ply(&o.ply)?;
    let mask = match (&o.mask, &o.image) {
        (Some(path), _) => Some(load_mask(path)?),
        (None, Some(path)) => {
            // parse_args checked that the region and threshold come with the image.
            let (region, threshold) = o.region.as_ref().zip(o.threshold).ok_or("--image needs --circle or --polygon, and --threshold")?;
            Some(mask_from_frame(path, region, threshold, o.spread)?)
        }
        _ => None,
    };
    if let (Some(m), Some(path)) = (&mask, &o.write_mask) {
        save_mask(m, path)?;
    }
    let pixel = |uv: &[f64; 2], m: &Mask| -> Option<usize> {
        let (x, y) = (uv[0].round(), uv[1].round());
        (x >= 0.0 && y >= 0.0 && (x as usize) < m.width && (y as usize) < m.height).then(|| y as usize * m.width + x as usize)
    };
    let selected: Vec<[f64; 3]> = match &mask {
        Some(m) => {
            let object = m.inside.iter().filter(|&&b| b).count();
            let mut covered = HashSet::new();
            let mut sel = Vec::new();
            for (p, uv) in points.xyz.iter().zip(&points.uv) {
                if let Some(i) = pixel(uv, m).filter(|&i| m.inside[i]) {
                    covered.insert(i);
                    sel.push(*p);
                }
            }
            println!(
                "object: {object} pixels of {}x{}; points: {} in the cloud, {} on the object, {} off it",
                m.width,
                m.height,
                points.xyz.len(),
                sel.len(),
                points.xyz.len() - sel.len()
            );
            println!("coverage: {:.2}% of the object's pixels have a point ({} of {object})", 100.0 * covered.len() as f64 / object.max(1) as f64, covered.len());
            sel
        }
        None => {
            println!("points: {} in the cloud (no mask: all are fitted)", points.xyz.len());
            points.xyz.clone()
        }
    };
    let first = fit(o.shape, &selected)?;
    report("fit, all points", &first, &selected, o.tolerance, o.expect_radius);
    let mut current = first;
    let mut kept: Vec<[f64; 3]> = Vec::new();
    for _ in 0..20 {
        let next: Vec<[f64; 3]> = selected.iter().copied().filter(|p| current.residual(p).abs() <= o.trim).collect();
        let same = next.len() == kept.len();
        kept = next;
        current = fit(o.shape, &kept)?;
        if same {
            break;
        }
    }
    report(&format!("fit, points within {} mm", o.trim), &current, &kept, o.tolerance, o.expect_radius);
    println!("kept {:.2}% of the fitted points", 100.0 * kept.len() as f64 / selected.len().max(1) as f64);
    if let (Some(path), Some(width)) = (&o.correspondence, o.stripe_width) {
        stripe_consistency(path, width, mask.as_ref())?;
    }
    Ok(())
}

/// The cubic terms of a camera pixel (coordinates in thousands of pixels).
fn cubic_terms(x: f64, y: f64) -> [f64; 10] {
    let (x, y) = (x / 1000.0, y / 1000.0);
    [1.0, x, y, x * x, x * y, y * y, x * x * x, x * x * y, x * y * y, y * y * y]
}

/// See `--correspondence` in the module's documentation.
fn stripe_consistency(path: &str, stripe_width: f64, mask: Option<&Mask>) -> Result<(), String> {
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read {path}: {e}"))?;
    let corr = stripelight::io::decode_pfm_rgb(&bytes).map_err(|e| format!("{path}: {e}"))?;
    let (w, h) = corr.size();
    if let Some(m) = mask.filter(|m| (m.width, m.height) != (w, h)) {
        return Err(format!("{path} is {w}x{h}, the object's mask {}x{}", m.width, m.height));
    }
    // (terms, coordinate in stripes) of every object pixel the first family decoded.
    let samples: Vec<([f64; 10], f64)> = (0..w * h)
        .filter(|&i| mask.is_none_or(|m| m.inside[i]))
        .filter_map(|i| {
            let s = corr.pixels()[i][0];
            s.is_finite().then(|| (cubic_terms((i % w) as f64, (i / w) as f64), s as f64 / stripe_width))
        })
        .collect();
    let value = |c: &[f64; 10], t: &[f64; 10]| -> f64 { c.iter().zip(t).map(|(a, b)| a * b).sum() };
    let mut coef = [0f64; 10];
    // Fitted to every pixel, then to those within 3, 1 and half a stripe of the last fit.
    for limit in [f64::INFINITY, 3.0, 1.0, 0.5] {
        let (mut a, mut b) = ([[0f64; 10]; 10], [0f64; 10]);
        for (t, s) in samples.iter().filter(|(t, s)| (s - value(&coef, t)).abs() <= limit) {
            for i in 0..10 {
                for j in 0..10 {
                    a[i][j] += t[i] * t[j];
                }
                b[i] += t[i] * s;
            }
        }
        coef = solve(a, b).ok_or_else(|| format!("{path}: too few decoded pixels ({}) for a cubic", samples.len()))?;
    }
    let share = |pick: &dyn Fn(f64) -> bool| 100.0 * samples.iter().filter(|(t, s)| pick((s - value(&coef, t)).abs())).count() as f64 / samples.len().max(1) as f64;
    println!(
        "stripe coordinates: {} pixels; against a cubic in the pixel: {:.2}% within a quarter of a stripe, {:.2}% within half, {:.2}% more than one stripe off",
        samples.len(),
        share(&|e| e <= 0.25),
        share(&|e| e <= 0.5),
        share(&|e| e > 1.0)
    );
    Ok(())
}
