//! The command line's types (clap): the commands and their arguments.

use crate::bench::BenchPipeline;
use crate::running;
use clap::{Parser, Subcommand};
use std::path::PathBuf;

/// Material Point Method simulations of dynamic fracture and frictional contact.
#[derive(Debug, Parser)]
#[command(name = "fractum", version, about)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run a scene: VTU frames, a ParaView .pvd collection and series.csv in the output folder.
    Run {
        /// Scene file (.ron).
        scene: PathBuf,
        /// Output folder [default: out/SCENE, SCENE being the scene file name without .ron]. A
        /// folder holding a previous run is refused unless --force.
        #[arg(long)]
        out: Option<PathBuf>,
        /// Replace the previous run in the output folder (its series, frames and
        /// checkpoints; other files are left).
        #[arg(long)]
        force: bool,
        /// Threads, steps, progress and checkpoints.
        #[command(flatten)]
        settings: RunArgs,
    },
    /// Continue a run from the newest checkpoint in its output folder, appending to its
    /// outputs. The scene is the one the run began with; a changed scene file or another
    /// build of fractum is refused.
    Resume {
        /// The run's output folder.
        out: PathBuf,
        /// Threads, steps, progress and checkpoints.
        #[command(flatten)]
        settings: RunArgs,
    },
    /// Validate a scene and print a summary of what it would run.
    Check {
        /// Scene file (.ron).
        scene: PathBuf,
        /// Only estimate the memory, from counts: validate the scene, seed its bodies and
        /// install its pipeline on a sample of particles, spawn nothing else, and print the
        /// estimate part by part against what this process may use (its memory limits
        /// included). Exits 2 when it does not fit.
        #[arg(long)]
        estimate: bool,
        /// With `--estimate`: also how the scene's particles would divide over this many ranks
        /// (slabs along the axis they spread furthest on, cut at cell faces to balance them),
        /// and the imbalance.
        #[arg(long, requires = "estimate", value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
        ranks: Option<u32>,
    },
    /// List every registered system with its stage, summary and parameters.
    Systems,
    /// Plot series.csv columns against time into a PNG.
    Plot {
        /// The series.csv of a run, or of several runs to compare on one plot (each curve is
        /// labelled with its run's directory).
        #[arg(required = true)]
        csv: Vec<PathBuf>,
        /// Column for the horizontal axis.
        #[arg(long, default_value = "time")]
        x: String,
        /// Columns to draw.
        #[arg(long, value_delimiter = ',', default_values = ["kinetic_energy", "strain_energy", "total_energy"])]
        columns: Vec<String>,
        /// Also draw the analytic centre-of-mass velocity of a bar's first axial mode, given as
        /// L,E,RHO,V0 (e.g. 25,100,1,0.1 for scenes/bar_vibration.ron).
        #[arg(long)]
        bar: Option<String>,
        /// Output PNG [default: next to the (first) CSV, named after the columns].
        #[arg(long)]
        output: Option<PathBuf>,
    },
    /// Peak of a load curve, the RMS deviation of its rising part from a straight line, and how
    /// far it runs past the peak before the load falls below 5% of it. A curve loaded in the
    /// negative direction (a loader pushing down) reads as its magnitudes.
    Curve {
        /// The series.csv of a run.
        csv: PathBuf,
        /// Column for x (e.g. displacement_top_y).
        #[arg(long)]
        x: String,
        /// Column for y (e.g. reaction_top_y).
        #[arg(long)]
        y: String,
        /// Ignore points with x below this (a start-up ramp).
        #[arg(long, default_value_t = 0.0)]
        from: f64,
    },
    /// Fragments of runs at one time: connected components of intact material, with size and
    /// speed; writes fragments.csv and fragment_sizes.csv into each run's folder and one PNG
    /// of the cumulative size distributions.
    Fragments(FragmentsArgs),
    /// A crack from a notch: its tip against time (crack.csv in the run's folder), initial
    /// angle and speed, beside the Rayleigh speed of the material.
    Crack(CrackArgs),
    /// Run the verification catalogue: every published case, measured and held against its
    /// reference; writes VERIFICATION.md and verification/ (into target/verify/docs, or
    /// --docs docs for the published pages).
    Verify(crate::verify::VerifyArgs),
    /// A picture (PNG) of a frame's particles coloured by a field, with a colour bar, the
    /// bodies' outlines and a scale bar.
    Snapshot(SnapshotArgs),
    /// Measure particle-steps per second of the stock pipelines on a generated scene.
    Bench(BenchArgs),
}

/// The arguments of `fractum fragments`.
#[derive(Debug, clap::Args)]
pub struct FragmentsArgs {
    /// Output folders of runs (several: their distributions on one plot).
    #[arg(required = true)]
    pub out: Vec<PathBuf>,
    /// Time of the frame to analyse (the nearest written) [default: the last frame].
    #[arg(long)]
    pub time: Option<f64>,
    /// Particles with damage below this are intact material.
    #[arg(long, default_value_t = 0.5)]
    pub damage_below: f64,
    /// Link length (m) joining intact particles [default: 1.5 particle spacings].
    #[arg(long)]
    pub link: Option<f64>,
    /// The scene's thickness (m) for 2D runs [default: the one the frames record].
    #[arg(long)]
    pub thickness: Option<f64>,
    /// Only these bodies, by index in the scene's order (e.g. the specimen, not its
    /// platens) [default: all].
    #[arg(long, value_delimiter = ',')]
    pub body: Vec<u16>,
    /// Output PNG [default: fragment_sizes.png in the first run's folder].
    #[arg(long)]
    pub output: Option<PathBuf>,
}

/// The arguments of `fractum snapshot`.
#[derive(Debug, clap::Args)]
pub struct SnapshotArgs {
    /// A particle frame (frames/particles_NNNNNNNN.vtu).
    pub frame: PathBuf,
    /// The field (damage, velocity, velocity_x, stress_xy, pressure, a system's column...).
    #[arg(long, default_value = "damage")]
    pub field: String,
    /// The plane a 3D frame is seen in.
    #[arg(long, value_enum, default_value = "xy")]
    pub view: crate::snapshot::View,
    /// Width of the particle area in pixels.
    #[arg(long, default_value_t = 900, value_parser = clap::value_parser!(u32).range(50..=8000))]
    pub width: u32,
    /// Colour range MIN,MAX [default: the field's range in the frame].
    #[arg(long, value_delimiter = ',', num_args = 2)]
    pub range: Vec<f64>,
    /// Output PNG [default: the frame's name with .png, field appended].
    #[arg(long)]
    pub output: Option<PathBuf>,
    /// Lines to draw over the particles: a CSV with the columns line, x and y, in metres in the
    /// view's coordinates (an experiment's traced cracks, say; see docs/verification/traces/).
    #[arg(long)]
    pub overlay: Option<PathBuf>,
}

/// The arguments of `fractum bench`.
#[derive(Debug, clap::Args)]
pub struct BenchArgs {
    /// Pipelines to measure.
    #[arg(long, value_enum, value_delimiter = ',', default_values = ["linear-usl", "lme-newmark"])]
    pub pipeline: Vec<BenchPipeline>,
    /// Dimensions of the block (2 and/or 3).
    #[arg(long, value_delimiter = ',', default_values = ["2", "3"], value_parser = clap::value_parser!(u8).range(2..=3))]
    pub dimensions: Vec<u8>,
    /// Particle counts.
    #[arg(long, value_delimiter = ',', default_values = ["10000", "100000", "1000000"])]
    pub particles: Vec<usize>,
    /// Thread counts.
    #[arg(long, value_delimiter = ',', default_values = ["1", "2"])]
    pub threads: Vec<usize>,
    /// Timed steps per measurement [default: about 2 million particle-steps, at least 5].
    #[arg(long)]
    pub steps: Option<u64>,
    /// Also time each stage, count the bytes a particle-step moves, measure the memory
    /// bandwidth (a STREAM triad at each thread count) and report the roofline and the
    /// serial fraction of the step.
    #[arg(long)]
    pub profile: bool,
}

/// The options `run` and `resume` share.
#[derive(Debug, clap::Args)]
pub struct RunArgs {
    /// Threads for the parallel kernels [default: all cores].
    #[arg(long, value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..=running::MAX_THREADS as u64))]
    pub threads: Option<usize>,
    /// Stop at this step (counted from the start of the run, also when resumed) if the
    /// scene's end comes later; the scene's end is never passed. Checkpoints keep the scene's
    /// end, so a later `resume` without --steps goes on to it.
    #[arg(long)]
    pub steps: Option<u64>,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
    /// Write a checkpoint every N steps (`1000`) or every T of simulated time (`2.5e-5s`),
    /// and one at the end; a run always writes one when interrupted.
    #[arg(long)]
    pub checkpoint_every: Option<fractum_io::checkpoint::CheckpointEvery>,
    /// Checkpoints to keep (the newest).
    #[arg(long, default_value_t = fractum_io::checkpoint::DEFAULT_KEEP, value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..=1000))]
    pub keep_checkpoints: usize,
}

impl RunArgs {
    pub(crate) fn settings(&self) -> running::RunSettings {
        running::RunSettings {
            threads: self.threads,
            steps: self.steps,
            quiet: self.quiet,
            checkpoint_every: self.checkpoint_every,
            keep_checkpoints: self.keep_checkpoints,
        }
    }
}

/// The arguments of `fractum crack`.
#[derive(Debug, clap::Args)]
pub struct CrackArgs {
    /// Output folder of a run.
    pub out: PathBuf,
    /// The notch tip, x,y (or x,y,z).
    #[arg(long, value_delimiter = ',', required = true)]
    pub notch: Vec<f64>,
    /// The notch's direction, from its mouth to its tip.
    #[arg(long, value_delimiter = ',', default_values = ["1", "0"])]
    pub direction: Vec<f64>,
    /// Particles damaged at least this much are crack (a softening law's crack band is
    /// rarely damaged fully).
    #[arg(long, default_value_t = 0.5)]
    pub damage_above: f64,
    /// Link length (m) joining crack particles [default: 1.5 particle spacings].
    #[arg(long)]
    pub link: Option<f64>,
    /// Crack length (m) at which the initial angle is taken [default: 8 link lengths].
    #[arg(long)]
    pub angle_length: Option<f64>,
    /// The run's scene, for the Rayleigh speed of its material.
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// The material of the cracked body [default: the scene's first].
    #[arg(long)]
    pub material: Option<String>,
    /// The scene's thickness (m) for 2D runs, for the default link [default: the one the frames
    /// record].
    #[arg(long)]
    pub thickness: Option<f64>,
    /// A time window FROM,TO (s) to report the crack's speed over as well, as papers report it
    /// (Kalthoff–Winkler: 40e-6,50e-6).
    #[arg(
        long,
        value_delimiter = ',',
        value_name = "FROM,TO",
        allow_negative_numbers = true
    )]
    pub window: Option<Vec<f64>>,
}
