//! Scenes: textured analytic objects in the camera frame, and the built-in test scenes.

use super::geometry::{HeightField, Shape};
use super::pigments;
use super::texture::{Texture, BLOTCH_DARK_LEVEL, BLOTCH_SATURATION, BLOTCH_VALUE};
use crate::error::{Error, Result};
use crate::raster::Rgb;
use glam::{DMat3, DVec2, DVec3};

/// One object of a scene: a surface and how much light it reflects.
#[derive(Clone, Debug)]
pub struct Object {
    /// The surface, camera frame, mm.
    pub shape: Shape,
    /// Its albedo, laid out in the shape's surface coordinates.
    pub texture: Texture,
}

/// A set of objects in the camera frame (mm), built from validated shapes.
#[derive(Clone, Debug)]
pub struct Scene {
    objects: Vec<Object>,
}

/// The nearest surface a ray meets.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit (the depth Z for a camera ray with `d.z = 1`).
    pub t: f64,
    /// The surface point, camera frame, mm.
    pub point: DVec3,
    /// Unit shading normal, turned to face the ray's origin.
    pub normal: DVec3,
    /// Linear albedo at the point.
    pub albedo: Rgb,
    /// Index of the object hit in [`Scene::objects`].
    pub object: usize,
}

/// Seed of the crumpled paper's folds: the paper scene is the same on every run.
const PAPER_SEED: u64 = 0x9A9E_4C4A_3D1F_0001;
/// Grid spacing of the paper's height field, mm: about one camera pixel at 750 mm on
/// the demo rig, finer than the 2-3 mm rounding of the folds.
const PAPER_SPACING_MM: f64 = 1.0;

impl Scene {
    /// Names accepted by [`Scene::builtin`]: the original five, then the hard scenes
    /// of real pigments and saturated dyes ([`Scene::HARD`]).
    pub const NAMES: &'static [&'static str] = &[
        "plane",
        "sphere",
        "paper",
        "textured",
        "occluders",
        "colorchecker",
        "sphere-dye",
        "paper-dye",
        "bag",
        "skin",
        "wood",
        "wall",
    ];

    /// The scenes of real pigments and hard dyes (a subset of [`Scene::NAMES`]).
    pub const HARD: &'static [&'static str] = &["colorchecker", "sphere-dye", "paper-dye", "bag", "skin", "wood", "wall"];

    /// A scene from objects; fails when a shape has non-finite or degenerate parameters.
    pub fn new(objects: Vec<Object>) -> Result<Self> {
        for o in &objects {
            o.shape.validate()?;
        }
        Ok(Scene { objects })
    }

    /// The objects, in the order given.
    pub fn objects(&self) -> &[Object] {
        &self.objects
    }

    /// A built-in scene for the demo rig's view (camera frame, Z about 600-950 mm):
    ///
    /// - `plane`: a white plane (albedo 0.8) through Z = 750 mm tilted 18 degrees, so depth
    ///   runs from about 640 to 900 mm across the view;
    /// - `sphere`: a sphere of radius 150 mm at Z = 800 mm in longitude/latitude squares of
    ///   saturated red, green, blue, yellow, cyan, magenta and white, before a light grey
    ///   plane at 950 mm;
    /// - `paper`: crumpled paper, a 520 x 400 mm sheet `z = 750 + h(x, y)` (Z about
    ///   720-785 mm) with folds and ridges of 15-30 mm, in four colour quadrants (cyan,
    ///   blue, green, red clockwise from the top left, as in the paper's Fig. 4), over a
    ///   dark table at 900 mm;
    /// - `textured`: an upright cylinder (radius 160 mm, axis at Z = 810 mm) with blotchy
    ///   multi-hue texture and dark patches, before a plane at 950 mm with a two-tone checkerboard;
    /// - `occluders`: a horizontal bar, a vertical post and a diagonal bar at 650-750 mm
    ///   before a plane at 950 mm: depth edges in three directions, cast shadows, plain albedos.
    ///
    /// The hard scenes, with real pigments ([`super::pigments`]) and dyes whose weak
    /// channels reflect 1 %:
    ///
    /// - `colorchecker`: the 24 ColorChecker Classic pigments printed poster size (60 mm
    ///   patches, 9 mm gaps, black card), 435 x 297 mm, bent around a vertical axis
    ///   (radius 450 mm, its sides 50 mm further back) and tilted (25 degrees back at
    ///   the top, turned 20 degrees, rolled 8), centred at 720 mm before a grey wall at
    ///   950 mm;
    /// - `sphere-dye`: the `sphere` with a checker of six pure dyes (red, green, blue,
    ///   yellow, cyan, magenta, 1 % off-channel) before the grey wall;
    /// - `paper-dye`: the crumpled `paper` in four pure dyes (cyan, blue, green, red);
    /// - `bag`: a soft bag (a 440 x 360 mm pillow bulging 95 mm towards the camera from
    ///   850 mm, with creases) in blotchy multi-hue dye (1 % off-channel) with
    ///   near-black patches (2.5 %), before a light wall at 950 mm;
    /// - `skin`: a head-sized sphere in light skin and a forearm-sized cylinder in dark
    ///   skin before it (the ColorChecker's skin patches, mottled ±12 %), casting a
    ///   shadow on it, before a wall at 950 mm;
    /// - `wood`: a pine board (520 x 300 mm) leaning back 35 degrees and a plank before
    ///   it, with growth rings of early and late wood, before a wall at 950 mm;
    /// - `wall`: the inside corner of a white (82 %) and a grey (25 %) wall meeting at
    ///   900 mm, each at 35 degrees to the image plane (about 650-900 mm).
    ///
    /// Unknown names fail with [`Error::Scene`] listing the known ones.
    ///
    /// ```
    /// let scene = stripelight::sim::Scene::builtin("sphere").unwrap();
    /// assert_eq!(scene.objects().len(), 2);
    /// assert!(stripelight::sim::Scene::builtin("teapot").is_err());
    /// ```
    pub fn builtin(name: &str) -> Result<Scene> {
        match name {
            "plane" => Ok(plane_scene()),
            "sphere" => Ok(sphere_scene()),
            "paper" => paper_scene(),
            "textured" => Ok(textured_scene()),
            "occluders" => Ok(occluders_scene()),
            "colorchecker" => Ok(colorchecker_scene()),
            "sphere-dye" => Ok(dye_sphere_scene()),
            "paper-dye" => dye_paper_scene(),
            "bag" => bag_scene(),
            "skin" => Ok(skin_scene()),
            "wood" => Ok(wood_scene()),
            "wall" => Ok(wall_scene()),
            _ => Err(Error::Scene(format!(
                "unknown scene {name:?}; known scenes: {}",
                Scene::NAMES.join(", ")
            ))),
        }
    }

    /// The nearest surface along `o + t·d` with `t` in `(t_min, t_max)`.
    pub fn cast(&self, o: DVec3, d: DVec3, t_min: f64, t_max: f64) -> Option<Hit> {
        let mut best: Option<(usize, f64)> = None;
        let mut limit = t_max;
        for (k, obj) in self.objects.iter().enumerate() {
            if let Some(t) = obj.shape.intersect(o, d, t_min, limit) {
                best = Some((k, t));
                limit = t;
            }
        }
        let (k, t) = best?;
        let obj = &self.objects[k];
        let point = o + d * t;
        let (mut normal, st) = obj.shape.surface(point);
        if normal.dot(d) > 0.0 {
            normal = -normal;
        }
        Some(Hit {
            t,
            point,
            normal,
            albedo: obj.texture.albedo(st),
            object: k,
        })
    }

    /// Whether any surface lies on the open segment from `a` to `b`, ignoring
    /// `clearance` mm at each end (so a segment that starts on a surface does not
    /// find that surface).
    pub fn blocked(&self, a: DVec3, b: DVec3, clearance: f64) -> bool {
        let d = b - a;
        let len = d.length();
        if !(len > 2.0 * clearance) {
            return false;
        }
        let (t0, t1) = (clearance / len, 1.0 - clearance / len);
        self.objects.iter().any(|o| o.shape.intersect(a, d, t0, t1).is_some())
    }
}

fn plain(shape: Shape, albedo: Rgb) -> Object {
    Object {
        shape,
        texture: Texture::Plain(albedo),
    }
}

/// The plane z = `depth` facing the camera.
fn wall(depth: f64) -> Shape {
    Shape::Plane {
        point: DVec3::new(0.0, 0.0, depth),
        normal: DVec3::NEG_Z,
    }
}

/// Rotation by `deg` degrees about the camera's z axis (towards +y from +x).
fn roll(deg: f64) -> DMat3 {
    DMat3::from_rotation_z(deg.to_radians())
}

fn plane_scene() -> Scene {
    // Tilted 18 degrees about an axis 30 degrees from the image's vertical, so depth
    // changes both across and down the image.
    let (tilt, azimuth) = (18f64.to_radians(), 30f64.to_radians());
    let normal = DVec3::new(tilt.sin() * azimuth.cos(), tilt.sin() * azimuth.sin(), -tilt.cos());
    Scene {
        objects: vec![plain(
            Shape::Plane {
                point: DVec3::new(0.0, 0.0, 750.0),
                normal,
            },
            [0.8; 3],
        )],
    }
}

fn sphere_scene() -> Scene {
    // Saturated dyes keep a little of their weak channels.
    let colours = vec![
        [0.75, 0.07, 0.06], // red
        [0.08, 0.62, 0.1],  // green
        [0.07, 0.1, 0.72],  // blue
        [0.75, 0.7, 0.08],  // yellow
        [0.08, 0.65, 0.7],  // cyan
        [0.7, 0.08, 0.65],  // magenta
        [0.75, 0.75, 0.75], // white
    ];
    checker_sphere(colours, 3)
}

/// A sphere of radius 150 mm at 800 mm in 22.5-degree squares of longitude and
/// latitude (`stride` apart in `colours` from one row to the next), before a light
/// grey wall at 950 mm.
fn checker_sphere(colours: Vec<[f32; 3]>, stride: usize) -> Scene {
    let radius = 150.0;
    Scene {
        objects: vec![
            Object {
                shape: Shape::Sphere { center: DVec3::new(0.0, 0.0, 800.0), radius },
                texture: Texture::Checker { colours, cell: radius * std::f64::consts::PI / 8.0, stride },
            },
            plain(wall(950.0), [0.7; 3]),
        ],
    }
}

/// The crumpled paper's height offset h(x, y), mm: ridges and valleys (tents with
/// rounded creases, tapering along their length) at random places, directions and
/// sizes, on a gentle sag of the whole sheet.
fn crumpled_paper(seed: u64) -> impl Fn(f64, f64) -> f64 {
    struct Fold {
        centre: (f64, f64),
        dir: (f64, f64),
        half_width: f64,
        half_length: f64,
        height: f64,
    }
    let mut state = seed;
    let mut next = move || {
        // SplitMix64.
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    };
    let folds: Vec<Fold> = (0..70)
        .map(|k| {
            let angle = next() * std::f64::consts::PI;
            let sign = if k % 2 == 0 { -1.0 } else { 1.0 };
            Fold {
                centre: (-290.0 + 580.0 * next(), -230.0 + 460.0 * next()),
                dir: (angle.cos(), angle.sin()),
                half_width: 9.0 + 22.0 * next(),
                half_length: 50.0 + 150.0 * next(),
                height: sign * (5.0 + 9.0 * next()),
            }
        })
        .collect();
    // Rounding of the creases, in units of a fold's half width.
    const ROUND: f64 = 0.08;
    let soft_abs = |x: f64| (x * x + ROUND * ROUND).sqrt() - ROUND;
    move |x, y| {
        let mut h = 0.00012 * (x * x + 0.6 * y * y) - 8.0;
        for f in &folds {
            let (dx, dy) = (x - f.centre.0, y - f.centre.1);
            let along = (dx * f.dir.0 + dy * f.dir.1) / f.half_length;
            let across = (-dx * f.dir.1 + dy * f.dir.0) / f.half_width;
            let taper = 1.0 - along * along;
            if taper <= 0.0 || across.abs() > 3.0 {
                continue;
            }
            // A tent 1 - |x| for |x| < 1 with rounded top and feet.
            let tent = (soft_abs(across - 1.0) + soft_abs(across + 1.0) - 2.0 * soft_abs(across)) / 2.0;
            h += f.height * tent * taper * taper;
        }
        h
    }
}

fn paper_scene() -> Result<Scene> {
    let sheet = HeightField::new(
        (-260.0, 260.0),
        (-200.0, 200.0),
        PAPER_SPACING_MM,
        750.0,
        crumpled_paper(PAPER_SEED),
    )?;
    Ok(Scene {
        objects: vec![
            Object {
                shape: Shape::HeightField(sheet),
                texture: Texture::Quadrants([
                    [0.1, 0.6, 0.68],  // cyan, top left
                    [0.1, 0.16, 0.65], // blue, top right
                    [0.12, 0.55, 0.14], // green, bottom right
                    [0.7, 0.12, 0.1],  // red, bottom left
                ]),
            },
            plain(wall(900.0), [0.22, 0.2, 0.18]),
        ],
    })
}

fn textured_scene() -> Scene {
    Scene {
        objects: vec![
            Object {
                shape: Shape::Cylinder {
                    center: DVec3::new(-10.0, 0.0, 810.0),
                    axis: DVec3::Y,
                    radius: 160.0,
                    half_length: 185.0,
                },
                texture: Texture::Blotchy {
                    scale: 60.0,
                    seed: 11,
                    saturation: BLOTCH_SATURATION,
                    value: BLOTCH_VALUE,
                    dark_level: BLOTCH_DARK_LEVEL,
                },
            },
            Object {
                shape: wall(950.0),
                texture: Texture::Checker {
                    colours: vec![[0.72, 0.7, 0.66], [0.5, 0.46, 0.4]],
                    cell: 60.0,
                    stride: 1,
                },
            },
        ],
    }
}

fn occluders_scene() -> Scene {
    let cuboid = |center: DVec3, half: DVec3, roll_deg: f64| Shape::Cuboid {
        center,
        axes: roll(roll_deg),
        half,
    };
    Scene {
        objects: vec![
            plain(wall(950.0), [0.62, 0.6, 0.56]),
            // Horizontal bar.
            plain(
                cuboid(DVec3::new(20.0, -135.0, 700.0), DVec3::new(230.0, 28.0, 30.0), 0.0),
                [0.78, 0.76, 0.72],
            ),
            // Vertical post, in front of the bar's left end.
            plain(
                cuboid(DVec3::new(-175.0, 30.0, 650.0), DVec3::new(28.0, 185.0, 30.0), 0.0),
                [0.62, 0.42, 0.26],
            ),
            // Diagonal bar, down to the right.
            plain(
                cuboid(DVec3::new(110.0, 95.0, 750.0), DVec3::new(190.0, 24.0, 24.0), 40.0),
                [0.32, 0.46, 0.66],
            ),
        ],
    }
}

/// Rotation turning a sheet facing the camera: `yaw` degrees about the camera's y
/// axis (its right side away), then `pitch` about x (its top away), then `roll` about
/// its normal.
fn orientation(yaw: f64, pitch: f64, roll_deg: f64) -> DMat3 {
    DMat3::from_rotation_y(-yaw.to_radians()) * DMat3::from_rotation_x(pitch.to_radians()) * roll(roll_deg)
}

/// Side of a poster-size ColorChecker patch, mm (the Classic's are about 40 mm; 1.5
/// times that makes the chart fill most of the frame at 720 mm).
const CHART_PATCH_MM: f64 = 60.0;
/// Gap between patches, and card border around them, mm (same 1.5 scale).
const CHART_GAP_MM: f64 = 9.0;
const CHART_BORDER_MM: f64 = 15.0;

fn colorchecker_scene() -> Scene {
    let pitch = CHART_PATCH_MM + CHART_GAP_MM;
    let half = DVec2::new(
        (6.0 * pitch - CHART_GAP_MM) / 2.0 + CHART_BORDER_MM,
        (4.0 * pitch - CHART_GAP_MM) / 2.0 + CHART_BORDER_MM,
    );
    Scene {
        objects: vec![
            Object {
                shape: Shape::BentSheet {
                    center: DVec3::new(0.0, 0.0, 720.0),
                    axes: orientation(20.0, 25.0, 8.0),
                    curvature: 1.0 / 450.0,
                    half_size: half,
                },
                texture: Texture::Chart {
                    colours: pigments::colorchecker(),
                    columns: 6,
                    patch: CHART_PATCH_MM,
                    gap: CHART_GAP_MM,
                    background: pigments::colorchecker_frame(),
                },
            },
            plain(wall(950.0), [0.5; 3]),
        ],
    }
}

fn dye_sphere_scene() -> Scene {
    // Stride 2 keeps vertical neighbours different.
    checker_sphere(pigments::DYES.to_vec(), 2)
}

fn dye_paper_scene() -> Result<Scene> {
    let sheet = HeightField::new(
        (-260.0, 260.0),
        (-200.0, 200.0),
        PAPER_SPACING_MM,
        750.0,
        crumpled_paper(PAPER_SEED),
    )?;
    let d = pigments::DYES;
    Ok(Scene {
        objects: vec![
            Object {
                shape: Shape::HeightField(sheet),
                // Cyan, blue, green, red clockwise from the top left, as `paper`.
                texture: Texture::Quadrants([d[4], d[2], d[1], d[0]]),
            },
            plain(wall(900.0), [0.22, 0.2, 0.18]),
        ],
    })
}

/// Seed of the bag's creases.
const BAG_SEED: u64 = 0xBA6_5EED;

fn bag_scene() -> Result<Scene> {
    let (a, b) = (220.0, 180.0);
    let creases = crumpled_paper(BAG_SEED);
    // A pillow: flat at the seams, 95 mm deep in the middle, steep near the seams.
    let pillow = move |x: f64, y: f64| {
        let profile = |u: f64| (1.0 - u.powi(4)).max(0.0).sqrt();
        let bulge = profile(x / a) * profile(y / b);
        -95.0 * bulge + 0.5 * creases(x, y) * bulge
    };
    let sheet = HeightField::new((-a, a), (-b, b), PAPER_SPACING_MM, 850.0, pillow)?;
    let value = 0.72;
    Ok(Scene {
        objects: vec![
            Object {
                shape: Shape::HeightField(sheet),
                texture: Texture::Blotchy {
                    scale: 45.0,
                    seed: 23,
                    // The weakest channel value · (1 − saturation) is the dyes' 1 %.
                    saturation: 1.0 - pigments::DYE_OFF as f64 / value,
                    value,
                    dark_level: pigments::NEAR_BLACK as f64 / value,
                },
            },
            plain(wall(950.0), [0.6; 3]),
        ],
    })
}

/// Relative brightness variation of the skin scene's mottling.
const SKIN_MOTTLE: f64 = 0.12;

fn skin_scene() -> Scene {
    let arm_axis = DVec3::new(0.92, 0.3, -0.25).normalize();
    Scene {
        objects: vec![
            Object {
                shape: Shape::Sphere {
                    center: DVec3::new(-70.0, -30.0, 830.0),
                    radius: 115.0,
                },
                texture: Texture::Mottled { base: pigments::light_skin(), amplitude: SKIN_MOTTLE, scale: 25.0, seed: 31 },
            },
            Object {
                shape: Shape::Cylinder {
                    center: DVec3::new(40.0, 95.0, 700.0),
                    axis: arm_axis,
                    radius: 42.0,
                    half_length: 260.0,
                },
                texture: Texture::Mottled { base: pigments::dark_skin(), amplitude: SKIN_MOTTLE, scale: 20.0, seed: 37 },
            },
            plain(wall(950.0), [0.6; 3]),
        ],
    }
}

fn wood_scene() -> Scene {
    let grain = |ring: f64, seed: u64| Texture::Wood { early: pigments::early_wood(), late: pigments::late_wood(), ring, seed };
    Scene {
        objects: vec![
            Object {
                shape: Shape::BentSheet {
                    center: DVec3::new(20.0, 10.0, 800.0),
                    axes: orientation(-15.0, 35.0, 0.0),
                    curvature: 0.0,
                    half_size: DVec2::new(260.0, 150.0),
                },
                texture: grain(9.0, 41),
            },
            Object {
                // A plank, long along its first axis, standing at 70 degrees.
                shape: Shape::Cuboid {
                    center: DVec3::new(-150.0, 20.0, 680.0),
                    axes: roll(70.0),
                    half: DVec3::new(200.0, 30.0, 12.0),
                },
                texture: grain(6.0, 43),
            },
            plain(wall(950.0), [0.7; 3]),
        ],
    }
}

/// Angle of each wall of the `wall` scene to the image plane, degrees.
const CORNER_ANGLE_DEG: f64 = 35.0;

fn wall_scene() -> Scene {
    let (s, c) = CORNER_ANGLE_DEG.to_radians().sin_cos();
    let crease = DVec3::new(60.0, 0.0, 900.0);
    // Seen from inside the corner the nearer of the two infinite planes is the wall.
    Scene {
        objects: vec![
            plain(Shape::Plane { point: crease, normal: DVec3::new(s, 0.0, -c) }, [pigments::WHITE_WALL; 3]),
            plain(Shape::Plane { point: crease, normal: DVec3::new(-s, 0.0, -c) }, [pigments::GREY_WALL; 3]),
        ],
    }
}
