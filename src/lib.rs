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
//! | stripe boundaries and their colour transitions | [`segment`] |
//! | stripe identification from neighbour windows | [`decode`] |
//! | depth from a calibrated projector-camera pair | [`triangulate`] |
//! | merging the range images of the families | [`merge`] |
//! | point clouds and PLY | [`cloud`] |
//! | the long-lived scanner that runs the stages per frame | [`scan`] |
//! | projector-camera calibration and rays | [`calib`] |
//! | projector-camera simulator with ground truth | [`sim`] |
//! | accuracy against ground truth | [`eval`] |
//! | images, PNG/PFM reading and writing | [`raster`], [`io`] |
//!
//! Everything except `wasm` is plain Rust with no knowledge of the browser; the
//! `wasm` module is the one thin boundary the web page talks to.
#![deny(missing_docs)]

pub mod pattern;
pub mod filter;
pub mod segment;
pub mod decode;
pub mod triangulate;
pub mod merge;
pub mod scan;
pub mod stages;
pub mod cloud;
pub mod calib;
pub mod sim;
pub mod eval;
pub mod error;
pub mod io;
pub mod raster;

#[cfg(target_arch = "wasm32")]
pub mod wasm;

pub use calib::Calibration;
pub use error::Error;
pub use pattern::PatternSpec;
pub use raster::Image;
