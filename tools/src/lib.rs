//! # fractum-cli
//!
//! The `fractum` command line: `run`, `check` and `systems`. The commands are library functions
//! so that a user's crate can build its own `fractum` with extra systems registered:
//!
//! ```no_run
//! let mut registry = fractum_systems::stock_registry();
//! // registry.register(my_crate::MY_DAMAGE).unwrap();
//! std::process::exit(fractum_cli::main_with(std::env::args_os(), &registry));
//! ```

/// `print!` that ignores a closed stdout (`fractum systems | head -1`): a reader that stops
/// reading is no error of ours, and `print!` would panic on it.
macro_rules! out {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = write!(std::io::stdout().lock(), $($arg)*);
    }};
}

/// `println!` that ignores a closed stdout (see `out!`).
macro_rules! outln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout().lock(), $($arg)*);
    }};
}

pub mod bench;
pub mod crack;
pub mod fragments;
pub mod plot;
pub mod remedy;
pub mod running;

use bench::{BenchCase, BenchPipeline, default_steps, measure, table};
use clap::{Parser, Subcommand};
use fractum_engine::dim::{Dim, Dimension};
use fractum_engine::energy::EnergyCreation;
use fractum_engine::output::{read_particle_frame, read_pvd, write_atomically};
use fractum_engine::registry::Registry;
use fractum_engine::resources::{Grid, Materials, Thickness};
use fractum_engine::run::RunSummary;
use fractum_engine::scene::{Built, SceneError, SceneFile, build_simulation};
use fractum_engine::simulation::{End, TimeStep};
use fractum_engine::with_dim;
use std::ffi::OsString;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Exit code: the scene is invalid.
pub const EXIT_BAD_SCENE: i32 = 1;
/// Exit code: the command line is malformed (clap's own code).
pub const EXIT_USAGE: i32 = 2;
/// Exit code: the run stopped on a non-finite value or a particle leaving the grid.
pub const EXIT_BLOWUP: i32 = 3;
/// Exit code: an output file could not be written or read.
pub const EXIT_IO: i32 = 4;
/// Exit code: the machine could not give what the run asked for (the thread pool).
pub const EXIT_RESOURCES: i32 = 5;
/// Exit code: a signal (SIGINT, SIGTERM) stopped the run after a step; its outputs and a
/// checkpoint are written, and `fractum resume` continues it.
pub const EXIT_INTERRUPTED: i32 = 130;
/// Exit code: a second signal stopped the run at once; the outputs and checkpoint of before
/// are intact, the current step's are not written.
pub const EXIT_ABANDONED: i32 = 131;

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
    /// Peak of a load curve and the RMS deviation of its rising part from a straight line.
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
    Fragments {
        /// Output folders of runs (several: their distributions on one plot).
        #[arg(required = true)]
        out: Vec<PathBuf>,
        /// Time of the frame to analyse (the nearest written) [default: the last frame].
        #[arg(long)]
        time: Option<f64>,
        /// Particles with damage below this are intact material.
        #[arg(long, default_value_t = 0.5)]
        damage_below: f64,
        /// Link length (m) joining intact particles [default: 1.5 particle spacings].
        #[arg(long)]
        link: Option<f64>,
        /// The scene's thickness (m) for 2D runs [default: the one the frames record].
        #[arg(long)]
        thickness: Option<f64>,
        /// Only these bodies, by index in the scene's order (e.g. the specimen, not its
        /// platens) [default: all].
        #[arg(long, value_delimiter = ',')]
        body: Vec<u16>,
        /// Output PNG [default: fragment_sizes.png in the first run's folder].
        #[arg(long)]
        output: Option<PathBuf>,
    },
    /// A crack from a notch: its tip against time (crack.csv in the run's folder), initial
    /// angle and speed, beside the Rayleigh speed of the material.
    Crack(CrackArgs),
    /// Measure particle-steps per second of the stock pipelines on a generated scene.
    Bench {
        /// Pipelines to measure.
        #[arg(long, value_enum, value_delimiter = ',', default_values = ["linear-usl", "lme-newmark"])]
        pipeline: Vec<BenchPipeline>,
        /// Dimensions of the block (2 and/or 3).
        #[arg(long, value_delimiter = ',', default_values = ["2", "3"], value_parser = clap::value_parser!(u8).range(2..=3))]
        dimensions: Vec<u8>,
        /// Particle counts.
        #[arg(long, value_delimiter = ',', default_values = ["10000", "100000", "1000000"])]
        particles: Vec<usize>,
        /// Thread counts.
        #[arg(long, value_delimiter = ',', default_values = ["1", "2"])]
        threads: Vec<usize>,
        /// Timed steps per measurement [default: about 2 million particle-steps, at least 5].
        #[arg(long)]
        steps: Option<u64>,
    },
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
    pub checkpoint_every: Option<fractum_engine::checkpoint::CheckpointEvery>,
    /// Checkpoints to keep (the newest).
    #[arg(long, default_value_t = fractum_engine::checkpoint::DEFAULT_KEEP, value_parser = clap::builder::RangedU64ValueParser::<usize>::new().range(1..=1000))]
    pub keep_checkpoints: usize,
}

impl RunArgs {
    fn settings(&self) -> running::RunSettings {
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
    /// Crack length (m) at which the initial angle is taken [default: 4 link lengths].
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
}

/// Parses `args` and runs the command with the systems in `registry`; returns the exit code.
pub fn main_with(args: impl IntoIterator<Item = OsString>, registry: &Registry) -> i32 {
    let cli = match Cli::try_parse_from(args) {
        Ok(cli) => cli,
        Err(e) => {
            let _ = e.print();
            return if e.use_stderr() { EXIT_USAGE } else { 0 };
        }
    };
    match cli.command {
        Command::Systems => {
            out!("{}", systems_report(registry));
            0
        }
        Command::Plot {
            csv,
            x,
            columns,
            bar,
            output,
        } => plot_command(&csv, &x, &columns, bar.as_deref(), output),
        Command::Curve { csv, x, y, from } => curve_command(&csv, &x, &y, from),
        Command::Crack(args) => crack_command(&args, registry),
        Command::Fragments {
            out,
            time,
            damage_below,
            link,
            thickness,
            body,
            output,
        } => {
            let options = fragments::FragmentOptions {
                damage_below,
                link,
                thickness,
                bodies: body,
            };
            fragments_command(&out, time, &options, output)
        }
        Command::Bench {
            pipeline,
            dimensions,
            particles,
            threads,
            steps,
        } => {
            let dimensions: Vec<Dimension> = dimensions
                .iter()
                .filter_map(|d| Dimension::of_count(*d as usize))
                .collect();
            let grid = BenchGrid {
                pipelines: &pipeline,
                dimensions: &dimensions,
                particles: &particles,
                threads: &threads,
                steps,
            };
            bench_command(&grid, registry)
        }
        Command::Check { scene } => match load(&scene, registry) {
            Ok((_, mut built)) => {
                out!("{}", check_report(&mut built));
                0
            }
            Err(e) => report_scene_error(&e),
        },
        Command::Run {
            scene,
            out,
            force,
            settings,
        } => running::run_command(&scene, out, force, &settings.settings(), registry),
        Command::Resume { out, settings } => {
            running::resume_command(&out, &settings.settings(), registry)
        }
    }
}

fn plot_command(
    csvs: &[PathBuf],
    x: &str,
    columns: &[String],
    bar: Option<&str>,
    output: Option<PathBuf>,
) -> i32 {
    let result = (|| {
        let runs = csvs
            .iter()
            .map(|csv| {
                let run = csv
                    .parent()
                    .and_then(Path::file_name)
                    .map_or_else(|| csv.display().to_string(), |n| n.to_string_lossy().into());
                Ok((run, plot::Series::read(csv)?))
            })
            .collect::<Result<Vec<_>, String>>()?;
        let bar = bar.map(plot::BarReference::parse).transpose()?;
        let output =
            output.unwrap_or_else(|| csvs[0].with_file_name(format!("{}.png", columns.join("+"))));
        plot::plot_runs(&runs, x, columns, bar, &output)
    })();
    match result {
        Ok(path) => {
            outln!("wrote {}", path.display());
            0
        }
        Err(e) => {
            eprintln!("error: {e}");
            EXIT_BAD_SCENE
        }
    }
}

/// A point of 2 or 3 coordinates as three.
fn point3(values: &[f64], what: &str) -> Result<[f64; 3], String> {
    match values {
        [x, y] => Ok([*x, *y, 0.0]),
        [x, y, z] => Ok([*x, *y, *z]),
        _ => Err(format!("--{what} takes 2 or 3 comma-separated numbers")),
    }
}

/// The Rayleigh speed of `material` (or the first) of the scene at `path`, with its name.
fn scene_rayleigh_speed(
    path: &Path,
    material: Option<&str>,
    registry: &Registry,
) -> Result<(String, f64), String> {
    let (_, built) = load(path, registry).map_err(|e| e.to_string())?;
    let materials = &built.simulation.world.resource::<Materials>().0;
    let m = match material {
        Some(name) => materials.iter().find(|m| m.name == name).ok_or_else(|| {
            let names: Vec<&str> = materials.iter().map(|m| m.name.as_str()).collect();
            format!(
                "no material {name:?} in {}; it has {names:?}",
                path.display()
            )
        })?,
        None => materials
            .first()
            .ok_or_else(|| format!("{} has no materials", path.display()))?,
    };
    let speed = crack::rayleigh_speed(m.youngs_modulus, m.poisson_ratio, m.density);
    Ok((m.name.clone(), speed))
}

fn crack_command(request: &CrackArgs, registry: &Registry) -> i32 {
    let dir = request.out.as_path();
    let result = (|| {
        let notch_tip = point3(&request.notch, "notch")?;
        let notch_direction = point3(&request.direction, "direction")?;
        let link = match request.link {
            Some(l) => l,
            None => {
                let frames = read_pvd(&dir.join("particles.pvd"))?;
                let first = frames.first().ok_or_else(|| {
                    format!("{}: the run wrote no particle frames", dir.display())
                })?;
                let path = dir.join(&first.1);
                let frame = read_particle_frame(&path)?;
                let (planar, thickness) = fragments::frame_thickness(&frame, request.thickness)
                    .map_err(|e| format!("{}: {e}", path.display()))?;
                1.5 * fragments::median_spacing(&frame, planar, thickness)
            }
        };
        let options = crack::CrackOptions {
            notch_tip,
            notch_direction,
            damage_above: request.damage_above,
            link,
            angle_length: request.angle_length.unwrap_or(4.0 * link),
        };
        let history = crack::crack_history(dir, &options)?;
        let mut table = String::from("time,tip_x,tip_y,tip_z,length\n");
        for t in &history {
            let [x, y, z] = t.tip;
            table.push_str(&format!("{:e},{x:e},{y:e},{z:e},{:e}\n", t.time, t.length));
        }
        let path = dir.join("crack.csv");
        write_atomically(&path, table.as_bytes())
            .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
        let length = history.last().map_or(0.0, |t| t.length);
        let mut report = format!(
            "crack length {length:e} m (link {link:e} m); wrote {}",
            path.display()
        );
        match crack::initial_angle(&history, &options) {
            Some(a) => report.push_str(&format!(
                "\ninitial angle {a:.1}° from the notch direction (at {:e} m of crack)",
                options.angle_length
            )),
            None => report.push_str(&format!(
                "\nno initial angle: the crack never reached {:e} m",
                options.angle_length
            )),
        }
        let rayleigh = request
            .scene
            .as_deref()
            .map(|s| scene_rayleigh_speed(s, request.material.as_deref(), registry))
            .transpose()?;
        match crack::crack_speed(&history) {
            Some((mean, largest)) => {
                report.push_str(&format!(
                    "\ncrack speed {mean:e} m/s (least squares over the growth), largest \
                     between frames {largest:e} m/s"
                ));
                if let Some((name, c_r)) = rayleigh {
                    report.push_str(&format!(
                        "\nRayleigh speed of {name}: {c_r:e} m/s (crack speed {:.2} of it, \
                         largest {:.2})",
                        mean / c_r,
                        largest / c_r
                    ));
                }
            }
            None => report.push_str("\nno crack speed: the crack did not grow between frames"),
        }
        Ok::<String, String>(report)
    })();
    match result {
        Ok(report) => {
            outln!("{report}");
            0
        }
        Err(e) => {
            eprintln!("error: {e}");
            EXIT_IO
        }
    }
}

fn fragments_command(
    dirs: &[PathBuf],
    time: Option<f64>,
    options: &fragments::FragmentOptions,
    output: Option<PathBuf>,
) -> i32 {
    let result = (|| {
        let mut runs = Vec::new();
        for dir in dirs {
            let run = fragments::run_fragments(dir, time, options)?;
            fragments::write_fragment_tables(&run)?;
            let largest = run.fragments.first().map_or(0.0, |f| f.diameter);
            outln!(
                "{}: t = {:e} s, {} fragments (largest {largest:e} m across), mass-weighted mean \
                 speed {:e} m/s, link {:e} m; wrote fragments.csv and fragment_sizes.csv",
                dir.display(),
                run.time,
                run.fragments.len(),
                fragments::mean_speed(&run.fragments),
                run.link
            );
            runs.push(run);
        }
        let output = output.unwrap_or_else(|| dirs[0].join("fragment_sizes.png"));
        fragments::plot_size_distributions(&runs, &output)
    })();
    match result {
        Ok(path) => {
            outln!("wrote {}", path.display());
            0
        }
        Err(e) => {
            eprintln!("error: {e}");
            EXIT_IO
        }
    }
}

fn curve_command(csv: &Path, x: &str, y: &str, from: f64) -> i32 {
    let result = (|| {
        let series = plot::Series::read(csv)?;
        let (xs, ys) = (series.column(x)?, series.column(y)?);
        plot::curve_summary(&xs, &ys, from)
            .ok_or_else(|| "too few points before the peak".to_string())
    })();
    match result {
        Ok(s) => {
            outln!(
                "peak {y} = {:.6e} at {x} = {:.6e}\npre-peak slope {:.6e}, RMS deviation from the line {:.6e} ({:.2}% of the peak)",
                s.peak,
                s.x_at_peak,
                s.slope,
                s.rms_deviation,
                100.0 * s.rms_deviation / s.peak.abs()
            );
            0
        }
        Err(e) => {
            eprintln!("error: {e}");
            EXIT_BAD_SCENE
        }
    }
}

/// Every combination `fractum bench` measures.
struct BenchGrid<'a> {
    pipelines: &'a [BenchPipeline],
    dimensions: &'a [Dimension],
    particles: &'a [usize],
    threads: &'a [usize],
    steps: Option<u64>,
}

impl BenchGrid<'_> {
    fn cases(&self) -> Vec<BenchCase> {
        let mut cases = Vec::new();
        for &pipeline in self.pipelines {
            for &dimension in self.dimensions {
                for &particles in self.particles {
                    for &threads in self.threads {
                        cases.push(BenchCase {
                            pipeline,
                            dimension,
                            particles,
                            threads: threads.max(1),
                            steps: self.steps.unwrap_or_else(|| default_steps(particles)),
                        });
                    }
                }
            }
        }
        cases
    }
}

fn bench_command(grid: &BenchGrid, registry: &Registry) -> i32 {
    let mut results = Vec::new();
    for case in grid.cases() {
        match measure(registry, case) {
            Ok(result) => {
                eprintln!(
                    "{} {} {} particles, {} threads: {:.3e} particle-steps/s",
                    result.pipeline.name(),
                    result.dimension.describe(),
                    result.particles,
                    result.threads,
                    result.rate()
                );
                results.push(result);
            }
            Err(e) => {
                eprintln!("error: {e}");
                return EXIT_BLOWUP;
            }
        }
    }
    out!("{}", table(&results));
    0
}

pub(crate) fn report_scene_error(e: &SceneError) -> i32 {
    eprintln!("error: {e}");
    EXIT_BAD_SCENE
}

/// Reads, validates and builds a scene.
pub fn load(path: &Path, registry: &Registry) -> Result<(SceneFile, Built), SceneError> {
    let file = SceneFile::read(path)?;
    let built = build_simulation(&file, registry)?;
    Ok((file, built))
}

/// The `fractum systems` listing.
pub fn systems_report(registry: &Registry) -> String {
    let mut out = String::new();
    let mut stage = None;
    for r in registry.iter() {
        if r.stage() != stage {
            stage = r.stage();
            let name = stage.map(|s| s.name()).unwrap_or("?");
            let _ = writeln!(out, "\n[{name}]");
        }
        let _ = writeln!(out, "  {:<28} {}", r.name, r.summary);
        for p in r.params {
            let default = p
                .default
                .map_or("required".to_string(), |d| format!("default {d}"));
            let _ = writeln!(out, "      {}: {} ({default}) - {}", p.name, p.ty, p.doc);
        }
        if !r.requires.is_empty() {
            let _ = writeln!(out, "      needs: {}", r.requires.join(", "));
        }
    }
    out.trim_start().to_string()
}

fn describe_step(step: TimeStep, limit: f64) -> String {
    match step {
        TimeStep::Fixed(dt) => format!("dt = {dt:e} s fixed (stable limit {limit:.4e} s)"),
        TimeStep::Cfl(f) => format!("CFL {f} of the stable limit (now dt = {:.4e} s)", f * limit),
    }
}

/// `(x, y)` or `(x, y, z)` with plain number formatting.
fn point<D: Dim>(v: D::Vector) -> String {
    use fractum_engine::dim::VectorOps;
    let parts: Vec<String> = v.to_3d()[..D::N].iter().map(|c| c.to_string()).collect();
    format!("({})", parts.join(", "))
}

/// The grid line of `fractum check`.
fn grid_line<D: Dim>(built: &mut Built) -> String {
    let grid = built.simulation.world.resource::<Grid<D>>().clone();
    let cells: Vec<String> = grid.cells.as_ref().iter().map(|c| c.to_string()).collect();
    let spacing = match &grid.graded {
        None => format!("h = {} m", grid.spacing),
        Some(axes) => {
            let largest = axes
                .coordinates
                .iter()
                .flat_map(|c| c.windows(2).map(|w| w[1] - w[0]))
                .fold(0.0, f64::max);
            // Widths are differences of node coordinates: print them to 12 significant digits.
            let short = |x: f64| format!("{}", format!("{x:.11e}").parse::<f64>().unwrap_or(x));
            format!(
                "graded, h = {} to {} m",
                short(grid.spacing),
                short(largest)
            )
        }
    };
    format!(
        "{} cells, {spacing}, {} nodes, box {} to {}",
        cells.join(" x "),
        grid.node_count(),
        point::<D>(grid.min),
        point::<D>(grid.max())
    )
}

/// The `fractum check` summary of a valid scene.
pub fn check_report(built: &mut Built) -> String {
    let summary = built.summary.clone();
    let sim = &mut built.simulation;
    let limit = sim.stable_time_step();
    let dimension = sim.dimension();
    let mut out = String::new();
    let _ = writeln!(
        out,
        "scene      {}{}",
        summary.source,
        if summary.title.is_empty() {
            String::new()
        } else {
            format!(" - {}", summary.title)
        }
    );
    let thickness = match dimension {
        Dimension::Two => format!(", thickness {} m", sim.world.resource::<Thickness>().0),
        Dimension::Three => String::new(),
    };
    let _ = writeln!(out, "dimension  {}{thickness}", dimension.describe());
    let grid = with_dim!(dimension, D => grid_line::<D>(built));
    let sim = &mut built.simulation;
    let _ = writeln!(out, "grid       {grid}");
    let counts: Vec<String> = summary
        .bodies
        .iter()
        .map(|(name, n)| format!("{name}: {n}"))
        .collect();
    let _ = writeln!(
        out,
        "particles  {} ({})",
        sim.particle_count(),
        counts.join(", ")
    );
    if let Some(memory) = sim
        .world
        .get_resource::<fractum_engine::scene::budget::MemoryUse>()
    {
        use fractum_engine::scene::budget::describe_bytes;
        let available = if memory.available.is_finite() {
            format!("{} available", describe_bytes(memory.available))
        } else {
            "available memory unknown".to_string()
        };
        let _ = writeln!(
            out,
            "memory     about {} estimated, {available}",
            describe_bytes(memory.needed)
        );
    }
    for m in &sim.world.resource::<Materials>().0 {
        let _ = writeln!(
            out,
            "material   {}: density {} kg/m3, E {} Pa, nu {}, wave speed {:.4e} m/s",
            m.name,
            m.density,
            m.youngs_modulus,
            m.poisson_ratio,
            m.wave_speed()
        );
    }
    let end = match sim.end() {
        End::Time(t) => format!("end at t = {t} s"),
        End::Steps(n) => format!("end after {n} steps"),
    };
    if let Some(step) = summary.time_step {
        let _ = writeln!(out, "time       {}; {end}", describe_step(step, limit));
    }
    for (name, condition) in &summary.boundaries {
        let _ = writeln!(out, "boundary   {name}: {condition}");
    }
    let _ = writeln!(out, "pipeline");
    for (stage, names) in &built.pipeline.by_stage {
        let _ = writeln!(out, "  {:<10} {}", stage.name(), names.join(", "));
    }
    let frames = match built.output.vtu_every {
        0 => "no VTU frames".to_string(),
        n => format!("VTU frame every {n} steps"),
    };
    let _ = writeln!(
        out,
        "output     {frames}; series.csv columns: {}",
        built.output.columns().join(",")
    );
    out.push_str("ok\n");
    out
}

/// The warning printed when a run first creates more energy than the watch allows.
pub fn energy_warning(first: &EnergyCreation) -> String {
    format!(
        "at step {} (t = {:.4e} s) the scheme has created {:.4e} J, {:.1}% of the energy in play \
         (the total energy above external_work in series.csv). An explicit run that creates energy is usually heading \
         for a blow-up: a smaller CFL factor, or a smoother basis (basis/gimp) than the linear \
         tents where a stiff contact or a steep stress moves particles across cells, usually cures it",
        first.step,
        first.time,
        first.created,
        100.0 * first.fraction
    )
}

/// The end-of-run summary.
pub fn summary_report(s: &RunSummary, out_dir: &Path) -> String {
    let removed = if s.removed > 0 {
        format!("{} particles left the grid and were removed\n", s.removed)
    } else {
        String::new()
    };
    let threads = if s.threads < s.threads_asked {
        format!(
            "{} ({} asked: a scene this small steps faster on one)",
            s.threads, s.threads_asked
        )
    } else {
        s.threads.to_string()
    };
    let energy = s.energy_created.map_or(String::new(), |worst| {
        format!(
            "energy: the scheme created up to {:.4e} J ({:.1}% of the energy in play) at step {}, \
             t = {:.4e} s (the total energy above external_work in series.csv)\n",
            worst.created,
            100.0 * worst.fraction,
            worst.step,
            worst.time
        )
    });
    format!(
        "steps {}, simulated time {:.6e} s, particles {}, threads {threads}\nwall time {:.3} s, {:.4e} particle-steps/s\n{} VTU frames, output in {}\n{removed}{energy}",
        s.steps,
        s.time,
        s.particles,
        s.wall.as_secs_f64(),
        s.particle_steps_per_second(),
        s.frames,
        out_dir.display()
    )
}
