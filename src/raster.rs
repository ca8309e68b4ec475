//! A minimal row-major image container shared by every stage.
//!
//! Pixel (u, v) is column u, row v; the centre of the top-left pixel is (0, 0)
//! (`conventions.md`). Colour images used inside the pipeline hold linear floats in
//! 0..=1 per channel unless a function says otherwise.

use crate::error::{Error, Result};

/// A `width` x `height` image of `T`, stored row by row.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Image<T> {
    width: usize,
    height: usize,
    data: Vec<T>,
}

/// Three linear colour channels per pixel.
pub type Rgb = [f32; 3];

/// 8-bit camera value from which a channel counts as clipped (saturated). A little
/// below 255 because webcams' tone curves and JPEG ringing rarely reach 255 exactly.
/// The page's exposure meter (`www/camera.js`) uses the same level.
pub const SATURATED: u8 = 250;

/// The table from 8-bit camera values to linear light in 0..=1 through a power law
/// `gamma`: `linear = (value / 255)^gamma` (2.2 for the simulator's camera and most
/// webcams; 1.0 keeps values as they are).
pub fn gamma_lut(gamma: f32) -> [f32; 256] {
    let mut lut = [0f32; 256];
    for (i, l) in lut.iter_mut().enumerate() {
        *l = (i as f32 / 255.0).powf(gamma);
    }
    lut
}

impl<T: Clone> Image<T> {
    /// An image filled with `value`.
    ///
    /// ```
    /// let img = stripelight::Image::new(4, 3, 0.5f32);
    /// assert_eq!(img.get(3, 2), 0.5);
    /// ```
    pub fn new(width: usize, height: usize, value: T) -> Self {
        Image {
            width,
            height,
            data: vec![value; width * height],
        }
    }

    /// Fill every pixel with `value` (no allocation).
    pub fn fill(&mut self, value: T) {
        self.data.iter_mut().for_each(|p| *p = value.clone());
    }
}

impl<T> AsRef<[T]> for Image<T> {
    fn as_ref(&self) -> &[T] {
        &self.data
    }
}

impl<T: Copy> Image<T> {
    /// The pixel at column `u`, row `v`. Panics when out of range (a programming error).
    #[inline]
    pub fn get(&self, u: usize, v: usize) -> T {
        self.data[v * self.width + u]
    }
}

impl<T> Image<T> {
    /// Wrap a row-major buffer; fails when its length is not `width * height`.
    pub fn from_vec(width: usize, height: usize, data: Vec<T>) -> Result<Self> {
        if data.len() != width * height {
            return Err(Error::BufferLength { size: (width, height), per_pixel: 1, got: data.len() });
        }
        Ok(Image {
            width,
            height,
            data,
        })
    }

    /// Width in pixels.
    #[inline]
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    #[inline]
    pub fn height(&self) -> usize {
        self.height
    }

    /// (width, height).
    #[inline]
    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// Mutable access to the pixel at column `u`, row `v`.
    #[inline]
    pub fn get_mut(&mut self, u: usize, v: usize) -> &mut T {
        &mut self.data[v * self.width + u]
    }

    /// All pixels, row-major.
    #[inline]
    pub fn pixels(&self) -> &[T] {
        &self.data
    }

    /// All pixels, row-major, mutable.
    #[inline]
    pub fn pixels_mut(&mut self) -> &mut [T] {
        &mut self.data
    }

    /// Row `v`.
    #[inline]
    pub fn row(&self, v: usize) -> &[T] {
        &self.data[v * self.width..(v + 1) * self.width]
    }

    /// The buffer, consuming the image.
    pub fn into_vec(self) -> Vec<T> {
        self.data
    }

    /// A new image of the same size with `f` applied to every pixel.
    pub fn map<U>(&self, f: impl FnMut(&T) -> U) -> Image<U> {
        Image {
            width: self.width,
            height: self.height,
            data: self.data.iter().map(f).collect(),
        }
    }

    /// Fails with [`Error::ImageSize`] unless the image is `width` x `height`.
    pub fn expect_size(&self, width: usize, height: usize) -> Result<()> {
        if (self.width, self.height) == (width, height) {
            Ok(())
        } else {
            Err(Error::ImageSize {
                expected: (width, height),
                got: (self.width, self.height),
            })
        }
    }
}

/// 8-bit sRGB-ish camera values to linear floats in 0..=1 through a power law
/// `gamma` (2.2 for the simulator's camera and most webcams; 1.0 keeps values as they are).
pub fn rgb8_to_linear(src: &Image<[u8; 3]>, gamma: f32, dst: &mut Image<Rgb>) {
    rgb8_to_linear_lut(src, &gamma_lut(gamma), dst);
}

/// [`rgb8_to_linear`] with a table from [`gamma_lut`] made once (the per-frame form).
pub fn rgb8_to_linear_lut(src: &Image<[u8; 3]>, lut: &[f32; 256], dst: &mut Image<Rgb>) {
    debug_assert_eq!(src.size(), dst.size());
    for (d, s) in dst.pixels_mut().iter_mut().zip(src.pixels()) {
        *d = [lut[s[0] as usize], lut[s[1] as usize], lut[s[2] as usize]];
    }
}

/// Linear floats to 8-bit values with the inverse of `gamma`, clamped to 0..=255.
pub fn linear_to_rgb8(src: &Image<Rgb>, gamma: f32) -> Image<[u8; 3]> {
    let inv = 1.0 / gamma;
    src.map(|p| p.map(|c| (c.clamp(0.0, 1.0).powf(inv) * 255.0).round() as u8))
}

/// Interleaved RGBA bytes (a canvas `ImageData`) to an RGB image.
pub fn from_rgba8(width: usize, height: usize, rgba: &[u8]) -> Result<Image<[u8; 3]>> {
    let mut out = Image::new(width, height, [0; 3]);
    rgba8_into(rgba, &mut out)?;
    Ok(out)
}

/// [`from_rgba8`] into an image of the right size (the per-frame form): fails when
/// `rgba` does not hold exactly 4 bytes for each of `dst`'s pixels.
pub fn rgba8_into(rgba: &[u8], dst: &mut Image<[u8; 3]>) -> Result<()> {
    let (width, height) = dst.size();
    if rgba.len() != width * height * 4 {
        return Err(Error::BufferLength { size: (width, height), per_pixel: 4, got: rgba.len() });
    }
    for (d, s) in dst.pixels_mut().iter_mut().zip(rgba.chunks_exact(4)) {
        *d = [s[0], s[1], s[2]];
    }
    Ok(())
}

/// An RGB image as interleaved RGBA bytes with alpha 255 (what a canvas shows).
pub fn to_rgba8(src: &Image<[u8; 3]>) -> Vec<u8> {
    let mut out = Vec::with_capacity(src.pixels().len() * 4);
    for p in src.pixels() {
        out.extend_from_slice(&[p[0], p[1], p[2], 255]);
    }
    out
}
