//! What a frame costs the writer thread: encoding and writing one particle frame of the
//! Kalthoff–Winkler plate (`scenes/kalthoff_winkler_dfg_tents.ron`, 49 200 particles, every field)
//! after 400 steps, uncompressed and zlib-compressed. Run with
//! `cargo bench -p fractum-systems --features bench --bench frames`; the sizes print before the
//! timings.

use criterion::{Criterion, criterion_group, criterion_main};
use fractum_io::output::{FrameCompression, ParticleFrame, particle_frame, write_particle_frame};
use fractum_scene::{SceneFile, build_simulation};
use std::path::PathBuf;
use std::time::Duration;

fn plate_frame() -> ParticleFrame {
    let scene =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../scenes/kalthoff_winkler_dfg_tents.ron");
    let file = SceneFile::read(&scene).expect("the shipped scene reads");
    let mut built = build_simulation(&file, &fractum_systems::stock_registry()).expect("it builds");
    for _ in 0..400 {
        built.simulation.step().expect("the plate steps");
    }
    particle_frame(&mut built.simulation.world)
}

fn frames(c: &mut Criterion) {
    let frame = plate_frame();
    let particles = frame.position.len();
    let dir = std::env::temp_dir().join(format!("fractum-bench-frames-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("a scratch folder");
    let mut group = c.benchmark_group("frame");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(10));
    for compression in [FrameCompression::None, FrameCompression::Zlib] {
        let path = dir.join(format!("{compression:?}.vtu"));
        write_particle_frame(&path, &frame, compression).expect("the frame writes");
        let bytes = std::fs::metadata(&path).expect("it exists").len();
        println!(
            "{compression:?}: {bytes} bytes, {:.1} per particle",
            bytes as f64 / particles as f64
        );
        group.bench_function(format!("{compression:?}"), |b| {
            b.iter(|| write_particle_frame(&path, &frame, compression).expect("the frame writes"));
        });
    }
    group.finish();
    let _ = std::fs::remove_dir_all(&dir);
}

// The macro generates an undocumented function.
#[allow(missing_docs)]
mod group {
    use super::*;
    criterion_group!(benches, frames);
}
use group::benches;
criterion_main!(benches);
