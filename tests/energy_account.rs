//! The energy account closes with damage: `series.csv`'s `external_work` equals the change of
//! the kinetic and stored energy, plus what the damage laws report they dissipated, plus a
//! small residual, on the shipped quasi-static beam (`scenes/three_point_bending.ron`).

use fractum_engine::prelude::*;
use fractum_io::output::series_row;
use fractum_scene::SceneFile;
use fractum_suite::repo_root;

/// One series row of the beam, and where its damage is.
struct BeamRow {
    time: f64,
    reaction: f64,
    kinetic_fraction: f64,
    work: f64,
    dissipated: f64,
    residual: f64,
    /// The highest damaged particle's height above the beam's underside (m), if any.
    highest_damage: Option<f64>,
}

/// The shipped beam mass scaled 100 times (its peak within 0.6% of the 10-times scaling the
/// scene ships; 11 s on one release thread) and stopped at 30 ms, past its peak (about 21 ms),
/// with a row every 20 steps.
fn beam_rows() -> Vec<BeamRow> {
    let path = repo_root().join("scenes/three_point_bending.ron");
    let text = std::fs::read_to_string(&path).unwrap().replace(
        "end: Time(0.062), quasi_static: (mass_scaling: 10.0)",
        "end: Time(0.03), quasi_static: (mass_scaling: 100.0)",
    );
    assert!(
        text.contains("mass_scaling: 100.0"),
        "the scene's time line changed"
    );
    let file = SceneFile::parse("three_point_bending.ron", text).unwrap_or_else(|e| panic!("{e}"));
    let mut built = fractum_scene::build_simulation(&file, &fractum_systems::stock_registry())
        .unwrap_or_else(|e| panic!("{e}"));
    let names = built.output.columns();
    // Row values start after the `step` column.
    let column = |c: &str| names.iter().position(|n| n == c).expect(c) - 1;
    let [reaction, kinetic, work, dissipated, residual] = [
        "reaction_load_y",
        "kinetic_fraction",
        "external_work",
        "dissipated_energy",
        "energy_residual",
    ]
    .map(column);
    let sim = &mut built.simulation;
    let mut rows = Vec::new();
    while !sim.finished() {
        sim.step().unwrap_or_else(|e| panic!("{e}"));
        if !sim.clock().step.is_multiple_of(20) {
            continue;
        }
        let row = series_row(&mut sim.world, &built.output);
        let mut damaged = sim
            .world
            .query_filtered::<(&Position<Two>, &Damage), With<Particle>>();
        let highest_damage = damaged
            .iter(&sim.world)
            .filter(|(_, d)| d.0 > 0.0)
            .map(|(x, _)| x.0.y)
            .reduce(f64::max);
        rows.push(BeamRow {
            time: row[0],
            reaction: row[reaction],
            kinetic_fraction: row[kinetic],
            work: row[work],
            dissipated: row[dissipated],
            residual: row[residual],
            highest_damage,
        });
    }
    rows
}

/// The beam loaded at 2 mm/s and mass scaled: the loader only ever pushes, the damage stays
/// in the lower half of the ligament up to the peak (no spurious damage under the load, as
/// unlike the same beam pushed at 0.2 m/s unscaled, whose reaction swings from −4.6 to +1.0 kN),
/// and the energy account closes. Measured: peak 1859 N at 21.5 ms; the highest damaged
/// particle at the peak 29.3 mm up the 50 mm beam (49.3 mm, under the loader, when pushed at
/// 0.2 m/s); the residual at most 0.05% of the work
/// once the damage has started (against −8.2% with the uniaxial dissipation account the laws
/// published before, which read high under the beam's biaxial stress), while the damage
/// dissipates 45% of the work.
#[test]
fn a_quasi_static_rankine_beam_closes_its_energy_account() {
    let rows = beam_rows();
    let peak = rows
        .iter()
        .min_by(|a, b| a.reaction.total_cmp(&b.reaction))
        .unwrap();
    let last = rows.last().unwrap();
    let pulled = rows.iter().map(|r| r.reaction).fold(f64::MIN, f64::max);
    let worst_residual = rows
        .iter()
        .filter(|r| r.dissipated > 0.0)
        .map(|r| (r.residual / r.work).abs())
        .fold(0.0, f64::max);
    eprintln!(
        "beam: peak {:.1} N at {:.2} ms, highest damage at the peak {:?} m, largest pull {pulled} \
         N, residual at most {:.4}% of the work, dissipated {:.1}% of the work at the end",
        -peak.reaction,
        1e3 * peak.time,
        peak.highest_damage,
        100.0 * worst_residual,
        100.0 * last.dissipated / last.work
    );
    assert!(
        peak.time < last.time - 5e-3,
        "the run ended before the peak"
    );
    assert!(pulled <= 0.0, "the loader pulled: {pulled} N");
    let highest = peak.highest_damage.expect("damage before the peak");
    // Nothing damaged in the top 10 mm, under the loader (pushed at 0.2 m/s, a particle 49.3 mm
    // up is damaged by the peak).
    assert!(highest < 0.04, "damage {highest} m up the beam at the peak");
    // The kinetic-energy check of quasi-static runs, over the upper half of the loading.
    let half = 0.5 * peak.work;
    for r in rows.iter().filter(|r| r.work > half && r.time <= peak.time) {
        assert!(
            r.kinetic_fraction < 0.05,
            "{} at {}",
            r.kinetic_fraction,
            r.time
        );
    }
    // Closing: the damage laws' release account leaves a residual of 0.05% of the work; the
    // uniaxial account left −8%.
    assert!(last.dissipated > 0.3 * last.work, "{}", last.dissipated);
    assert!(worst_residual < 0.002, "residual {worst_residual}");
}
