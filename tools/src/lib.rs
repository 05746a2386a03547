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
pub mod body_motion;
pub mod cell_crossing;
pub mod cli;
mod commands;
pub mod crack;
pub mod crossing;
pub mod fragments;
pub mod overlay;
pub mod plot;
pub mod ranks;
pub mod remedy;
pub mod reports;
pub mod resuming;
pub mod running;
pub mod snapshot;
pub mod verify;

pub use cli::{Cli, Command, CrackArgs, RunArgs};
pub use reports::{
    RunLength, check_report, energy_warning, kinetic_warning, run_length, summary_report,
    systems_report,
};

use clap::Parser;
use fractum_engine::registry::Registry;
use fractum_scene::{Built, SceneError, SceneFile, build_simulation, estimate_memory};
use std::ffi::OsString;
use std::path::Path;

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
/// Exit code: `fractum verify` found a case outside its tolerance, or one it could not run or
/// measure.
pub const EXIT_VERIFY_FAILED: i32 = 6;
/// Exit code: a signal (SIGINT, SIGTERM) stopped the run after a step; its outputs and a
/// checkpoint are written, and `fractum resume` continues it.
pub const EXIT_INTERRUPTED: i32 = 130;
/// Exit code: a second signal stopped the run at once; the outputs and checkpoint of before
/// are intact, the current step's are not written.
pub const EXIT_ABANDONED: i32 = 131;

/// Parses `args` and runs the command with the systems in `registry`; returns the exit code.
pub fn main_with(args: impl IntoIterator<Item = OsString>, registry: &Registry) -> i32 {
    let cli = match Cli::try_parse_from(args) {
        Ok(cli) => cli,
        Err(e) => {
            let _ = e.print();
            return if e.use_stderr() { EXIT_USAGE } else { 0 };
        }
    };
    let divided = matches!(cli.command, Command::Run { .. } | Command::Resume { .. });
    if !divided && let Some(code) = ranks::one_process_only() {
        return code;
    }
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
        } => commands::plot::plot_command(&csv, &x, &columns, bar.as_deref(), output),
        Command::Curve { csv, x, y, from } => commands::curve::curve_command(&csv, &x, &y, from),
        Command::Crack(args) => commands::crack::crack_command(&args, registry),
        Command::Fragments(args) => commands::fragments::fragments_command(&args),
        Command::Bench(args) => commands::bench::bench_command(&args, registry),
        Command::Verify(args) => verify::verify_command(&args),
        Command::Snapshot(args) => commands::snapshot::snapshot_command(&args),
        Command::Check {
            scene,
            estimate: true,
            ranks,
        } => match SceneFile::read(&scene)
            .and_then(|file| estimate_memory(&file, registry, ranks.map(|r| r as usize)))
        {
            Ok(estimate) => {
                out!("{}", reports::estimate_report(&estimate));
                if estimate.refusal.is_some() {
                    EXIT_BAD_SCENE
                } else {
                    0
                }
            }
            Err(e) => report_scene_error(&e),
        },
        Command::Check {
            scene,
            estimate: false,
            ..
        } => commands::check::check_command(&scene, registry),
        Command::Run {
            scene,
            out,
            force,
            settings,
        } => match ranks::several_ranks() {
            None => running::run_command(&scene, out, force, &settings.settings(), registry),
            Some(Ok(comm)) => {
                let settings = settings.settings();
                running::run_ranks(&scene, out, force, &settings, registry, comm.as_ref())
            }
            Some(Err(code)) => code,
        },
        Command::Resume { out, settings } => match ranks::several_ranks() {
            None => resuming::resume_command(&out, &settings.settings(), registry),
            Some(Ok(comm)) => {
                resuming::resume_ranks(&out, &settings.settings(), registry, comm.as_ref())
            }
            Some(Err(code)) => code,
        },
    }
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
