//! The one thin boundary between the browser and the pipeline.
//!
//! Everything here converts: JSON text and typed arrays in, typed arrays and JSON text
//! out, and [`crate::Error`] into a JS `Error` whose message is the error's one-line
//! `Display`. No pipeline logic lives here and no core type carries a wasm attribute.
//! The page's web worker (`www/worker.js`) is the only caller; its message protocol is
//! documented there.
//!
//! Images cross the boundary as interleaved RGBA bytes (what a canvas `ImageData`
//! holds); clouds as the scanner's own flat arrays ([`crate::cloud::Cloud`]), one entry
//! per point: positions `x, y, z` (mm, camera frame), colours `r, g, b`, camera pixels
//! `u, v` and family bit masks. Each result array is copied exactly once, from the
//! scanner's buffers into a new JavaScript typed array the worker then transfers.

use crate::calib::{crosstalk_from_values, parse_crosstalk, ApproxRig, Calibration, CameraResponse, IDENTITY_CROSSTALK};
use crate::cloud::{encode_ply, Cloud};
use crate::error::Error;
use crate::filter::FilterMode;
use crate::io;
use crate::pattern::{PatternSpec, DEFAULT_STRIPE_WIDTH};
use crate::raster::{to_rgba8, Image};
use crate::scan::{ScanConfig, Scanner};
use crate::sim;
use js_sys::{Float32Array, Object, Reflect, Uint8Array};

#[wasm_bindgen]
extern "C" {
    /// The stage clock: `performance.now()`, milliseconds with a fraction, on the
    /// global scope of a page, a worker and Node alike (`Date.now()` counts whole
    /// milliseconds, too coarse for stages of a few).
    #[wasm_bindgen(js_namespace = performance, js_name = now)]
    fn performance_now() -> f64;
}
use wasm_bindgen::prelude::*;

/// Runs once when the module is instantiated: panics are printed to the console with
/// their message and location before they surface as a `RuntimeError`.
#[wasm_bindgen(start)]
fn start() {
    console_error_panic_hook::set_once();
}

/// The `threads` build only (`pkg-threads/`): `initThreadPool(n)` starts a pool of `n`
/// web workers sharing this module's memory, on which the stages that run at once
/// natively then run at once here too. The worker awaits it once, after loading.
#[cfg(feature = "threads")]
pub use wasm_bindgen_rayon::init_thread_pool;

/// How many threads a scan's stages may run on: the pool's size in the `threads`
/// build once it has started, otherwise 1.
#[wasm_bindgen(js_name = threadCount)]
pub fn thread_count() -> usize {
    #[cfg(feature = "threads")]
    return rayon::current_num_threads();
    #[cfg(not(feature = "threads"))]
    return 1;
}

fn js_error(e: Error) -> JsError {
    JsError::new(&e.to_string())
}

fn parse_filter(name: &str) -> Result<FilterMode, JsError> {
    name.parse().map_err(js_error)
}

/// An 8-bit RGBA image (row-major, 4 bytes a pixel, alpha 255).
#[wasm_bindgen(js_name = RgbaImage)]
pub struct RgbaImage {
    width: u32,
    height: u32,
    data: Vec<u8>,
}

impl RgbaImage {
    fn from_rgb(img: &Image<[u8; 3]>) -> Self {
        RgbaImage { width: img.width() as u32, height: img.height() as u32, data: to_rgba8(img) }
    }
}

#[wasm_bindgen(js_class = RgbaImage)]
impl RgbaImage {
    /// Width in pixels.
    #[wasm_bindgen(getter)]
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    #[wasm_bindgen(getter)]
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The pixels, copied into a new JS array (transferable).
    pub fn rgba(&self) -> Uint8Array {
        Uint8Array::from(&self.data[..])
    }
}

/// The spec JSON of a new pattern with `directions` stripe families (1, 2 or 3) for a
/// `width` x `height` projector, with the default stripe width.
#[wasm_bindgen(js_name = generatePattern)]
pub fn generate_pattern(directions: u32, width: u32, height: u32) -> Result<String, JsError> {
    let spec = PatternSpec::generate(directions as usize, width, height, DEFAULT_STRIPE_WIDTH).map_err(js_error)?;
    Ok(spec.to_json())
}

/// Validate a pattern spec; returns it re-serialized (canonical form).
#[wasm_bindgen(js_name = parseSpec)]
pub fn parse_spec(spec_json: &str) -> Result<String, JsError> {
    Ok(PatternSpec::from_json(spec_json).map_err(js_error)?.to_json())
}

/// The pixels the projector shows for a spec, at the spec's resolution.
#[wasm_bindgen(js_name = renderPattern)]
pub fn render_pattern(spec_json: &str) -> Result<RgbaImage, JsError> {
    let spec = PatternSpec::from_json(spec_json).map_err(js_error)?;
    Ok(RgbaImage::from_rgb(&spec.render_rgb8()))
}

/// The calibration JSON of the default demo rig (VGA camera, XGA projector, 200 mm
/// diagonal baseline, aimed at 750 mm).
#[wasm_bindgen(js_name = defaultCalibration)]
pub fn default_calibration() -> String {
    Calibration::demo().to_json()
}

/// Validate a calibration file; returns it re-serialized. Errors name the field.
#[wasm_bindgen(js_name = parseCalibration)]
pub fn parse_calibration(calib_json: &str) -> Result<String, JsError> {
    Ok(Calibration::from_json(calib_json).map_err(js_error)?.to_json())
}

/// A usable calibration JSON from an approximate rig, given as JSON with the fields of
/// `ApproxRig`: `camera_width`, `camera_height`, `camera_hfov_deg`, `projector_width`,
/// `projector_height`, `projector_hfov_deg`, `baseline_mm` (`[x, y, z]`, the
/// projector's centre in camera coordinates) and `aim_distance_mm`.
#[wasm_bindgen(js_name = calibrationFromRig)]
pub fn calibration_from_rig(rig_json: &str) -> Result<String, JsError> {
    let de = &mut serde_json::Deserializer::from_str(rig_json);
    let rig: ApproxRig = serde_path_to_error::deserialize(de).map_err(|e| {
        let path = e.path().to_string();
        let field = if path == "." { "(rig)".to_string() } else { path };
        js_error(Error::Calib { field, problem: e.into_inner().to_string() })
    })?;
    Ok(Calibration::from_approx_rig(&rig).map_err(js_error)?.to_json())
}

/// Names of the simulator's built-in scenes.
#[wasm_bindgen(js_name = sceneNames)]
pub fn scene_names() -> Vec<String> {
    sim::Scene::NAMES.iter().map(|s| s.to_string()).collect()
}

/// The camera frame the simulator renders for a built-in scene lit by the spec's
/// pattern on the calibrated rig (camera-sized RGBA).
#[wasm_bindgen(js_name = renderScene)]
pub fn render_scene(name: &str, spec_json: &str, calib_json: &str, seed: u32) -> Result<RgbaImage, JsError> {
    let spec = PatternSpec::from_json(spec_json).map_err(js_error)?;
    let calib = Calibration::from_json(calib_json).map_err(js_error)?;
    let scene = sim::Scene::builtin(name).map_err(js_error)?;
    let config = sim::SimConfig {
        seed: seed as u64,
        projector_gamma: spec.encoding_gamma as f32,
        ..Default::default()
    };
    let frame = sim::render(&scene, &calib, &spec.render_rgb8(), &config).map_err(js_error)?;
    Ok(RgbaImage::from_rgb(&frame.image))
}

/// The colour mixing of the simulator's camera (9 numbers, row-major): scanning its
/// frames with it is what a measured colour calibration of a real rig gives.
#[wasm_bindgen(js_name = simulatorCrosstalk)]
pub fn simulator_crosstalk() -> Vec<f32> {
    sim::SimConfig::default().crosstalk.iter().flatten().copied().collect()
}

/// The camera's colour mixing (9 numbers, row-major) from four RGBA frames of a white
/// card under the projector's full red, green, blue and black, the codes read through
/// the power law of `camera_gamma`, or through `response` (256 linear values, one per
/// code) where one is given.
#[wasm_bindgen(js_name = estimateCrosstalk)]
#[allow(clippy::too_many_arguments)]
pub fn estimate_crosstalk(
    red: &[u8],
    green: &[u8],
    blue: &[u8],
    black: &[u8],
    width: u32,
    height: u32,
    camera_gamma: f32,
    response: Option<Vec<f32>>,
) -> Result<Vec<f32>, JsError> {
    let frame = |rgba: &[u8]| rgb_frame(width, height, rgba);
    let (r, g, b, k) = (frame(red)?, frame(green)?, frame(blue)?, frame(black)?);
    let response = response.map(|table| CameraResponse::from_table(&table)).transpose().map_err(js_error)?;
    let m = crate::calib::estimate_crosstalk_for([&r, &g, &b], &k, camera_gamma, response.as_ref()).map_err(js_error)?;
    Ok(m.iter().flatten().copied().collect())
}

/// The camera's colour mixing (9 numbers, row-major, columns scaled to sum to 1)
/// estimated from one RGBA frame of the pattern on the scene itself, as `stripelight
/// scan --crosstalk frame` does: the frame scanned with no mixing, the mixing read from
/// the stripes identified, the frame scanned again with it, `FRAME_MIXING_ROUNDS`
/// times (see [`Scanner::scan_estimating_crosstalk`]). For a rig whose white-card
/// frames were never taken. `filter` and `response` as for [`WasmScanner::new`]. Fails,
/// naming the problem, where the first scan identifies too little to estimate from.
#[wasm_bindgen(js_name = estimateCrosstalkFromFrame)]
#[allow(clippy::too_many_arguments)]
pub fn estimate_crosstalk_from_frame(
    spec_json: &str,
    calib_json: &str,
    filter: &str,
    response: Option<Vec<f32>>,
    rgba: &[u8],
    width: u32,
    height: u32,
) -> Result<Vec<f32>, JsError> {
    let spec = PatternSpec::from_json(spec_json).map_err(js_error)?;
    let calib = Calibration::from_json(calib_json).map_err(js_error)?;
    let response = response.map(|table| CameraResponse::from_table(&table)).transpose().map_err(js_error)?;
    let config = ScanConfig { filter: parse_filter(filter)?, response, ..ScanConfig::default() };
    let mut scanner = Scanner::new(spec, calib, config).map_err(js_error)?;
    let frame = rgb_frame(width, height, rgba)?;
    let (estimates, stopped) = scanner.scan_estimating_crosstalk(&frame, crate::scan::FRAME_MIXING_ROUNDS).map_err(js_error)?;
    match (estimates.last(), stopped) {
        (Some(m), _) => Ok(m.crosstalk.iter().flatten().copied().collect()),
        (None, Some(e)) => Err(js_error(e)),
        (None, None) => Err(js_error(Error::Internal("no round of the colour mixing's estimate ran".into()))),
    }
}

/// An RGBA frame of `width` x `height` as the pipeline's RGB image (its size checked).
fn rgb_frame(width: u32, height: u32, rgba: &[u8]) -> Result<Image<[u8; 3]>, JsError> {
    crate::raster::from_rgba8(width as usize, height as usize, rgba).map_err(js_error)
}

/// The camera's response (256 linear values, one per 8-bit code) from three RGBA frames
/// of a white card at the scanning exposure, under the projector's full white, grey
/// `grey_level` and black (`stripelight response`).
#[wasm_bindgen(js_name = estimateResponse)]
#[allow(clippy::too_many_arguments)]
pub fn estimate_response(
    white: &[u8],
    grey: &[u8],
    black: &[u8],
    width: u32,
    height: u32,
    grey_level: u8,
    camera_gamma: f32,
    projector_gamma: f32,
) -> Result<Vec<f32>, JsError> {
    let frame = |rgba: &[u8]| rgb_frame(width, height, rgba);
    let (white, grey, black) = (frame(white)?, frame(grey)?, frame(black)?);
    let response = crate::calib::estimate_response(&white, &grey, &black, grey_level, camera_gamma, projector_gamma)
        .map_err(js_error)?;
    Ok(response.linear().to_vec())
}

/// A camera response file as `stripelight response` writes it (`{"linear": [...]}`),
/// checked; returns its 256 values.
#[wasm_bindgen(js_name = parseResponse)]
pub fn parse_response(text: &str) -> Result<Vec<f32>, JsError> {
    Ok(CameraResponse::from_json(text).map_err(js_error)?.linear().to_vec())
}

/// A camera response (256 values) in its file form, checked.
#[wasm_bindgen(js_name = responseJson)]
pub fn response_json(table: &[f32]) -> Result<String, JsError> {
    Ok(CameraResponse::from_table(table).map_err(js_error)?.to_json())
}

/// The largest share of a code's light by which a camera response (256 values) differs
/// from the power law of `camera_gamma`.
#[wasm_bindgen(js_name = responseDeparture)]
pub fn response_departure(table: &[f32], camera_gamma: f32) -> Result<f32, JsError> {
    Ok(CameraResponse::from_table(table).map_err(js_error)?.departure(camera_gamma))
}

/// The departure from the power law below which a measured response is read as the
/// power law ([`crate::calib::response::POWER_LAW_TOLERANCE`]).
#[wasm_bindgen(js_name = powerLawTolerance)]
pub fn power_law_tolerance() -> f32 {
    crate::calib::response::POWER_LAW_TOLERANCE
}

/// The 8-bit camera value from which a channel counts as clipped (the page's exposure
/// meter uses the decoder's level).
#[wasm_bindgen(js_name = saturationLevel)]
pub fn saturation_level() -> u8 {
    crate::raster::SATURATED
}

/// The camera's colour mixing typed by a person: 9 numbers, row by row, separated by
/// commas, semicolons or white space; returns them, checked (finite, invertible).
#[wasm_bindgen(js_name = parseCrosstalk)]
pub fn parse_crosstalk_js(text: &str) -> Result<Vec<f32>, JsError> {
    Ok(parse_crosstalk(text).map_err(js_error)?.iter().flatten().copied().collect())
}

/// Decode PNG or JPEG bytes to RGBA (no colour management: the values as stored).
#[wasm_bindgen(js_name = decodeImage)]
pub fn decode_image(bytes: &[u8]) -> Result<RgbaImage, JsError> {
    Ok(RgbaImage::from_rgb(&io::decode_rgb8(bytes).map_err(js_error)?))
}

/// A cloud as a plain JS object `{positions, colors, pixels, families}` of new typed
/// arrays (one copy each, transferable).
fn cloud_to_js(cloud: &Cloud) -> Result<Object, JsError> {
    let obj = Object::new();
    let set = |key: &str, value: &JsValue| {
        Reflect::set(&obj, &JsValue::from_str(key), value).map_err(|_| JsError::new("could not build the cloud object"))
    };
    set("positions", &Float32Array::from(&cloud.positions[..]).into())?;
    set("colors", &Uint8Array::from(&cloud.colors[..]).into())?;
    set("pixels", &Float32Array::from(&cloud.pixels[..]).into())?;
    set("families", &Uint8Array::from(&cloud.families[..]).into())?;
    Ok(obj)
}

/// One intermediate image of the last scan, for the teaching view.
#[wasm_bindgen(js_name = StageImage)]
pub struct StageImage {
    name: String,
    caption: String,
    image: RgbaImage,
}

#[wasm_bindgen(js_class = StageImage)]
impl StageImage {
    /// Short name, e.g. `restored-0`.
    #[wasm_bindgen(getter)]
    pub fn name(&self) -> String {
        self.name.clone()
    }

    /// One sentence saying what the image shows.
    #[wasm_bindgen(getter)]
    pub fn caption(&self) -> String {
        self.caption.clone()
    }

    /// Width in pixels.
    #[wasm_bindgen(getter)]
    pub fn width(&self) -> u32 {
        self.image.width
    }

    /// Height in pixels.
    #[wasm_bindgen(getter)]
    pub fn height(&self) -> u32 {
        self.image.height
    }

    /// The pixels as RGBA.
    pub fn rgba(&self) -> Uint8Array {
        self.image.rgba()
    }
}

/// A long-lived scanner for one (pattern spec, calibration) pair; frames must have the
/// calibration's camera size.
#[wasm_bindgen(js_name = Scanner)]
pub struct WasmScanner {
    inner: Scanner,
}

#[wasm_bindgen(js_class = Scanner)]
impl WasmScanner {
    /// A scanner for a spec and calibration (JSON texts) with a filter
    /// (`direct`, `loggrad` or `loggrad-norot`) and the camera's colour mixing
    /// (`crosstalk`: 9 numbers, row-major, row = camera channel; `undefined` for none)
    /// and the camera's response (`response`: 256 linear values, one per 8-bit code, as
    /// `estimateResponse` gives; `undefined` for the power law). Errors say which input
    /// is wrong.
    #[wasm_bindgen(constructor)]
    pub fn new(
        spec_json: &str,
        calib_json: &str,
        filter: &str,
        crosstalk: Option<Vec<f32>>,
        response: Option<Vec<f32>>,
    ) -> Result<WasmScanner, JsError> {
        let spec = PatternSpec::from_json(spec_json).map_err(js_error)?;
        let calib = Calibration::from_json(calib_json).map_err(js_error)?;
        let crosstalk = match crosstalk {
            None => IDENTITY_CROSSTALK,
            Some(m) => crosstalk_from_values(&m).map_err(js_error)?,
        };
        let response = response.map(|table| CameraResponse::from_table(&table)).transpose().map_err(js_error)?;
        let config = ScanConfig {
            filter: parse_filter(filter)?,
            crosstalk,
            response,
            clock: Some(performance_now),
            ..ScanConfig::default()
        };
        Ok(WasmScanner { inner: Scanner::new(spec, calib, config).map_err(js_error)? })
    }

    /// Frame width the scanner takes (the calibration's camera width).
    #[wasm_bindgen(getter)]
    pub fn width(&self) -> u32 {
        self.inner.size().0 as u32
    }

    /// Frame height the scanner takes.
    #[wasm_bindgen(getter)]
    pub fn height(&self) -> u32 {
        self.inner.size().1 as u32
    }

    /// Change the filter for the following scans.
    #[wasm_bindgen(js_name = setFilter)]
    pub fn set_filter(&mut self, filter: &str) -> Result<(), JsError> {
        self.inner.set_filter(parse_filter(filter)?);
        Ok(())
    }

    /// Scan one frame given as RGBA bytes (a canvas `ImageData`'s `data`); returns the
    /// scan's figures (`ScanStats`) as JSON. The clouds and depth stay in the scanner
    /// until the next frame: take them with [`WasmScanner::cloud`] and
    /// [`WasmScanner::depth`].
    pub fn scan(&mut self, rgba: &[u8], width: u32, height: u32) -> Result<String, JsError> {
        let result = self.inner.scan_rgba(width as usize, height as usize, rgba).map_err(js_error)?;
        // Plain numbers and strings always serialize.
        Ok(serde_json::to_string(&result.stats).unwrap_or_default())
    }

    /// Number of stripe families (each has its own cloud).
    #[wasm_bindgen(getter, js_name = familyCount)]
    pub fn family_count(&self) -> u32 {
        self.inner.spec().families.len() as u32
    }

    /// A cloud of the last scan as `{positions, colors, pixels, families}`: the merged
    /// cloud when `family` is `undefined`, family `family`'s own cloud otherwise.
    pub fn cloud(&self, family: Option<u32>) -> Result<Object, JsError> {
        let cloud = self.inner.layer(family.map(|k| k as usize)).map_err(js_error)?;
        cloud_to_js(&cloud)
    }

    /// The merged depth of the last scan, Z in mm per camera pixel, row-major; NaN
    /// where none.
    pub fn depth(&self) -> Float32Array {
        Float32Array::from(self.inner.result().depth.pixels())
    }

    /// The correspondences of the last scan: per camera pixel (row-major), three values,
    /// value k = family k's projector coordinate along its normal (the spec's `s`,
    /// projector pixels); NaN where none or where the pattern has no family k.
    pub fn correspondence(&self) -> Float32Array {
        Float32Array::from(self.inner.result().correspondence().pixels().as_flattened())
    }

    /// The intermediate images of the last scan (empty before the first).
    pub fn stages(&self) -> Vec<StageImage> {
        self.inner
            .stages()
            .into_iter()
            .map(|s| StageImage { name: s.name, caption: s.caption, image: RgbaImage::from_rgb(&s.image) })
            .collect()
    }
}

/// Encode a cloud given as flat arrays (see the module docs) as PLY per
/// `conventions.md`; binary little-endian unless `ascii`.
#[wasm_bindgen(js_name = encodePly)]
pub fn encode_ply_js(
    positions: &[f32],
    colors: &[u8],
    pixels: &[f32],
    families: &[u8],
    ascii: bool,
) -> Result<Vec<u8>, JsError> {
    let cloud = Cloud::from_parts(positions.to_vec(), colors.to_vec(), pixels.to_vec(), families.to_vec()).map_err(js_error)?;
    Ok(encode_ply(&cloud, ascii))
}

/// Encode a depth map (row-major, Z in mm, NaN where none) as PFM per `conventions.md`.
#[wasm_bindgen(js_name = encodePfm)]
pub fn encode_pfm_js(depth: &[f32], width: u32, height: u32) -> Result<Vec<u8>, JsError> {
    let img = Image::from_vec(width as usize, height as usize, depth.to_vec()).map_err(js_error)?;
    Ok(io::encode_pfm(&img))
}

/// Encode correspondences (row-major, three values per pixel, as
/// `Scanner.correspondence` gives them) as a colour PFM (`PF`) per `conventions.md`.
#[wasm_bindgen(js_name = encodePfmRgb)]
pub fn encode_pfm_rgb_js(values: &[f32], width: u32, height: u32) -> Result<Vec<u8>, JsError> {
    let (w, h) = (width as usize, height as usize);
    if values.len() != w * h * 3 {
        return Err(js_error(Error::BufferLength { size: (w, h), per_pixel: 3, got: values.len() }));
    }
    let pixels = values.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    let img = Image::from_vec(w, h, pixels).map_err(js_error)?;
    Ok(io::encode_pfm_rgb(&img))
}

/// Panics on purpose, so that the page's recovery from a panicking worker can be
/// tested end to end. Nothing else calls it. With `in_pool`, in the `threads` build,
/// the panic happens on a thread of the pool, which stops there: the worker then waits
/// for the pool's answer for ever, and the page has to see that it hangs.
#[wasm_bindgen(js_name = panicForTest)]
pub fn panic_for_test(in_pool: bool) {
    #[cfg(feature = "threads")]
    if in_pool {
        rayon::join(|| (), || panic!("deliberate panic on a thread of the pool, requested by the page's self-test"));
    }
    #[cfg(not(feature = "threads"))]
    let _ = in_pool;
    panic!("deliberate panic requested by the page's self-test");
}
