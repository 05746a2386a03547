//! Quasi-static runs (`time.quasi_static`): mass scaling by `α` is the unscaled dynamics loaded
//! `√α` times faster on a time axis stretched `√α` times, the weight stays the scene's, and the
//! kinetic-energy check tells a slow pull from a jerk.

use fractum_engine::prelude::*;
use fractum_io::run::{RunSummary, run};
use fractum_scene::{Built, SceneFile, build_simulation};
use fractum_suite::temp_dir;

/// A steel bar 0.1 m long under gravity, clamped at its left end and pulled along x at its
/// right end: the pull ramps from rest to `speed` over `ramp` seconds. Runs `steps` CFL steps.
fn bar(quasi_static: &str, speed: f64, ramp: f64, steps: u64) -> Built {
    let text = format!(
        r#"(
    time: (step: Cfl(0.5), end: Steps({steps}){quasi_static}),
    grid: (min: (-0.01, -0.01), max: (0.12, 0.03), spacing: 0.01),
    materials: {{ "steel": (density: 7800.0, youngs_modulus: 2.0e11, poisson_ratio: 0.3) }},
    bodies: [(name: "bar", shape: Rectangle(min: (0.0, 0.0), max: (0.1, 0.02)), material: "steel")],
    boundaries: [
        (name: "clamp", nodes: Box(min: (0.0, 0.0), max: (0.0, 0.02)), condition: Fixed),
        (name: "pull", nodes: Box(min: (0.1, 0.0), max: (0.1, 0.02)),
         condition: Velocity(x: [(0.0, 0.0), ({ramp:e}, {speed:e})])),
    ],
    body_force: (0.0, -9.81),
    output: (csv_every: 5, probes: [Reaction("clamp"), Reaction("pull")]),
    pipeline: [(system: "basis/linear"), (system: "predictor/usl"),
               (system: "stress/linear_elastic"), (system: "advection/usl")],
)"#
    );
    let file = SceneFile::parse("bar.ron", text).unwrap_or_else(|e| panic!("{e}"));
    build_simulation(&file, &fractum_systems::stock_registry()).unwrap_or_else(|e| panic!("{e}"))
}

/// Runs `built` to its end with its outputs in a fresh folder; the summary and `series.csv`'s
/// header and rows.
fn run_to_end(mut built: Built, name: &str) -> (RunSummary, Vec<String>, Vec<Vec<f64>>) {
    let out = temp_dir(name);
    let summary =
        run(&mut built.simulation, &built.output, &out, |_| {}).unwrap_or_else(|e| panic!("{e}"));
    let text = std::fs::read_to_string(out.join("series.csv")).unwrap();
    let mut lines = text.lines();
    let header: Vec<String> = lines
        .next()
        .unwrap()
        .split(',')
        .map(str::to_string)
        .collect();
    let rows = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    let _ = std::fs::remove_dir_all(&out);
    (summary, header, rows)
}

fn total_mass(world: &mut World) -> f64 {
    let mut query = world.query_filtered::<&Mass, With<Particle>>();
    query.iter(world).map(|m| m.0).sum()
}

#[test]
fn mass_scaling_scales_the_masses_and_the_step_and_keeps_the_weight() {
    let mut plain = bar("", 0.1, 1e-4, 1).simulation;
    let mut scaled = bar(", quasi_static: (mass_scaling: 25.0)", 0.1, 1e-4, 1).simulation;
    let (m, m_scaled) = (total_mass(&mut plain.world), total_mass(&mut scaled.world));
    assert!((m_scaled / m - 25.0).abs() < 1e-12, "{m} {m_scaled}");
    let (dt, dt_scaled) = (plain.stable_time_step(), scaled.stable_time_step());
    assert!((dt_scaled / dt - 5.0).abs() < 1e-12, "{dt} {dt_scaled}");
    let weight = |sim: &fractum_engine::Simulation, mass: f64| {
        sim.world.resource::<BodyForce<Two>>().0.y * mass
    };
    let (w, w_scaled) = (weight(&plain, m), weight(&scaled, m_scaled));
    assert!((w_scaled / w - 1.0).abs() < 1e-12, "{w} {w_scaled}");
}

/// Scaled by 4 and pulled at v, the bar is the unscaled bar pulled at 2v, read at twice the
/// time: the same reactions, energies and work at every row (the same number of CFL steps,
/// each twice as long), to round-off.
#[test]
fn mass_scaling_is_the_unscaled_run_loaded_faster_on_a_stretched_time_axis() {
    let steps = 400;
    let (_, header, scaled) = run_to_end(
        bar(", quasi_static: (mass_scaling: 4.0)", 0.5, 2e-4, steps),
        "scaled",
    );
    let (_, plain_header, faster) = run_to_end(
        bar(", quasi_static: (mass_scaling: 1.0)", 1.0, 1e-4, steps),
        "faster",
    );
    assert_eq!(header, plain_header);
    assert_eq!(scaled.len(), faster.len());
    let column = |name: &str| header.iter().position(|c| c == name).unwrap();
    let pulled = column("reaction_pull_x");
    let largest = faster.iter().map(|r| r[pulled].abs()).fold(0.0, f64::max);
    assert!(largest > 1e3, "the pull must load the bar: {largest} N");
    for (a, b) in scaled.iter().zip(&faster) {
        assert!((a[column("time")] - 2.0 * b[column("time")]).abs() < 1e-15);
        for name in [
            "reaction_pull_x",
            "reaction_clamp_y",
            "kinetic_energy",
            "strain_energy",
            "external_work",
            "kinetic_fraction",
        ] {
            let (x, y) = (a[column(name)], b[column(name)]);
            let scale = faster
                .iter()
                .map(|r| r[column(name)].abs())
                .fold(0.0, f64::max);
            assert!(
                (x - y).abs() <= 1e-9 * scale,
                "{name} at step {}: {x} scaled, {y} unscaled and twice as fast",
                a[0]
            );
        }
    }
}

/// The bar's wave crosses it in 20 µs. Pulled from rest at 1 mm/s over 200 µs and held for
/// 500 µs (many transits), its kinetic energy near the end is a small part of the stored; jerked
/// to 2 m/s at once and read within 25 µs (the wave has come back from the clamp once), it is
/// not.
#[test]
fn the_kinetic_check_tells_a_slow_pull_from_a_jerk() {
    let slow = run_to_end(bar(", quasi_static: ()", 1e-3, 2e-4, 1200), "slow");
    let jerk = run_to_end(bar(", quasi_static: ()", 2.0, 1e-9, 40), "jerk");
    let fraction = |(_, header, rows): &(RunSummary, Vec<String>, Vec<Vec<f64>>)| {
        let k = header.iter().position(|c| c == "kinetic_fraction").unwrap();
        rows.last().unwrap()[k]
    };
    assert!(fraction(&slow) < 0.05, "slow: {}", fraction(&slow));
    assert_eq!(slow.0.kinetic_excess, None);
    let excess = jerk.0.kinetic_excess.expect("a jerk is dynamic");
    assert!(excess.fraction > 0.5, "{excess:?}");
}
