//! `fractum bench`: particle-steps per second of the stock pipelines.

use crate::EXIT_BLOWUP;
use crate::bench::{BenchCase, BenchPipeline, default_steps, measure, table};
use fractum_engine::dim::Dimension;
use fractum_engine::registry::Registry;

/// Every combination `fractum bench` measures.
pub(crate) struct BenchGrid<'a> {
    pub(crate) pipelines: &'a [BenchPipeline],
    pub(crate) dimensions: &'a [Dimension],
    pub(crate) particles: &'a [usize],
    pub(crate) threads: &'a [usize],
    pub(crate) steps: Option<u64>,
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

pub(crate) fn bench_command(grid: &BenchGrid, registry: &Registry) -> i32 {
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
