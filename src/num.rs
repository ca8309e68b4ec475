//! Number helpers of the per-frame loops.

/// The larger of two numbers that are never NaN (scores, light levels, edge
/// strengths). `f32::max` handles NaN, which in WebAssembly is a call to a library
/// routine (`fmaxf`) instead of one instruction: in the line alignment it was a tenth
/// of a frame. This is a comparison and a select on every target. Like `f32::max`, a
/// NaN `a` gives `b`.
#[inline]
pub fn max_f32(a: f32, b: f32) -> f32 {
    if a >= b {
        a
    } else {
        b
    }
}

/// [`max_f32`] for `f64` (no `fmax` call in WebAssembly); a NaN `a` gives `b`.
#[inline]
pub fn max_f64(a: f64, b: f64) -> f64 {
    if a >= b {
        a
    } else {
        b
    }
}
