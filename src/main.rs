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
        /// Write a stripe pattern image and the spec file that describes it.
        Pattern {
            /// Number of stripe directions: 1, 2 or 3.
            #[arg(long)]
            directions: usize,
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
            #[arg(long)]
            out: PathBuf,
            /// The pattern spec (JSON).
            #[arg(long)]
            spec: PathBuf,
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
            /// row · projector primaries); `sim` for the simulator's default.
            #[arg(long)]
            crosstalk: Option<String>,
        },
        /// Render built-in scenes, scan them and print the accuracy table (Markdown).
        Eval {
            /// Scenes to evaluate (default: all built-in scenes).
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
        },
        /// Write a calibration file.
        Calib {
            /// The demo rig (VGA camera, XGA projector, 200 mm diagonal baseline).
            #[arg(long)]
            default: bool,
            /// The demo rig with lens distortion on both devices.
            #[arg(long)]
            distorted: bool,
            /// The calibration (JSON).
            #[arg(long)]
            out: PathBuf,
        },
        /// Simulate the camera frame of a built-in scene lit by a pattern, with its
        /// ground-truth depth.
        Render {
            /// plane, sphere, paper, textured or occluders.
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

    /// Read and validate a pattern spec file.
    pub fn load_spec(path: &Path) -> Result<PatternSpec> {
        PatternSpec::from_json(&read_text(path)?).map_err(|e| prefix(path, e))
    }

    fn prefix(path: &Path, e: Error) -> Error {
        e.in_file(path)
    }

    fn dispatch(command: Command) -> Result<()> {
        match command {
            Command::Pattern { directions, width, height, stripe_width, out, spec } => {
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
            Command::Scan { spec, calib, image, filter, camera_gamma, depth, ply, ascii, debug, crosstalk } => {
                let spec = load_spec(&spec)?;
                let calib = load_calib(&calib)?;
                let filter: FilterMode = filter.parse()?;
                let frame = io::read_rgb8(&image)?;
                let crosstalk = match crosstalk.as_deref() {
                    None => stripelight::calib::IDENTITY_CROSSTALK,
                    Some("sim") => stripelight::sim::SimConfig::default().crosstalk,
                    Some(text) => stripelight::calib::parse_crosstalk(text)?,
                };
                let config = ScanConfig { filter, camera_gamma, crosstalk, ..ScanConfig::default() };
                let mut scanner = Scanner::new(spec, calib, config)?;
                let result = scanner.scan(&frame).map_err(|e| prefix(&image, e))?;
                let stats = &result.stats;
                let families: Vec<String> = stats.decoded.iter().enumerate().map(|(k, n)| format!("family {k}: {n}")).collect();
                eprintln!(
                    "{} points ({}), {} of {} pixels usable, filter {}",
                    stats.merged,
                    families.join(", "),
                    stats.usable,
                    stats.width * stats.height,
                    stats.filter
                );
                if stats.merged == 0 {
                    eprintln!("nothing decoded: is the pattern in view, in focus and not over- or under-exposed?");
                }
                if let Some(path) = depth {
                    io::write_file(&path, &io::encode_pfm(&result.depth))?;
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
            Command::Eval { scenes, directions, filters, seed } => {
                let scenes: Vec<String> = if scenes.is_empty() {
                    stripelight::sim::Scene::NAMES.iter().map(|s| s.to_string()).collect()
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
            Command::Crosstalk { red, green, blue, black, camera_gamma } => {
                let (r, g, b, k) = (io::read_rgb8(&red)?, io::read_rgb8(&green)?, io::read_rgb8(&blue)?, io::read_rgb8(&black)?);
                let m = stripelight::calib::estimate_crosstalk([&r, &g, &b], &k, camera_gamma)?;
                // The form `scan --crosstalk` takes.
                let values: Vec<String> = m.iter().flatten().map(|v| format!("{v:.4}")).collect();
                println!("{}", values.join(","));
                Ok(())
            }
            Command::Calib { default, distorted, out } => {
                if !default && !distorted {
                    return Err(Error::Setting { name: "calib", problem: "needs --default or --distorted".into() });
                }
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
