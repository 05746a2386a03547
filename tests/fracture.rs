//! Fracture verification small enough for CI (`scenes/tension_softening.ron` in 2D and
//! `scenes/tension_softening_3d.ron` in 3D): homogeneous uniaxial tension, where the stress is
//! `E ε̇ t` in every particle, so the onset and the full failure of eigensoftening have exact
//! times.

use fractum_engine::diagnostics::totals;
use fractum_engine::prelude::*;
use fractum_suite::{load, repo_root};

/// Damage and onset strain of every particle after each step, in id order.
fn history(scene: &str) -> Vec<Vec<(f64, f64)>> {
    let mut built = load(&repo_root().join("scenes").join(scene)).unwrap_or_else(|e| panic!("{e}"));
    let sim = &mut built.simulation;
    let mut steps = Vec::new();
    while !sim.finished() {
        sim.step().unwrap_or_else(|e| panic!("{e}"));
        let mut query = sim
            .world
            .query_filtered::<(&ParticleId, &Damage, &DamageHistory), With<Particle>>();
        let mut rows: Vec<_> = query
            .iter(&sim.world)
            .map(|(id, d, h)| (id.0, d.0, h.0))
            .collect();
        rows.sort_by_key(|r| r.0);
        steps.push(rows.into_iter().map(|(_, d, h)| (d, h)).collect());
    }
    steps
}

/// A shipped scene with text edits (each `(from, to)` must match), built with the stock systems.
fn scene_with(scene: &str, edits: &[(&str, &str)]) -> fractum_scene::Built {
    let mut text = std::fs::read_to_string(repo_root().join("scenes").join(scene)).unwrap();
    for (from, to) in edits {
        assert!(text.contains(from), "{scene} has no {from:?}");
        text = text.replace(from, to);
    }
    let file = fractum_scene::SceneFile::parse(scene, text).unwrap_or_else(|e| panic!("{e}"));
    fractum_scene::build_simulation(&file, &fractum_systems::stock_registry())
        .unwrap_or_else(|e| panic!("{e}"))
}

/// Onset and failure of every particle against the analytic steps.
fn onset_and_failure_at_the_analytic_times(scene: &str) {
    let steps = history(scene);
    let particles = steps[0].len();
    // E = 1e4 Pa, ε̇ = 0.1 /s, Δt = 1e-5 s: σ = 0.01 n after step n passes f_t = 1.005 Pa
    // at step 100.5, so the first step with σ > f_t is 101.
    let onset_step = 101;
    // w_c = 2 G_F / f_t = 9.975e-6 m over h_ε = 0.05 m: a strain 1.995e-4 past the onset
    // strain, i.e. 199.5 steps; χ reaches 1 at the 200th step after onset.
    let failure_step = 301;
    let mut failures = Vec::new();
    for p in 0..particles {
        let cracked = steps.iter().position(|s| s[p].1 > 0.0);
        let onset = cracked.expect("the particle cracks") + 1;
        let failed = steps
            .iter()
            .position(|s| s[p].0 >= 1.0)
            .expect("the particle fails")
            + 1;
        failures.push(failed);
        // σ = 1000 t reaches f_t exactly at step 100; round-off decides between 100 and 101.
        assert!(
            onset.abs_diff(onset_step) <= 1,
            "particle {p}: onset at step {onset}"
        );
        // Below f_t nothing happens.
        let before = &steps[..onset - 1];
        assert!(
            before.iter().all(|s| s[p] == (0.0, 0.0)),
            "particle {p}: damage before onset"
        );
        // χ never decreases.
        let monotone = steps.windows(2).all(|w| w[1][p].0 >= w[0][p].0);
        assert!(monotone, "particle {p}: χ decreased");
    }
    // The field stays homogeneous, so every particle fails at the analytic step, except that
    // the column next to the prescribed end may fail one step early: its boundary nodes move at
    // the prescribed speed while interior node velocities come from the softening particles,
    // which lag them by O(Δt). Measured: 16 of 320 particles at step 300, the rest at 301 (2D);
    // 128 of 2560 (3D).
    let near = failures.iter().all(|f| f.abs_diff(failure_step) <= 1);
    assert!(near, "failures at steps {failures:?}");
    let on_time = failures.iter().filter(|f| **f == failure_step).count();
    assert!(
        on_time * 10 >= failures.len() * 9,
        "{on_time} of {} fail on time",
        failures.len()
    );
}

#[test]
fn eigensoftening_onset_and_failure_happen_at_the_analytic_times() {
    onset_and_failure_at_the_analytic_times("tension_softening.ron");
}

#[test]
fn eigensoftening_onset_and_failure_happen_at_the_analytic_times_in_3d() {
    onset_and_failure_at_the_analytic_times("tension_softening_3d.ron");
}

/// Runs a bar pulled at its right end at 0.1 m/s (the left end held, doing no work) to the
/// end of its scene. Returns the work of the right end and the kinetic energy at the start.
fn pull_to_the_end(sim: &mut fractum_engine::Simulation) -> (f64, f64) {
    let kinetic_start = totals(&mut sim.world).kinetic_energy;
    let right = sim
        .world
        .resource::<BoundaryConditions>()
        .regions
        .iter()
        .position(|r| r.name == "right")
        .unwrap();
    let mut work = 0.0;
    while !sim.finished() {
        sim.step().unwrap_or_else(|e| panic!("{e}"));
        work += sim.world.resource::<Reactions<Two>>().0[right].x * 0.1 * sim.clock().dt;
    }
    (work, kinetic_start)
}

#[test]
fn eigensoftening_absorbs_the_work_its_traction_law_implies() {
    // Eq. (16) scales the (still growing) elastic stress by 1 − χ, so the traction a cracking
    // point follows is (1 − χ(w)) E ε, not the cohesive law σ(w). With the linear law the work
    // per unit volume is ½ E ε_f² up to onset and E (ε_f Δ/2 + Δ²/6) after it, Δ = w_c/h_ε:
    // per unit crack area G_F (1 + E w_c / (3 h_ε f_t)) instead of G_F.
    let (e, rate, dt, volume): (f64, f64, f64, f64) = (1.0e4, 0.1, 1.0e-5, 1.0 * 0.2);
    let (ft, gf, band) = (1.005, 5.0124375e-6, 0.05);
    let onset_strain = rate * 101.0 * dt;
    let delta = 2.0 * gf / ft / band;
    let expected = volume
        * (0.5 * e * onset_strain.powi(2) + e * (onset_strain * delta / 2.0 + delta * delta / 6.0));

    let mut built =
        load(&repo_root().join("scenes/tension_softening.ron")).unwrap_or_else(|e| panic!("{e}"));
    let sim = &mut built.simulation;
    let (work, kinetic_start) = pull_to_the_end(sim);
    let kinetic_change = totals(&mut sim.world).kinetic_energy - kinetic_start;
    let absorbed = work - kinetic_change;
    // Measured: within 0.6%. 2% covers the discrete onset and the one-step lag of χ behind the
    // strain, both O(Δt / t_failure) = O(0.5%).
    assert!(
        (absorbed / expected - 1.0).abs() < 0.02,
        "absorbed {absorbed:e} J, expected {expected:e} J"
    );
    // The crack-band estimate in series.csv counts G_F per band; the scheme dissipates more,
    // by the factor above: 1 + E w_c / (3 h_ε f_t) = 1.66 here.
}

/// Work absorbed by the bar of `scenes/tension_softening.ron` (the right end's work less the
/// change of kinetic energy) with the cohesive traction, the softening law `shape`, band width
/// `band` and end time `end`; and the share of particles fully failed at the end.
fn cohesive_bar_absorbs(shape: &str, band: f64, end: f64) -> (f64, f64) {
    let band_text = format!("band_width: {band:e}");
    let shape_text = format!("softening: {shape}, traction: Cohesive,");
    let end_text = format!("end: Time({end:e})");
    let mut built = scene_with(
        "tension_softening.ron",
        &[
            ("band_width: 0.05", &band_text),
            ("softening: Linear,", &shape_text),
            ("end: Time(4.0e-3)", &end_text),
        ],
    );
    let sim = &mut built.simulation;
    let (work, kinetic_start) = pull_to_the_end(sim);
    let kinetic_change = totals(&mut sim.world).kinetic_energy - kinetic_start;
    let mut damage = sim.world.query_filtered::<&Damage, With<Particle>>();
    let all: Vec<f64> = damage.iter(&sim.world).map(|d| d.0).collect();
    let failed = all.iter().filter(|d| **d >= 1.0).count() as f64 / all.len() as f64;
    (work - kinetic_change, failed)
}

#[test]
fn cohesive_eigensoftening_dissipates_g_f_per_unit_crack_area_for_each_law() {
    use fractum_systems::damage::softening::{SofteningLaw, SofteningShape};
    // The bar (1 m x 0.2 m, unit thickness) cracks everywhere at once: every particle is a
    // band of width h_ε, so the crack area per unit volume is 1/h_ε and the bar must absorb
    // V G_F / h_ε. Each band is under its snap-back limit (E G_F / (c f_t²): 0.099, 0.050 and
    // 0.060 m for c = 1/2, 1, 5/6); each run lasts until the bar has failed.
    let (ft, gf, volume) = (1.005, 5.0124375e-6, 0.2);
    for (shape, law_shape, band, end) in [
        ("Linear", SofteningShape::Linear, 0.05, 4.0e-3),
        ("Exponential", SofteningShape::Exponential, 0.04, 1.2e-2),
        ("Bilinear", SofteningShape::Bilinear, 0.05, 6.0e-3),
    ] {
        let law = SofteningLaw {
            shape: law_shape,
            tensile_strength: ft,
            fracture_energy: gf,
        };
        // The exponential law is cut at f_t/1000: 0.1% of G_F is never dissipated.
        let expected = volume / band * law.dissipated(law.critical_opening());
        let (absorbed, failed) = cohesive_bar_absorbs(shape, band, end);
        println!(
            "{shape}: absorbed {absorbed:e} J against V G_F / h_ε = {expected:e} J ({:+.2}%), \
             failed {:.0}%",
            100.0 * (absorbed / expected - 1.0),
            100.0 * failed
        );
        assert_eq!(failed, 1.0, "{shape}: the bar has not failed by {end} s");
        assert!(
            (absorbed / expected - 1.0).abs() < 0.02,
            "{shape}: absorbed {absorbed:e} J, expected {expected:e} J"
        );
    }
}

/// Energy absorbed by the weak band of `scenes/tension_rankine.ron` once it has failed, with
/// the fracture energy and end time of the scene replaced by `fracture_energy` and `end`: the
/// work of the moving end less the change of kinetic energy and the stored elastic energy left
/// (which `damage/rankine` scales down where damage has opened). Returns (absorbed, A G_f).
fn rankine_band_absorbs(fracture_energy: f64, end: f64) -> (f64, f64) {
    let energy = format!("fracture_energy: {fracture_energy:e}");
    let time = format!("end: Time({end:e})");
    let mut built = scene_with(
        "tension_rankine.ron",
        &[
            ("fracture_energy: 1.26253125e-2", &energy),
            ("end: Time(4.5e-3)", &time),
        ],
    );
    let sim = &mut built.simulation;
    let (work, kinetic_start) = pull_to_the_end(sim);
    // The band has failed throughout, and nothing else is damaged.
    let names: Vec<String> = sim
        .world
        .resource::<Materials>()
        .0
        .iter()
        .map(|m| m.name.clone())
        .collect();
    let mut query = sim
        .world
        .query_filtered::<(&MaterialId, &Damage), With<Particle>>();
    for (material, damage) in query.iter(&sim.world) {
        let name = &names[material.0 as usize];
        let expected = if name == "band" { 1.0 } else { 0.0 };
        assert_eq!(damage.0, expected, "a particle of {name}");
    }
    let end = totals(&mut sim.world);
    let absorbed = work - (end.kinetic_energy - kinetic_start) - end.strain_energy;
    // The engine's energy account finds the same work (the end's displacement is exact).
    let account = sim
        .world
        .resource::<fractum_engine::energy::EnergyAccount>();
    assert!(
        (account.external_work / work - 1.0).abs() < 1e-9,
        "account {:e} J, reactions {work:e} J",
        account.external_work
    );
    (absorbed, 0.2 * fracture_energy)
}

#[test]
fn a_rankine_band_as_wide_as_its_length_absorbs_the_fracture_energy_per_unit_area() {
    // Two softening slopes (H̄_s l_ch = 0.02 and 0.0125): the same G_f per unit crack area.
    // Measured at the end of the runs: +1.9% and +0.7% (+0.4% in the first just after the
    // band fails; the rest is the numerical dissipation of the waves that follow).
    for (gf, end) in [(1.26253125e-2, 4.5e-3), (2.0200500e-2, 6.0e-3)] {
        let (absorbed, expected) = rankine_band_absorbs(gf, end);
        assert!(
            (absorbed / expected - 1.0).abs() < 0.05,
            "G_f {gf}: absorbed {absorbed:e} J, A G_f {expected:e} J"
        );
    }
}

/// The Rankine law's install check on strengths stays with the built world
/// (`StrengthChecks`), for strengths changed before the first step: in
/// `scenes/flyer_plate_spall.ron` (G_f = 2000 J/m², E = 190 GPa, l_ch the cell diagonal
/// 0.707 mm) it takes the scene's 570 MPa and refuses 2 GPa, above the snap-back bound
/// `√(2 E G_f / l_ch)` = 1.04 GPa, on the bar the law governs, and leaves the flyer's alone.
#[test]
fn a_rankine_law_keeps_its_strength_check_after_the_build() {
    use fractum_engine::strength::StrengthChecks;
    let built = scene_with("flyer_plate_spall.ron", &[]);
    let world = &built.simulation.world;
    let material = |name: &str| {
        let position = world
            .resource::<Materials>()
            .0
            .iter()
            .position(|m| m.name == name);
        MaterialId(position.unwrap() as u16)
    };
    let (bar, flyer) = (material("bar"), material("flyer"));
    let checks = world.resource::<StrengthChecks>();
    assert_eq!(checks.len(), 1);
    assert_eq!(checks.check(&[(bar, 570.0e6), (flyer, 570.0e6)]), Ok(()));
    assert_eq!(checks.check(&[(flyer, 2.0e9)]), Ok(()));
    let refused = checks.check(&[(bar, 570.0e6), (bar, 2.0e9)]).unwrap_err();
    assert!(
        refused.starts_with("damage/rankine refuses it") && refused.contains("σ_f = 2e9 Pa"),
        "{refused}"
    );
}

/// The crack tip of `scenes/time_to_failure_strip.ron` after each step, with the scene's
/// crack speed replaced by `crack_speed`: (time, the largest x of a fully failed particle on
/// the crack line).
fn time_to_failure_tip(crack_speed: f64) -> Vec<(f64, f64)> {
    time_to_failure_tip_refined(crack_speed, 1, None)
}

/// As [`time_to_failure_tip`], on a grid `refinement` times finer (the spacing, the step and
/// the notch's band divided by it) and with `characteristic_length` set when given.
fn time_to_failure_tip_refined(
    crack_speed: f64,
    refinement: u32,
    characteristic_length: Option<f64>,
) -> Vec<(f64, f64)> {
    let k = f64::from(refinement);
    let mut damage = format!("crack_speed: {crack_speed:?}");
    if let Some(length) = characteristic_length {
        damage += &format!(", characteristic_length: {length:?}");
    }
    let (spacing, step) = (
        format!("spacing: {:?})", 0.02 / k),
        format!("Fixed({:?})", 1.0e-5 / k),
    );
    let notch = format!(
        "Rectangle(min: (0.0, {:?}), max: (0.1, {:?}))",
        0.2 - 0.01 / k,
        0.2 + 0.01 / k
    );
    let mut built = scene_with(
        "time_to_failure_strip.ron",
        &[
            ("crack_speed: 200.0", &damage),
            ("spacing: 0.02)", &spacing),
            ("Fixed(1.0e-5)", &step),
            ("Rectangle(min: (0.0, 0.19), max: (0.1, 0.21))", &notch),
        ],
    );
    let sim = &mut built.simulation;
    let mut tips = Vec::new();
    while !sim.finished() {
        sim.step().unwrap_or_else(|e| panic!("{e}"));
        let mut query = sim
            .world
            .query_filtered::<(&Position<Two>, &Damage), With<Particle>>();
        let tip = query
            .iter(&sim.world)
            .filter(|(x, d)| d.0 >= 1.0 && (x.0.y - 0.2).abs() < 0.02)
            .map(|(x, _)| x.0.x)
            .fold(0.0, f64::max);
        tips.push((sim.clock().time, tip));
    }
    tips
}

/// The front's speed once the load has stopped rising (t > 2 ms), while the tip runs from
/// x = 0.2 to 0.9 m.
fn steady_front_speed(tips: &[(f64, f64)]) -> f64 {
    let steady: Vec<(f64, f64)> = tips
        .iter()
        .copied()
        .filter(|&(t, x)| t > 2.0e-3 && x > 0.2 && x < 0.9)
        .collect();
    assert!(
        steady.len() > 100,
        "the crack ran through too soon: {}",
        steady.len()
    );
    slope(&steady)
}

/// Least-squares slope of `points`.
fn slope(points: &[(f64, f64)]) -> f64 {
    let n = points.len() as f64;
    let (mt, mx) = points
        .iter()
        .fold((0.0, 0.0), |(a, b), (t, x)| (a + t / n, b + x / n));
    let (stx, stt) = points.iter().fold((0.0, 0.0), |(a, b), (t, x)| {
        (a + (t - mt) * (x - mx), b + (t - mt) * (t - mt))
    });
    stx / stt
}

/// At this resolution (h = 0.02 m, two particles per cell) the failure front runs at 0.915 c_f
/// for c_f = 100 m/s and 0.911 c_f for 200 m/s (measured). It is not the prescribed speed in
/// general, and this test does not claim it is. The front crosses one particle spacing s = h/2
/// in the time the particle behind it takes to reach the damage D* at which the next one passes
/// σ_f, so it runs at s / (D* τ), τ = l_ch / c_f. With the paper's l_ch, the cell diagonal, τ
/// shrinks with the grid while the zone ahead of the tip that is above σ_f keeps its size, so
/// the front speeds up under refinement (release runs, the scene's spacing, step and notch band
/// divided by k, least squares while the tip runs from x = 0.2 to 0.9 m after 2 ms):
///
/// | h | c_f = 100 m/s | c_f = 200 m/s |
/// | --- | --- | --- |
/// | 0.02 m | 0.91 c_f | 0.91 c_f |
/// | 0.01 m | 1.72 c_f | 1.54 c_f |
/// | 0.005 m | 3.00 c_f | 2.13 c_f (0.73 c_R) |
///
/// The paper's claim of a speed "predictable even as the mesh is refined" (its §2.7) needs τ
/// held fixed: see the next test.
#[test]
fn a_time_to_failure_crack_runs_within_ten_percent_of_c_f_at_the_shipped_resolution() {
    for crack_speed in [100.0, 200.0] {
        let speed = steady_front_speed(&time_to_failure_tip(crack_speed));
        eprintln!(
            "time-to-failure crack at c_f = {crack_speed} m/s: front speed {speed:.1} m/s ({:.3} of c_f)",
            speed / crack_speed
        );
        assert!(
            (speed / crack_speed - 1.0).abs() < 0.10,
            "crack speed {speed} m/s against c_f {crack_speed} m/s"
        );
    }
}

/// With `characteristic_length` held at the shipped grid's cell diagonal, the time-to-failure
/// front converges under refinement: its speed on a grid twice as fine is within 10% of the
/// shipped grid's, for two values of c_f. Measured here: 0.915 and 0.867 c_f at h and h/2 for
/// c_f = 100 m/s, 0.911 and 0.859 c_f for 200 m/s; at h/4 0.852 and 0.832 c_f (release runs,
/// the tip read from frames every 0.1 ms). The front
/// advances about 0.021–0.024 m (the zone above σ_f ahead of its tip) per τ whatever the grid,
/// so its speed is set by τ, not by c_f alone: it is within 10% of c_f only at h.
#[test]
fn a_time_to_failure_front_converges_with_a_fixed_characteristic_length() {
    let diagonal = 0.02 * 2f64.sqrt();
    for crack_speed in [100.0, 200.0] {
        let speeds: Vec<f64> = [1, 2]
            .iter()
            .map(|&k| {
                steady_front_speed(&time_to_failure_tip_refined(crack_speed, k, Some(diagonal)))
            })
            .collect();
        eprintln!(
            "time-to-failure front, l_ch fixed at {diagonal:.4} m, c_f = {crack_speed} m/s: \
             {:.3} c_f at h = 0.02 m, {:.3} c_f at 0.01 m",
            speeds[0] / crack_speed,
            speeds[1] / crack_speed
        );
        assert!(
            (speeds[1] / speeds[0] - 1.0).abs() < 0.10,
            "c_f {crack_speed}: {speeds:?} m/s"
        );
    }
}

#[test]
fn weibull_strengths_follow_eq_25_per_particle_and_reach_the_frames() {
    // The strip with Weibull strengths: 0.4 m² × 1 mm particles of 1e-4 m² × 1e-3 m = 1e-7 m³
    // against a reference volume of 1e-7 m³, so the median stays σ̄_f = 100 Pa.
    let mut built = scene_with(
        "time_to_failure_strip.ron",
        &[(
            "crack_speed: 200.0)",
            "crack_speed: 200.0, weibull: (modulus: 6.0, reference_volume: 1.0e-7, seed: 11, \
             thickness: 1.0e-3))",
        )],
    );
    let world = &mut built.simulation.world;
    let mut query =
        world.query_filtered::<(&ParticleId, &InitialVolume, &Strength), With<Particle>>();
    let mut strengths = Vec::new();
    for (id, v0, s) in query.iter(world) {
        // The scene's thickness is 1 m; the option's 1 mm makes the volume 1e-3 of V₀.
        let r = fractum_systems::damage::weibull::uniform(11, id.0);
        let expected =
            fractum_systems::damage::weibull::weibull_strength(100.0, 1.0e-7, 6.0, v0.0 * 1e-3, r);
        assert_eq!(s.0, expected, "particle {}", id.0);
        strengths.push(s.0);
    }
    strengths.sort_by(f64::total_cmp);
    let median = strengths[strengths.len() / 2];
    assert!((median / 100.0 - 1.0).abs() < 0.05, "median {median}");
    let frame = fractum_io::output::particle_frame(world);
    let written = frame
        .scalars
        .iter()
        .find(|(name, _)| name == "strength")
        .expect("a strength array in the frame");
    assert_eq!(written.1.len(), strengths.len());
}

/// A frame's `strength` holds only strengths a law defines: in `tension_rankine.ron` the band's
/// particles carry the law's σ_f, the bar's (no strength law) NaN, never an infinity.
#[test]
fn frames_show_strength_only_where_a_law_governs() {
    let mut built = scene_with("tension_rankine.ron", &[]);
    let world = &mut built.simulation.world;
    let frame = fractum_io::output::particle_frame(world);
    let (_, strength) = frame
        .scalars
        .iter()
        .find(|(name, _)| name == "strength")
        .expect("a strength array in the frame");
    let band = world
        .resource::<Materials>()
        .0
        .iter()
        .position(|m| m.name == "band")
        .map(|i| i as u16);
    let mut query = world.query_filtered::<&MaterialId, With<Particle>>();
    let materials: Vec<MaterialId> = query.iter(world).copied().collect();
    let governed = materials.iter().filter(|m| Some(m.0) == band).count();
    assert!(governed > 0 && governed < materials.len(), "{governed}");
    for (m, s) in materials.iter().zip(strength) {
        if Some(m.0) == band {
            assert!(s.is_finite() && *s > 0.0, "{s}");
        } else {
            assert!(s.is_nan(), "{s}");
        }
    }
}

#[test]
fn rankine_leaves_the_damage_a_scene_seeds_out_of_its_dissipated_energy() {
    // The band of tension_rankine.ron with its lower half seeded as failed: after a step far
    // below the strength, nothing has been dissipated, though 8 particles are failed.
    let mut built = scene_with(
        "tension_rankine.ron",
        &[(
            "            material: \"band\",\n",
            "            material: \"band\",\n            cracks: [Rectangle(min: (0.5, 0.0), max: (0.55, 0.1))],\n",
        )],
    );
    let sim = &mut built.simulation;
    sim.step().unwrap_or_else(|e| panic!("{e}"));
    let columns = sim.world.resource::<SeriesColumns>();
    let value = |name: &str| columns.value(name).unwrap();
    assert_eq!(value("failed_particles"), 8.0);
    assert!(
        value("dissipated_energy").abs() < 1e-18,
        "{}",
        value("dissipated_energy")
    );
}

#[test]
fn eigensoftening_leaves_the_damage_a_scene_seeds_out_of_its_dissipated_energy() {
    // tension_softening.ron with a notch seeded as failed across the bar's lower half at mid
    // length: after a step far below the strength, nothing has been dissipated, though the
    // notch's particles are failed (each would count G_F V₀ / h_ε otherwise).
    for traction in ["Published", "Cohesive"] {
        let mut built = scene_with(
            "tension_softening.ron",
            &[
                (
                    "            material: \"brittle\",\n",
                    "            material: \"brittle\",\n            cracks: [Rectangle(min: (0.5, 0.0), max: (0.55, 0.1))],\n",
                ),
                (
                    "            softening: Linear,\n",
                    &format!("            softening: Linear,\n            traction: {traction},\n"),
                ),
            ],
        );
        let sim = &mut built.simulation;
        sim.step().unwrap_or_else(|e| panic!("{e}"));
        let columns = sim.world.resource::<SeriesColumns>();
        assert_eq!(columns.value("failed_particles"), Some(8.0), "{traction}");
        let dissipated = columns.value("dissipated_energy").unwrap();
        assert!(dissipated.abs() < 1e-18, "{traction}: {dissipated:e}");
    }
}

/// The tension bar with `damage/rankine` on its band and `damage/time_to_failure` on the rest:
/// both publish `damaged_particles` and `failed_particles`, and the published columns count
/// the whole bar (they were the last entry's alone).
#[test]
fn damage_columns_of_entries_split_by_material_add_up() {
    let time_to_failure = "        (system: \"damage/time_to_failure\", params: (tensile_strength: \
                           100.5, crack_speed: 200.0), materials: [\"bar\"]),\n        \
                           (system: \"advection/usl\"),";
    let mut built = scene_with(
        "tension_rankine.ron",
        &[("        (system: \"advection/usl\"),", time_to_failure)],
    );
    assert_eq!(
        built.output.system_columns,
        ["damaged_particles", "failed_particles", "dissipated_energy"]
    );
    let sim = &mut built.simulation;
    let bar = MaterialId(0);
    let mut counted = (0, 0);
    for _ in 0..200 {
        sim.step().unwrap_or_else(|e| panic!("{e}"));
        let mut query = sim.world.query::<(&MaterialId, &Damage)>();
        let (mut damaged, mut failed) = (0.0, 0.0);
        counted = (0, 0);
        for (m, d) in query.iter(&sim.world) {
            damaged += f64::from(u8::from(d.0 > 0.0));
            failed += f64::from(u8::from(d.0 >= 1.0));
            if d.0 > 0.0 {
                if *m == bar {
                    counted.0 += 1
                } else {
                    counted.1 += 1
                }
            }
        }
        let columns = sim.world.resource::<SeriesColumns>();
        let step = sim.clock().step;
        assert_eq!(
            columns.value("damaged_particles"),
            Some(damaged),
            "step {step}"
        );
        assert_eq!(
            columns.value("failed_particles"),
            Some(failed),
            "step {step}"
        );
    }
    // Both entries have damaged particles, so the columns hold a sum.
    assert!(counted.0 > 0 && counted.1 > 0, "{counted:?}");
}
