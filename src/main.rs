//! The `stripelight` command line (native only). Forms and meanings are contracts
//! (`conventions.md`): exit 0 on success, non-zero with a one-line reason on stderr
//! for bad input.

#[cfg(target_arch = "wasm32")]
fn main() {}

#[cfg(not(target_arch = "wasm32"))]
fn main() {
    std::process::exit(cli::run());
}

#[cfg(not(target_arch = "wasm32"))]
mod cli {
    use clap::{Parser, Subcommand};
    use std::path::{Path, PathBuf};
    use stripelight::error::Result;
    use stripelight::filter::FilterMode;
    use stripelight::scan::{ScanConfig, Scanner};
    use stripelight::{io, Calibration, Error, PatternSpec};

    #[derive(Parser)]
    #[command(name = "stripelight", version, about = "One-shot colour-stripe structured light")]
    struct Cli {
        #[command(subcommand)]
        command: Command,
    }

    #[derive(Subcommand)]
    enum Command {
        /// Write a stripe pattern image and the spec file that describes it, or read a
        /// spec from another system's pattern image (`pattern import`).
        #[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
        Pattern {
            #[command(subcommand)]
            action: Option<PatternAction>,
            /// Number of stripe directions: 1, 2 or 3.
            #[arg(long, required = true)]
            directions: Option<usize>,
            /// Projector width in pixels.
            #[arg(long, default_value_t = 1024)]
            width: u32,
            /// Projector height in pixels.
            #[arg(long, default_value_t = 768)]
            height: u32,
            /// Stripe width in projector pixels.
            #[arg(long, default_value_t = stripelight::pattern::DEFAULT_STRIPE_WIDTH)]
            stripe_width: f64,
            /// The pattern image (PNG).
            #[arg(long, required = true)]
            out: Option<PathBuf>,
            /// The pattern spec (JSON).
            #[arg(long, required = true)]
            spec: Option<PathBuf>,
        },
        /// Decode a camera frame into a depth map and a point cloud.
        Scan {
            /// The pattern spec (JSON) the projector showed.
            #[arg(long)]
            spec: PathBuf,
            /// The calibration (JSON).
            #[arg(long)]
            calib: PathBuf,
            /// The camera frame (PNG or JPEG), the calibration's camera size.
            #[arg(long)]
            image: PathBuf,
            /// direct, loggrad or loggrad-norot.
            #[arg(long, default_value = "loggrad")]
            filter: String,
            /// The camera's encoding gamma (8-bit value = 255 · linear^(1/gamma)).
            #[arg(long, default_value_t = 2.2)]
            camera_gamma: f32,
            /// Depth map out (PFM, Z in mm, NaN where none).
            #[arg(long)]
            depth: Option<PathBuf>,
            /// Correspondences out (colour PFM: channel k = family k's projector
            /// coordinate along its normal, the spec's `s`, in projector pixels; NaN
            /// where none or where the pattern has no family k).
            #[arg(long)]
            correspondence: Option<PathBuf>,
            /// Point cloud out (PLY).
            #[arg(long)]
            ply: Option<PathBuf>,
            /// Write the PLY as ASCII instead of binary.
            #[arg(long)]
            ascii: bool,
            /// Write every stage as a PNG into this folder (made if missing).
            #[arg(long)]
            debug: Option<PathBuf>,
            /// The camera's colour mixing, 9 numbers row by row (camera channel =
            /// row · projector primaries); `sim` for the simulator's default; `frame` to
            /// estimate it from the frame itself (scanned with none, the mixing
            /// estimated from the stripes identified, scanned again, twice over).
            #[arg(long)]
            crosstalk: Option<String>,
            /// The camera's measured response (JSON from `stripelight response`): the
            /// frame's codes are read through it instead of --camera-gamma's power law.
            #[arg(long)]
            response: Option<PathBuf>,
            /// The scale the frame is decoded at: `auto` (reduced by an integer factor
            /// where a projector pixel covers 3 or more camera pixels, as in large
            /// photographs; never below VGA), `full`, or a factor from 1 to 16. The
            /// outputs keep the frame's size either way.
            #[arg(long, default_value = "auto")]
            decode_scale: String,
        },
        /// Render built-in scenes, scan them and print the accuracy table (Markdown).
        Eval {
            /// Scenes to evaluate (default: the original five; with --hard, all
            /// built-in scenes).
            #[arg(long, value_delimiter = ',')]
            scenes: Vec<String>,
            /// Numbers of directions (default 1,2,3).
            #[arg(long, value_delimiter = ',', default_values_t = [1usize, 2, 3])]
            directions: Vec<usize>,
            /// Filters (default direct,loggrad).
            #[arg(long, value_delimiter = ',', default_values_t = [String::from("direct"), String::from("loggrad")])]
            filters: Vec<String>,
            /// Noise seed of the simulator.
            #[arg(long, default_value_t = 1)]
            seed: u64,
            /// The hard evaluation instead (issue 10): every scene under every
            /// condition, two directions, loggrad, measured colour mixing, beside a
            /// Gray-code reference; prints the whole of docs/accuracy.md.
            #[arg(long)]
            hard: bool,
            /// With --hard: the conditions (default all: default, partial, clipped,
            /// webcam, narrow, wide, soft, shoulder, 8mp, world).
            #[arg(long, value_delimiter = ',')]
            conditions: Vec<String>,
        },
        /// Measure the camera's colour mixing (for `scan --crosstalk`) from frames of a
        /// white card under the projector's full red, green, blue and black.
        Crosstalk {
            /// Frame under full red.
            #[arg(long)]
            red: PathBuf,
            /// Frame under full green.
            #[arg(long)]
            green: PathBuf,
            /// Frame under full blue.
            #[arg(long)]
            blue: PathBuf,
            /// Frame under black (ambient light and the projector's black level).
            #[arg(long)]
            black: PathBuf,
            /// The camera's encoding gamma.
            #[arg(long, default_value_t = 2.2)]
            camera_gamma: f32,
            /// The camera's measured response (JSON from `stripelight response`), read
            /// instead of --camera-gamma's power law.
            #[arg(long)]
            response: Option<PathBuf>,
        },
        /// Measure the camera's response (for `scan --response`; a tone curve's
        /// highlight shoulder) from frames of a white card under the projector's full
        /// white, a grey level and black, all at the exposure the scans will use, with
        /// the card's brightest part just clipping under white. Prints JSON.
        Response {
            /// Frame under full white.
            #[arg(long)]
            white: PathBuf,
            /// Frame under the grey level --grey-level.
            #[arg(long)]
            grey: PathBuf,
            /// Frame under black.
            #[arg(long)]
            black: PathBuf,
            /// The projector's grey level of the --grey frame (8-bit).
            #[arg(long, default_value_t = stripelight::calib::response::DEFAULT_GREY_LEVEL)]
            grey_level: u8,
            /// The camera's encoding gamma, which the codes up to 200 follow.
            #[arg(long, default_value_t = 2.2)]
            camera_gamma: f32,
            /// The projector's gamma (the pattern spec's `encoding_gamma`).
            #[arg(long, default_value_t = 2.2)]
            projector_gamma: f32,
        },
        /// Write a calibration file: the demo rig (--default, --distorted), or one
        /// imported from another tool (`calib import`).
        #[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
        Calib {
            #[command(subcommand)]
            action: Option<CalibAction>,
            /// The demo rig (VGA camera, XGA projector, 200 mm diagonal baseline).
            #[arg(long)]
            default: bool,
            /// The demo rig with lens distortion on both devices.
            #[arg(long)]
            distorted: bool,
            /// The calibration (JSON).
            #[arg(long, required = true)]
            out: Option<PathBuf>,
        },
        /// Simulate the camera frame of a built-in scene lit by a pattern, with its
        /// ground-truth depth.
        Render {
            /// A built-in scene: plane, sphere, paper, textured, occluders, colorchecker,
            /// sphere-dye, paper-dye, bag, skin, wood or wall.
            #[arg(long)]
            scene: String,
            /// The pattern spec (JSON) the projector shows.
            #[arg(long)]
            spec: PathBuf,
            /// The calibration (JSON); its projector must have the pattern's size.
            #[arg(long)]
            calib: PathBuf,
            /// The simulated camera frame (PNG).
            #[arg(long)]
            out: PathBuf,
            /// Ground-truth depth out (PFM, Z in mm, NaN where no surface).
            #[arg(long)]
            depth: Option<PathBuf>,
            /// Seed of the sensor noise.
            #[arg(long, default_value_t = 0)]
            seed: u64,
        },
    }

    #[derive(Subcommand)]
    enum PatternAction {
        /// Read the image a projector shows (another system's colour-stripe pattern)
        /// into a spec: its stripe runs, their colours, margins and the window that
        /// makes them unique.
        ///
        /// The image holds one family of stripes (every row the same for --axis
        /// columns, every column for rows). It is placed on the projector at --offset
        /// (the projector pixel of the image's top-left pixel) and --scale (projector
        /// pixels per image pixel); the projector is the placed image's size unless
        /// given.
        Import {
            /// The pattern image (PNG or JPEG; PNG keeps its colours exact).
            #[arg(long)]
            image: PathBuf,
            /// The spec (JSON) to write.
            #[arg(long)]
            out: PathBuf,
            /// columns (vertical stripes) or rows (horizontal stripes).
            #[arg(long, default_value = "columns")]
            axis: String,
            /// Projector width in pixels.
            #[arg(long)]
            projector_width: Option<u32>,
            /// Projector height in pixels.
            #[arg(long)]
            projector_height: Option<u32>,
            /// Projector pixel X,Y of the image's top-left pixel.
            #[arg(long, default_value = "0,0")]
            offset: String,
            /// Projector pixels per image pixel.
            #[arg(long, default_value_t = 1.0)]
            scale: f64,
            /// The image's encoding gamma (pixel value = 255 · linear^(1/gamma)).
            #[arg(long, default_value_t = 2.2)]
            encoding_gamma: f64,
        },
    }

    #[derive(Subcommand)]
    enum CalibAction {
        /// Convert a calibration from OpenCV or Bouguet's MATLAB toolbox into the
        /// project's calibration JSON.
        ///
        /// Reads OpenCV FileStorage YAML or JSON (cam_K/cam_kc/proj_K/proj_kc,
        /// cameraMatrix1/distCoeffs1/cameraMatrix2/distCoeffs2, M1/D1/M2/D2, K1/D1/K2/D2
        /// with R or om, T and image sizes) and Bouguet's MATLAB stereo text (fc_left,
        /// cc_left, kc_left, alpha_c_left, the same _right, om, T), recognised from the
        /// content. The camera is the first device (cameraMatrix1, left), the projector
        /// the second (right); R, T map camera to projector coordinates, X_p = R X_c + T,
        /// as cv::stereoCalibrate returns them. T must be in mm, or give --unit-scale.
        Import {
            /// The calibration to read.
            #[arg(long)]
            from: PathBuf,
            /// The project's calibration (JSON) to write.
            #[arg(long)]
            out: PathBuf,
            /// Camera image size WxH, when the file gives none.
            #[arg(long, value_name = "WxH")]
            camera_size: Option<String>,
            /// Projector size WxH, when the file gives none.
            #[arg(long, value_name = "WxH")]
            projector_size: Option<String>,
            /// Millimetres per unit of the file's T (1000 when T is in metres).
            #[arg(long, default_value_t = 1.0)]
            unit_scale: f64,
        },
    }

    pub fn run() -> i32 {
        let cli = match Cli::try_parse() {
            Ok(cli) => cli,
            Err(e) => {
                use clap::error::ErrorKind;
                if matches!(e.kind(), ErrorKind::DisplayHelp | ErrorKind::DisplayVersion | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand) {
                    let _ = e.print();
                    return if e.kind() == ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand { 2 } else { 0 };
                }
                // One line: clap's first line without its "error: " prefix.
                let text = e.render().to_string();
                let first = text.lines().next().unwrap_or("bad arguments");
                eprintln!("stripelight: {}", first.trim_start_matches("error: "));
                return 2;
            }
        };
        match dispatch(cli.command) {
            Ok(()) => 0,
            Err(e) => {
                eprintln!("stripelight: {e}");
                1
            }
        }
    }

    fn read_text(path: &Path) -> Result<String> {
        std::fs::read_to_string(path).map_err(|e| Error::io(path, e))
    }

    /// Read and validate a calibration file.
    pub fn load_calib(path: &Path) -> Result<Calibration> {
        Calibration::from_json(&read_text(path)?).map_err(|e| prefix(path, e))
    }

    /// Read and validate a camera response file (`stripelight response`).
    pub fn load_response(path: &Path) -> Result<stripelight::calib::CameraResponse> {
        stripelight::calib::CameraResponse::from_json(&read_text(path)?).map_err(|e| prefix(path, e))
    }

    /// Read and validate a pattern spec file.
    pub fn load_spec(path: &Path) -> Result<PatternSpec> {
        PatternSpec::from_json(&read_text(path)?).map_err(|e| prefix(path, e))
    }

    fn prefix(path: &Path, e: Error) -> Error {
        e.in_file(path)
    }

    fn dispatch(command: Command) -> Result<()> {
        match command {
            Command::Pattern { action: Some(PatternAction::Import { image, out, axis, projector_width, projector_height, offset, scale, encoding_gamma }), .. } => {
                use stripelight::pattern::import::{import_image, Placement};
                let projector = match (projector_width, projector_height) {
                    (Some(w), Some(h)) => Some((w, h)),
                    (None, None) => None,
                    _ => return Err(Error::Setting { name: "projector size", problem: "give both --projector-width and --projector-height, or neither".into() }),
                };
                let offset = match offset.split(',').map(|t| t.trim().parse::<f64>()).collect::<std::result::Result<Vec<_>, _>>() {
                    Ok(v) if v.len() == 2 => (v[0], v[1]),
                    _ => return Err(Error::Setting { name: "offset", problem: format!("must be X,Y (two numbers), got {offset:?}") }),
                };
                let place = Placement { axis: axis.parse()?, projector, offset, scale, encoding_gamma };
                let picture = io::read_rgb8(&image)?;
                let (spec, report) = import_image(&picture, &place).map_err(|e| prefix(&image, e))?;
                io::write_file(&out, spec.to_json().as_bytes())?;
                eprintln!("{report}: {}", out.display());
                Ok(())
            }
            Command::Pattern { directions, width, height, stripe_width, out, spec, .. } => {
                let (Some(directions), Some(out), Some(spec)) = (directions, out, spec) else {
                    return Err(Error::Setting { name: "pattern", problem: "needs --directions, --out and --spec".into() });
                };
                let pattern = PatternSpec::generate(directions, width, height, stripe_width)?;
                io::write_file(&spec, pattern.to_json().as_bytes())?;
                io::write_file(&out, &io::encode_png(&pattern.render_rgb8())?)?;
                eprintln!(
                    "{} direction(s), {} stripes of {} px, window {}: {}",
                    directions,
                    pattern.families.iter().map(|f| f.count).max().unwrap_or(0),
                    stripe_width,
                    pattern.window,
                    out.display()
                );
                Ok(())
            }
            Command::Scan { spec, calib, image, filter, camera_gamma, depth, correspondence, ply, ascii, debug, crosstalk, response, decode_scale } => {
                let spec = load_spec(&spec)?;
                let calib = load_calib(&calib)?;
                let filter: FilterMode = filter.parse()?;
                let frame = io::read_rgb8(&image)?;
                let from_frame = crosstalk.as_deref() == Some("frame");
                let crosstalk = match crosstalk.as_deref() {
                    None | Some("frame") => stripelight::calib::IDENTITY_CROSSTALK,
                    Some("sim") => stripelight::sim::SimConfig::default().crosstalk,
                    Some(text) => stripelight::calib::parse_crosstalk(text)?,
                };
                let response = response.as_deref().map(load_response).transpose()?;
                let decode_scale = decode_scale.parse()?;
                let config = ScanConfig { filter, camera_gamma, crosstalk, response, decode_scale, ..ScanConfig::default() };
                let mut scanner = Scanner::new(spec, calib, config)?;
                if from_frame {
                    let (estimates, stopped) = scanner.scan_estimating_crosstalk(&frame, stripelight::scan::FRAME_MIXING_ROUNDS).map_err(|e| prefix(&image, e))?;
                    for (round, m) in estimates.iter().enumerate() {
                        let values: Vec<String> = m.crosstalk.iter().flatten().map(|x| format!("{x:.4}")).collect();
                        eprintln!(
                            "colour mixing from the frame, round {}: {} ({} pixels inside stripes, {} to {} tiles a primary)",
                            round + 1,
                            values.join(","),
                            m.pixels,
                            m.tiles.iter().min().unwrap_or(&0),
                            m.tiles.iter().max().unwrap_or(&0)
                        );
                    }
                    if let Some(e) = stopped {
                        let kept = if estimates.is_empty() { "no colour mixing".to_string() } else { format!("round {}'s", estimates.len()) };
                        eprintln!("{e}; scanned with {kept}");
                    }
                } else {
                    scanner.scan(&frame).map_err(|e| prefix(&image, e))?;
                }
                let result = scanner.result();
                let stats = &result.stats;
                let families: Vec<String> = stats.decoded.iter().enumerate().map(|(k, n)| format!("family {k}: {n}")).collect();
                let f = stats.decode_factor;
                let scale = if f > 1 { format!(", decoded at 1/{f} scale ({}x{})", stats.width / f, stats.height / f) } else { String::new() };
                eprintln!(
                    "{} points ({}), {} of {} pixels usable, filter {}{scale}",
                    stats.merged,
                    families.join(", "),
                    stats.usable,
                    stats.width * stats.height,
                    stats.filter
                );
                if stats.merged == 0 {
                    eprintln!("nothing decoded: is the pattern in view, in focus and not over- or under-exposed?");
                }
                if filter == FilterMode::Direct && stats.decoded.len() >= 3 {
                    eprintln!("note: with three directions every pixel shows three stripes at once, which direct estimation cannot separate (about a tenth decodes on the simulator): use --filter loggrad");
                }
                if let Some(path) = depth {
                    io::write_file(&path, &io::encode_pfm(&result.depth))?;
                }
                if let Some(path) = correspondence {
                    io::write_file(&path, &io::encode_pfm_rgb(&result.correspondence()))?;
                }
                if let Some(path) = ply {
                    io::write_file(&path, &stripelight::cloud::encode_ply(&result.cloud, ascii))?;
                }
                if let Some(dir) = debug {
                    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
                    for stage in scanner.stages() {
                        io::write_file(&dir.join(format!("{}.png", stage.name)), &io::encode_png(&stage.image)?)?;
                    }
                }
                Ok(())
            }
            Command::Eval { scenes, directions, filters, seed, hard, conditions } => {
                use stripelight::eval::hard as h;
                use stripelight::sim::Scene;
                if hard {
                    let mut options = h::ReportOptions { seed, ..h::ReportOptions::default() };
                    if !scenes.is_empty() {
                        for s in &scenes {
                            Scene::builtin(s)?;
                        }
                        options.scenes = scenes;
                        options.restrict_heavy = false;
                    }
                    if !conditions.is_empty() {
                        options.conditions = conditions.iter().map(|c| h::condition(c)).collect::<Result<Vec<_>>>()?;
                    }
                    let report = h::report(&options, &mut |line| eprintln!("{line}"))?;
                    print!("{report}");
                    return Ok(());
                }
                if !conditions.is_empty() {
                    return Err(Error::Setting { name: "conditions", problem: "needs --hard".into() });
                }
                let scenes: Vec<String> = if scenes.is_empty() {
                    Scene::NAMES.iter().filter(|s| !Scene::HARD.contains(s)).map(|s| s.to_string()).collect()
                } else {
                    scenes
                };
                let filters = filters.iter().map(|f| f.parse()).collect::<Result<Vec<FilterMode>>>()?;
                let calib = Calibration::demo();
                let mut rows = Vec::new();
                for scene in &scenes {
                    for &n in &directions {
                        for &f in &filters {
                            rows.push(stripelight::eval::evaluate(scene, n, f, &calib, seed)?);
                        }
                    }
                }
                print!("{}", stripelight::eval::markdown(&rows));
                Ok(())
            }
            Command::Crosstalk { red, green, blue, black, camera_gamma, response } => {
                let (r, g, b, k) = (io::read_rgb8(&red)?, io::read_rgb8(&green)?, io::read_rgb8(&blue)?, io::read_rgb8(&black)?);
                let response = response.as_deref().map(load_response).transpose()?;
                let m = stripelight::calib::estimate_crosstalk_for([&r, &g, &b], &k, camera_gamma, response.as_ref())?;
                // The form `scan --crosstalk` takes.
                let values: Vec<String> = m.iter().flatten().map(|v| format!("{v:.4}")).collect();
                println!("{}", values.join(","));
                Ok(())
            }
            Command::Response { white, grey, black, grey_level, camera_gamma, projector_gamma } => {
                let (w, g, k) = (io::read_rgb8(&white)?, io::read_rgb8(&grey)?, io::read_rgb8(&black)?);
                let response = stripelight::calib::estimate_response(&w, &g, &k, grey_level, camera_gamma, projector_gamma)?;
                println!("{}", response.to_json());
                Ok(())
            }
            Command::Calib { action: Some(CalibAction::Import { from, out, camera_size, projector_size, unit_scale }), .. } => {
                use stripelight::calib::import;
                let options = import::ImportOptions {
                    camera_size: camera_size.map(|s| import::parse_size("camera-size", &s)).transpose()?,
                    projector_size: projector_size.map(|s| import::parse_size("projector-size", &s)).transpose()?,
                    unit_scale,
                };
                let imported = import::from_text(&read_text(&from)?, &options).map_err(|e| prefix(&from, e))?;
                io::write_file(&out, imported.calibration.to_json().as_bytes())?;
                eprintln!("{}: {}", out.display(), imported.summary());
                Ok(())
            }
            Command::Calib { action: None, default, distorted, out } => {
                if !default && !distorted {
                    return Err(Error::Setting { name: "calib", problem: "needs --default or --distorted".into() });
                }
                let Some(out) = out else {
                    return Err(Error::Setting { name: "out", problem: "is needed".into() });
                };
                let calib = if distorted { Calibration::demo_distorted() } else { Calibration::demo() };
                io::write_file(&out, calib.to_json().as_bytes())
            }
            Command::Render { scene, spec, calib, out, depth, seed } => {
                use stripelight::sim;
                let scene = sim::Scene::builtin(&scene)?;
                let pattern = load_spec(&spec)?;
                let calib = load_calib(&calib)?;
                let (pw, ph) = (calib.projector.width, calib.projector.height);
                if (pattern.width, pattern.height) != (pw, ph) {
                    return Err(Error::ProjectorMismatch { pattern: (pattern.width, pattern.height), calibration: (pw, ph) });
                }
                let cfg = sim::SimConfig {
                    projector_gamma: pattern.encoding_gamma as f32,
                    seed,
                    ..sim::SimConfig::default()
                };
                let frame = sim::render(&scene, &calib, &pattern.render_rgb8(), &cfg)?;
                io::write_file(&out, &io::encode_png(&frame.image)?)?;
                if let Some(path) = depth {
                    io::write_file(&path, &io::encode_pfm(&frame.depth))?;
                }
                Ok(())
            }
        }
    }
}
