//! # stripelight
//!
//! One-shot colour-stripe structured light after Lee, Je and Lee, *Color-Stripe
//! Structured Light Robust to Surface Color and Discontinuity*. A projector shows one
//! pattern of colour stripes in one, two or three directions; one camera frame of the
//! lit scene gives a depth map and a point cloud.
//!
//! The modules follow the method in the order a reader meets it in the paper. Each
//! uses only the modules in its last column, and those never use it back: the crate's
//! dependencies form no cycle (`tests/layering.rs` reads the `use` lines, fails on a
//! cycle and checks this column).
//!
//! | stage | module | uses |
//! |---|---|---|
//! | coded stripe patterns and their spec files | [`pattern`] | error, raster |
//! | log-gradient illumination restoration (eq. 5-8) | [`filter`] | error, num, raster |
//! | stripe boundaries and their colour transitions | [`segment`] | filter, num, raster |
//! | order-preserving alignment of a line's boundaries to the pattern | [`align`] | segment |
//! | stripe identification from neighbour sequences | [`decode`] | align, num, pattern, segment |
//! | depth from a calibrated projector-camera pair | [`triangulate`] | calib, num, pattern |
//! | merging the range images of the families | [`merge`] | num |
//! | point clouds as flat arrays, and PLY | [`cloud`] | error |
//! | pictures of every stage, for people | [`stages`] | filter, raster, segment |
//! | the long-lived scanner that runs the stages per frame | [`scan`] | calib, cloud, decode, error, filter, merge, pattern, raster, segment, stages, triangulate |
//! | projector-camera calibration, its import from OpenCV and Bouguet files, rays and colour mixing (measured, or read from a scanned frame's stripes) | [`calib`] | error, pattern, raster |
//! | projector-camera simulator with ground truth | [`sim`] | calib, error, raster |
//! | accuracy against ground truth, and the Gray-code reference | [`eval`] | calib, error, filter, pattern, raster, scan, sim, triangulate |
//! | PNG/PFM reading and writing | [`io`] | error, raster |
//! | images, gamma, pixel formats | [`raster`] | error |
//! | the error type | [`error`] | |
//! | number helpers of the per-frame loops | [`num`] | |
//! | the browser boundary (wasm32 only) | `wasm` | calib, cloud, error, filter, io, pattern, raster, scan, sim |
//!
//! Everything except `wasm` is plain Rust with no knowledge of the browser; the
//! `wasm` module is the one thin boundary the web page talks to.
#![deny(missing_docs)]

pub mod pattern;
pub mod filter;
pub mod segment;
pub mod align;
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
pub mod num;

#[cfg(target_arch = "wasm32")]
pub mod wasm;

pub use calib::Calibration;
pub use error::Error;
pub use pattern::PatternSpec;
pub use raster::Image;
