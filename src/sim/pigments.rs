//! Surface colours of the hard scenes, as linear diffuse reflectance per channel.
//!
//! Real pigments come from a published table: the 24 patches of the ColorChecker
//! Classic, whose 8-bit sRGB values are converted to linear light with the sRGB
//! transfer function (IEC 61966-2-1). Saturated dyes are written directly in linear
//! reflectance, with the weak channels down to 1 %: what strongly dyed fabric, plastic
//! or printed paper reflects outside its colour's band (a deep red dye returns about a
//! percent of green and blue light).

use crate::raster::Rgb;

/// The ColorChecker Classic's 24 patches, row by row as on the chart (4 rows of 6,
/// dark skin at the top left, black at the bottom right), with the manufacturer's
/// 8-bit sRGB values as published in the chart's documentation and reproduced in the
/// "Manufacturer's sRGB color values" column of Wikipedia's *ColorChecker* article
/// (X-Rite, post-2009 formulation; hexadecimal 735244 for dark skin, c29682 for light
/// skin, ...).
pub const COLORCHECKER_SRGB: [(&str, [u8; 3]); 24] = [
    ("dark skin", [115, 82, 68]),
    ("light skin", [194, 150, 130]),
    ("blue sky", [98, 122, 157]),
    ("foliage", [87, 108, 67]),
    ("blue flower", [133, 128, 177]),
    ("bluish green", [103, 189, 170]),
    ("orange", [214, 126, 44]),
    ("purplish blue", [80, 91, 166]),
    ("moderate red", [193, 90, 99]),
    ("purple", [94, 60, 108]),
    ("yellow green", [157, 188, 64]),
    ("orange yellow", [224, 163, 46]),
    ("blue", [56, 61, 150]),
    ("green", [70, 148, 73]),
    ("red", [175, 54, 60]),
    ("yellow", [231, 199, 31]),
    ("magenta", [187, 86, 149]),
    ("cyan", [8, 133, 161]),
    ("white 9.5", [243, 243, 242]),
    ("neutral 8", [200, 200, 200]),
    ("neutral 6.5", [160, 160, 160]),
    ("neutral 5", [122, 122, 121]),
    ("neutral 3.5", [85, 85, 85]),
    ("black 2", [52, 52, 52]),
];

/// Linear light of an 8-bit sRGB value (the sRGB transfer function, IEC 61966-2-1:
/// linear below code 10, a 2.4 power above).
pub fn srgb_to_linear(code: u8) -> f32 {
    let x = code as f64 / 255.0;
    let y = if x <= 0.04045 { x / 12.92 } else { ((x + 0.055) / 1.055).powf(2.4) };
    y as f32
}

/// Linear reflectance of an 8-bit sRGB colour.
pub fn srgb_colour(c: [u8; 3]) -> Rgb {
    c.map(srgb_to_linear)
}

/// The ColorChecker's 24 patches as linear reflectance, in chart order.
pub fn colorchecker() -> Vec<Rgb> {
    COLORCHECKER_SRGB.iter().map(|&(_, c)| srgb_colour(c)).collect()
}

/// The ColorChecker's black card between and around the patches: the chart's matte
/// black frame, taken as its black patch (sRGB 52, about 3.4 % reflectance).
pub fn colorchecker_frame() -> Rgb {
    srgb_colour(COLORCHECKER_SRGB[23].1)
}

/// Off-channel reflectance of the pure dyes: 1 %, the hardest case.
pub const DYE_OFF: f32 = 0.01;

/// Six pure dyes (red, green, blue, yellow, cyan, magenta): 1 % in the channels
/// outside their colour, 55-75 % inside.
pub const DYES: [Rgb; 6] = [
    [0.72, DYE_OFF, DYE_OFF],
    [DYE_OFF, 0.58, DYE_OFF],
    [DYE_OFF, DYE_OFF, 0.62],
    [0.74, 0.66, DYE_OFF],
    [DYE_OFF, 0.56, 0.66],
    [0.70, DYE_OFF, 0.60],
];

/// Reflectance of the near-black patches of the dyed bag: 2.5 %, black fabric or
/// leather (darker than the ColorChecker's black patch).
pub const NEAR_BLACK: f32 = 0.025;

/// Light skin: the ColorChecker's "light skin" patch, which the chart's makers chose
/// to match light human skin.
pub fn light_skin() -> Rgb {
    srgb_colour(COLORCHECKER_SRGB[1].1)
}

/// Dark skin: the ColorChecker's "dark skin" patch.
pub fn dark_skin() -> Rgb {
    srgb_colour(COLORCHECKER_SRGB[0].1)
}

/// Pine's early wood (the light bands), sRGB (214, 170, 118): an approximation read
/// off photographs of planed pine, not a measurement.
pub fn early_wood() -> Rgb {
    srgb_colour([214, 170, 118])
}

/// Pine's late wood (the dark bands), sRGB (158, 104, 58), likewise approximate.
pub fn late_wood() -> Rgb {
    srgb_colour([158, 104, 58])
}

/// Matte white wall paint: 82 % reflectance (white paints reflect 80-90 %).
pub const WHITE_WALL: f32 = 0.82;

/// A mid-grey wall: 25 %, close to the ColorChecker's neutral 5 (about 19 %) and 6.5
/// (35 %).
pub const GREY_WALL: f32 = 0.25;
