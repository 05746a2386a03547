//! The first paper's edge-cracked panel (eigensoftening-lme-mpm.md §3.1, Fig. 4), at the
//! paper's resolution: the shipped scenes `edge_cracked_panel_{lme,linear,griffith}.ron`.
//!
//! - Before cracking, R/u is 1.98 (plane-strain finite elements, lateral edges free).
//! - The published LME curve peaks at R = 0.0301 for u = 0.0154 and falls to about zero within
//!   Δu ≈ 0.002; the linear basis wiggles where LME stays straight.
//! - With the Griffith-consistent normalisation the peak is linear-elastic fracture mechanics':
//!   R = 0.0129 at u = 0.0065. The refinement study towards it is the `griffith_h*` cases of `fractum verify`
//!   (docs/verification/; too large here).

use fractum_cli::plot::{CurveSummary, curve_summary};
use fractum_io::output::series_row;
use fractum_suite::repo_root;

/// Plane-strain finite-element slope R/u of the cracked panel before cracking.
const ELASTIC_SLOPE: f64 = 1.98;

/// `(u, R)` of a shipped panel scene every 10 steps, up to simulated time `end`.
fn load_curve(scene: &str, end: f64) -> (Vec<f64>, Vec<f64>) {
    let path = repo_root().join("scenes").join(scene);
    let text = std::fs::read_to_string(&path).unwrap();
    let file = fractum_scene::SceneFile::parse(scene, text).unwrap_or_else(|e| panic!("{e}"));
    let mut built = fractum_scene::build_simulation(&file, &fractum_systems::stock_registry())
        .unwrap_or_else(|e| panic!("{e}"));
    built
        .simulation
        .set_end(fractum_engine::simulation::End::Time(end));
    let names = built.output.columns();
    // Row values start after the `step` column.
    let column = |name: &str| names.iter().position(|n| n == name).expect(name) - 1;
    let (u_column, r_column) = (column("displacement_top_y"), column("reaction_top_y"));
    let sim = &mut built.simulation;
    let (mut u, mut r) = (Vec::new(), Vec::new());
    while !sim.finished() {
        sim.step().unwrap_or_else(|e| panic!("{scene}: {e}"));
        if sim.clock().step.is_multiple_of(10) {
            let row = series_row(&mut sim.world, &built.output);
            u.push(row[u_column]);
            r.push(row[r_column]);
        }
    }
    (u, r)
}

/// Peak, pre-peak slope and wiggle from u = 0.002 (past the 1 s ramp), as `fractum curve`.
fn summary(scene: &str, u: &[f64], r: &[f64]) -> CurveSummary {
    let s = curve_summary(u, r, 0.002).expect("a rising curve");
    println!(
        "{scene}: peak {:.5} at u = {:.5}, slope {:.4}, wiggle {:.2}% of the peak",
        s.peak,
        s.x_at_peak,
        s.slope,
        100.0 * s.rms_deviation / s.peak
    );
    s
}

/// How far past the peak the reaction first drops below 5% of it.
fn drop_after_peak(u: &[f64], r: &[f64], s: &CurveSummary) -> f64 {
    let peak = r.iter().position(|&x| x == s.peak).unwrap();
    let fallen = (peak..r.len())
        .find(|&k| r[k] < 0.05 * s.peak)
        .expect("the reaction falls after the peak");
    u[fallen] - s.x_at_peak
}

#[test]
fn lme_panel_matches_the_published_curve_and_stays_straight_where_linear_wiggles() {
    // Both scenes to u = 0.019: past both peaks and the LME fall (the scenes run to 0.0205).
    let (u, r) = load_curve("edge_cracked_panel_lme.ron", 19.5);
    let lme = summary("LME", &u, &r);
    let fall = drop_after_peak(&u, &r, &lme);
    println!("LME: reaction below 5% of the peak {fall:.5} after it");
    let (u_linear, r_linear) = load_curve("edge_cracked_panel_linear.ron", 19.5);
    let linear = summary("linear", &u_linear, &r_linear);

    assert!(
        (lme.slope / ELASTIC_SLOPE - 1.0).abs() < 0.05,
        "elastic slope {} against {ELASTIC_SLOPE}",
        lme.slope
    );
    assert!((lme.peak / 0.030 - 1.0).abs() < 0.15, "peak {}", lme.peak);
    assert!(
        (lme.x_at_peak / 0.0155 - 1.0).abs() < 0.10,
        "u at the peak {}",
        lme.x_at_peak
    );
    assert!(fall < 0.002, "the reaction takes Δu = {fall} to fall");
    assert!(
        lme.rms_deviation / lme.peak < linear.rms_deviation / linear.peak,
        "LME wiggles {} against linear's {}",
        lme.rms_deviation / lme.peak,
        linear.rms_deviation / linear.peak
    );
}

#[test]
fn griffith_normalisation_peaks_at_linear_elastic_fracture_mechanics() {
    let (u, r) = load_curve("edge_cracked_panel_griffith.ron", 9.0);
    let griffith = summary("Griffith", &u, &r);
    // At the shipped h = 0.025 (4 cells per crack length); `fractum verify` has the refinement.
    assert!(
        (griffith.peak / 0.0129 - 1.0).abs() < 0.10,
        "peak {}",
        griffith.peak
    );
    assert!(
        (griffith.x_at_peak / 0.0065 - 1.0).abs() < 0.10,
        "u at the peak {}",
        griffith.x_at_peak
    );
    assert!(drop_after_peak(&u, &r, &griffith) < 0.002);
}
