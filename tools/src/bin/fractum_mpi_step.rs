//! `fractum-mpi-step SCENE STEPS [--serial]`: steps a scene as the ranks `mpirun` started (or
//! as one process with `--serial`) and prints, per rank, the particles it owns, a digest of
//! their state that adds over particles, how often the slabs were re-cut and the imbalance
//! after the last step, the particles it held with its ghosts and the bytes it sent to other
//! ranks per step, the wall time of its build and steps, and its part of each series column. The ranks'
//! lines add up to the single process's when the distributed step reproduces it
//! (`tools/tests/mpi_run.rs`). Built with the `mpi` feature.

use fractum_cli::ranks::{communicator, step_digest};
use fractum_engine::communicator::Communicator;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (Some(scene), Some(steps)) = (args.first(), args.get(1).and_then(|s| s.parse().ok()))
    else {
        eprintln!("usage: fractum-mpi-step SCENE STEPS [--serial]");
        std::process::exit(2);
    };
    let serial = args.iter().any(|a| a == "--serial");
    let file = match fractum_scene::SceneFile::read(std::path::Path::new(scene)) {
        Ok(file) => file,
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    };
    let comm = communicator();
    let started = std::time::Instant::now();
    let result = if serial {
        step_digest(&file, steps, None)
    } else {
        step_digest(&file, steps, Some(&*comm as &dyn Communicator))
    };
    let wall = started.elapsed().as_secs_f64();
    match result {
        Ok(digest) => {
            let columns: Vec<String> = digest
                .columns
                .iter()
                .map(|(name, value)| format!("{name}={value:e}"))
                .collect();
            let (held, sent) = digest.traffic;
            println!(
                "rank {} of {}: particles {} digest {:016x} re-cuts {} imbalance {:.3} held {held} \
                 sent-per-step {} wall {wall:.3} columns {}",
                comm.rank(),
                comm.size(),
                digest.particles,
                digest.digest,
                digest.rebalanced.0,
                digest.rebalanced.1,
                sent / steps.max(1),
                columns.join(",")
            );
        }
        Err(e) => {
            eprintln!("error: rank {}: {e}", comm.rank());
            std::process::exit(1);
        }
    }
}
