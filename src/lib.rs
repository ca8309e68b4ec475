//! # stripelight
//!
//! One-shot colour-stripe structured light after Lee, Je and Lee, *Color-Stripe
//! Structured Light Robust to Surface Color and Discontinuity*. A projector shows one
//! pattern of colour stripes in one, two or three directions; one camera frame of the
//! lit scene gives a depth map and a point cloud.
//!
//! The modules follow the method in the order a reader meets it in the paper:
//!
//! | stage | module |
//! |---|---|
//! | coded stripe patterns and their spec files | [`pattern`] |
//! | log-gradient illumination restoration (eq. 5-8) | [`filter`] |
//! | projector-camera calibration and rays | [`calib`] |
//! | projector-camera simulator with ground truth | [`sim`] |
//! | images, PNG/PFM/PLY reading and writing | [`raster`], [`io`] |
//!
//! Everything except `wasm` is plain Rust with no knowledge of the browser; the
//! `wasm` module is the one thin boundary the web page talks to.
#![deny(missing_docs)]

pub mod calib;
pub mod error;
pub mod filter;
pub mod io;
pub mod pattern;
pub mod raster;
pub mod sim;

#[cfg(target_arch = "wasm32")]
pub mod wasm;

pub use calib::Calibration;
pub use error::Error;
pub use pattern::PatternSpec;
pub use raster::Image;
