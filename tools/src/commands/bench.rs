//! `fractum bench`: particle-steps per second of the stock pipelines.

use crate::EXIT_BLOWUP;
use crate::bench::{
    BenchCase, BenchPipeline, default_steps, measure, profile_report, table, triad_bandwidth,
};
use crate::cli::BenchArgs;
use fractum_engine::dim::Dimension;
use fractum_engine::registry::Registry;

/// Every combination `fractum bench` measures.
pub(crate) struct BenchGrid<'a> {
    pub(crate) pipelines: &'a [BenchPipeline],
    pub(crate) dimensions: &'a [Dimension],
    pub(crate) particles: &'a [usize],
    pub(crate) threads: &'a [usize],
    pub(crate) steps: Option<u64>,
    pub(crate) profile: bool,
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
                            profile: self.profile,
                        });
                    }
                }
            }
        }
        cases
    }
}

/// `fractum bench` with `args`; the exit code.
pub(crate) fn bench_command(args: &BenchArgs, registry: &Registry) -> i32 {
    let dimensions: Vec<Dimension> = args
        .dimensions
        .iter()
        .filter_map(|d| Dimension::of_count(*d as usize))
        .collect();
    let grid = &BenchGrid {
        pipelines: &args.pipeline,
        dimensions: &dimensions,
        particles: &args.particles,
        threads: &args.threads,
        steps: args.steps,
        profile: args.profile,
    };
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
    if grid.profile {
        let mut bandwidth = Vec::new();
        for &threads in grid.threads {
            match triad_bandwidth(threads.max(1), TRIAD_ELEMENTS) {
                Ok(bytes_per_second) => {
                    eprintln!(
                        "triad, {threads} threads: {:.2} GB/s",
                        bytes_per_second / 1e9
                    );
                    bandwidth.push((threads.max(1), bytes_per_second));
                }
                Err(e) => {
                    eprintln!("error: the triad: {e}");
                    return EXIT_BLOWUP;
                }
            }
        }
        out!("{}", profile_report(&results, &bandwidth));
    }
    0
}

/// Elements of each triad array: 2²⁴ f64s, 128 MiB, well beyond the caches of the machines we
/// measure on.
const TRIAD_ELEMENTS: usize = 1 << 24;
