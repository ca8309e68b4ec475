//! Pictures of every stage of a scan, for people: the teaching view of the web page
//! and `stripelight scan --debug DIR`.

use crate::filter::{FilterMode, Restored};
use crate::raster::Image;
use crate::segment::{Segmentation, NO_CODE};

/// A named intermediate image for people to look at.
#[derive(Clone, Debug)]
pub struct Stage {
    /// Short file-name-friendly name, e.g. `restored-0`.
    pub name: String,
    /// What it shows, one sentence.
    pub caption: String,
    /// The picture.
    pub image: Image<[u8; 3]>,
}

/// What one frame's stages are drawn from: the frame and every stage's output, as the
/// scanner keeps them (see `Scanner::stages`).
pub struct StageInputs<'a> {
    /// The 8-bit camera frame.
    pub frame: &'a Image<[u8; 3]>,
    /// The filter that restored the families.
    pub filter: FilterMode,
    /// Each family's restored image.
    pub restored: &'a [Restored],
    /// Each family's boundaries.
    pub segmentations: &'a [Segmentation],
    /// Each family's stripe coordinate per pixel (NaN = none).
    pub stripe_coords: &'a [Vec<f32>],
    /// Each family's depth, mm.
    pub family_depth: &'a [Image<f32>],
    /// The merged depth, mm.
    pub depth: &'a Image<f32>,
}

/// A hue in [0, 1) at full saturation as 8-bit RGB.
fn hue(h: f32, value: f32) -> [u8; 3] {
    let h6 = h.rem_euclid(1.0) * 6.0;
    let x = 1.0 - ((h6 % 2.0) - 1.0).abs();
    let (r, g, b) = match h6 as u32 {
        0 => (1.0, x, 0.0),
        1 => (x, 1.0, 0.0),
        2 => (0.0, 1.0, x),
        3 => (0.0, x, 1.0),
        4 => (x, 0.0, 1.0),
        _ => (1.0, 0.0, x),
    };
    [r, g, b].map(|c: f32| (c * value * 255.0).round() as u8)
}

/// Pixels with a depth.
fn decoded(depth: &[f32]) -> usize {
    depth.iter().filter(|z| !z.is_nan()).count()
}

/// Depth in mm to a colour: near red through green to far blue over the range of the
/// finite values of `depth`; black where there is none.
fn depth_picture(depth: &[f32], w: usize, h: usize) -> Image<[u8; 3]> {
    let (lo, hi) = depth
        .iter()
        .filter(|z| z.is_finite())
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &z| (a.min(z), b.max(z)));
    let span = (hi - lo).max(1.0);
    let data = depth
        .iter()
        .map(|&z| if z.is_finite() { hue(0.66 * (z - lo) / span, 1.0) } else { [0, 0, 0] })
        .collect();
    Image::from_vec(w, h, data).unwrap_or_else(|_| Image::new(w, h, [0, 0, 0]))
}

/// Draw the stages of one frame.
pub fn render(inputs: &StageInputs) -> Vec<Stage> {
    let (w, h) = inputs.frame.size();
    let mut out = vec![Stage {
        name: "input".into(),
        caption: "The camera frame.".into(),
        image: inputs.frame.clone(),
    }];
    for (k, restored) in inputs.restored.iter().enumerate() {
        // Restored log colour: zero mean, about ±1 for the palette's steps.
        let data = (0..w * h)
            .map(|i| {
                let c = |ch: usize| ((restored.log[ch][i] * 0.45 + 0.5).clamp(0.0, 1.0) * 255.0) as u8;
                [c(0), c(1), c(2)]
            })
            .collect();
        let restored_img = Image::from_vec(w, h, data).unwrap_or_else(|_| Image::new(w, h, [0, 0, 0]));
        out.push(Stage {
            name: format!("restored-{k}"),
            caption: format!(
                "Family {k}: restored stripe colours (log scale, {}); dominant direction {:.0} degrees.",
                inputs.filter,
                restored.dominant.to_degrees()
            ),
            image: restored_img.clone(),
        });
        let angle = restored.angle.iter().map(|&a| hue(a / std::f32::consts::PI, 0.9)).collect();
        out.push(Stage {
            name: format!("angle-{k}"),
            caption: format!("Family {k}: the angle chosen per pixel (hue: 0 to 180 degrees)."),
            image: Image::from_vec(w, h, angle).unwrap_or_else(|_| Image::new(w, h, [0, 0, 0])),
        });
        // Segmentation: boundaries over the dimmed restored image; white identified,
        // orange read but not identified, grey unreadable.
        let mut seg_img = restored_img.map(|p| p.map(|c| c / 3));
        let seg = &inputs.segmentations[k];
        if let Some(axis) = seg.axis {
            for (line, edges) in seg.lines.iter().enumerate() {
                for e in edges {
                    let s = e.pos.round().max(0.0) as usize;
                    let i = axis.index(line, s.min(axis.lines(w, h).1 - 1), w);
                    let colour = if e.id >= 0 {
                        [255, 255, 255]
                    } else if e.code != NO_CODE {
                        [255, 140, 0]
                    } else {
                        [110, 110, 110]
                    };
                    seg_img.pixels_mut()[i] = colour;
                }
            }
        }
        out.push(Stage {
            name: format!("segmentation-{k}"),
            caption: format!("Family {k}: stripe boundaries (white identified, orange read but not identified, grey unreadable)."),
            image: seg_img,
        });
        let coords = &inputs.stripe_coords[k];
        let ids = coords
            .iter()
            .map(|&q| {
                if q.is_nan() {
                    [0, 0, 0]
                } else {
                    let j = q.floor();
                    hue(j * 0.618_034, 0.55 + 0.45 * (q - j))
                }
            })
            .collect();
        out.push(Stage {
            name: format!("identities-{k}"),
            caption: format!("Family {k}: stripe identities in false colour (brightness ramps across each stripe)."),
            image: Image::from_vec(w, h, ids).unwrap_or_else(|_| Image::new(w, h, [0, 0, 0])),
        });
        let depth = inputs.family_depth[k].pixels();
        out.push(Stage {
            name: format!("depth-{k}"),
            caption: format!("Family {k}: depth (near red, far blue), {} points.", decoded(depth)),
            image: depth_picture(depth, w, h),
        });
    }
    let depth = inputs.depth.pixels();
    out.push(Stage {
        name: "depth-merged".into(),
        caption: format!("Merged depth, {} points.", decoded(depth)),
        image: depth_picture(depth, w, h),
    });
    out
}
