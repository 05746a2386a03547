//! The same scene gives bitwise-identical results with 1 and 2 threads.

use fractum_engine::prelude::*;
use fractum_engine::scene::End;
use fractum_suite::{load, repo_root};

fn state_after(threads: usize, steps: u64) -> Vec<u64> {
    let mut built = load(&repo_root().join("scenes/two_disks.ron")).unwrap();
    let sim = &mut built.simulation;
    sim.set_threads(threads).unwrap();
    sim.set_end(End::Steps(steps));
    while !sim.finished() {
        sim.step().unwrap();
    }
    let mut query = sim
        .world
        .query_filtered::<(&ParticleId, &Position, &Velocity, &Stress, &Volume), With<Particle>>();
    let mut rows: Vec<_> = query.iter(&sim.world).collect();
    rows.sort_by_key(|r| r.0.0);
    rows.iter()
        .flat_map(|(_, x, v, s, vol)| {
            [
                x.0.x, x.0.y, v.0.x, v.0.y, s.0.xx, s.0.yy, s.0.zz, s.0.xy, vol.0,
            ]
            .map(f64::to_bits)
        })
        .collect()
}

#[test]
fn one_and_two_threads_give_identical_bits() {
    // 1700 steps of 1 ms take the disks through first contact (about t = 1.6 s).
    let one = state_after(1, 1700);
    let two = state_after(2, 1700);
    assert_eq!(one.len(), two.len());
    let differing = one.iter().zip(&two).filter(|(a, b)| a != b).count();
    assert_eq!(differing, 0, "{differing} of {} values differ", one.len());
}
