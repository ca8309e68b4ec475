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
        Error::Invalid(format!("{}: {e}", path.display()))
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
            Command::Calib { default, distorted, out } => {
                if !default && !distorted {
                    return Err(Error::Invalid("calib needs --default or --distorted".into()));
                }
                let calib = if distorted { Calibration::demo_distorted() } else { Calibration::demo() };
                io::write_file(&out, calib.to_json().as_bytes())
            }
        }
    }
}
