//! Verification against analytic solutions (issue: MPM core). Tolerances are the ones the
//! specification states, or are justified next to the assertion.

use fractum_engine::run::series_row;
use fractum_engine::scene::{SceneFile, build_simulation};
use fractum_suite::repo_root;

/// `(time, value)` of each of `columns`, sampled every `every` steps, from the scene with its
/// pipeline replaced by `pipeline` (or kept when `None`).
fn history(
    scene: &str,
    pipeline: Option<&str>,
    columns: &[&str],
    every: u64,
) -> Vec<Vec<(f64, f64)>> {
    let mut text = std::fs::read_to_string(repo_root().join("scenes").join(scene)).unwrap();
    if let Some(pipeline) = pipeline {
        let start = text.find("    pipeline: [").unwrap();
        text = format!("{}    pipeline: [{pipeline}],\n)\n", &text[..start]);
    }
    let file = SceneFile::parse(scene, text).unwrap_or_else(|e| panic!("{e}"));
    let registry = fractum_systems::stock_registry();
    let mut built = build_simulation(&file, &registry).unwrap_or_else(|e| panic!("{e}"));
    let names = built.output.columns();
    // Row values start after the `step` column.
    let indices: Vec<usize> = columns
        .iter()
        .map(|c| names.iter().position(|n| n == c).expect("column") - 1)
        .collect();
    let sim = &mut built.simulation;
    let mut series = vec![Vec::new(); columns.len()];
    loop {
        if sim.clock().step.is_multiple_of(every) {
            let row = series_row(&mut sim.world, &built.output);
            for (k, &i) in indices.iter().enumerate() {
                series[k].push((row[0], row[i]));
            }
        }
        if sim.finished() {
            break;
        }
        sim.step().unwrap_or_else(|e| panic!("{e}"));
    }
    series
}

/// Zero crossings of a sampled signal, by linear interpolation.
fn zero_crossings(samples: &[(f64, f64)]) -> Vec<f64> {
    samples
        .windows(2)
        .filter(|w| w[0].1 * w[1].1 < 0.0)
        .map(|w| w[0].0 - w[0].1 * (w[1].0 - w[0].0) / (w[1].1 - w[0].1))
        .collect()
}

struct BarErrors {
    period: f64,
    amplitude: f64,
}

/// Errors of the centre-of-mass velocity against `(2 v0/π) cos(ω t)` over three periods:
/// relative period error (mean of the periods between zero crossings) and the largest relative
/// error of the peak in each period.
fn bar_errors(samples: &[(f64, f64)]) -> BarErrors {
    let (period, amplitude) = (10.0, 2.0 * 0.1 / std::f64::consts::PI);
    let crossings = zero_crossings(samples);
    assert!(crossings.len() >= 5, "{crossings:?}");
    let periods: Vec<f64> = crossings.windows(2).map(|w| 2.0 * (w[1] - w[0])).collect();
    let mean_period = periods.iter().sum::<f64>() / periods.len() as f64;
    let peak_error = (0..3)
        .map(|k| {
            let peak = samples
                .iter()
                .filter(|(t, _)| *t >= k as f64 * period && *t < (k + 1) as f64 * period)
                .map(|(_, v)| v.abs())
                .fold(0.0, f64::max);
            (peak / amplitude - 1.0).abs()
        })
        .fold(0.0, f64::max);
    BarErrors {
        period: (mean_period / period - 1.0).abs(),
        amplitude: peak_error,
    }
}

#[test]
fn bar_first_mode_lme_newmark_is_within_one_percent() {
    let errors = bar_errors(&history("bar_vibration.ron", None, &["com_velocity_x"], 5)[0]);
    // Specification: LME + Newmark within 1% in period and amplitude over three periods.
    // Measured: period 0.06%, amplitude 0.40% (the predictor-corrector damps the amplitude by
    // about π ω Δt / 2 per period; the scene's Δt = 0.002 keeps three periods inside 1%).
    assert!(errors.period < 0.01, "period error {}", errors.period);
    assert!(
        errors.amplitude < 0.01,
        "amplitude error {}",
        errors.amplitude
    );
}

#[test]
fn bar_first_mode_linear_usl_is_within_one_percent() {
    let pipeline = r#"(system: "basis/linear"), (system: "predictor/usl"),
        (system: "stress/linear_elastic"), (system: "advection/usl")"#;
    let errors =
        bar_errors(&history("bar_vibration.ron", Some(pipeline), &["com_velocity_x"], 5)[0]);
    // Measured: period 0.06%, amplitude 0.01%; 1% is the specification's bound for the
    // reference pair, applied here too so that a regression in USL is caught.
    assert!(errors.period < 0.01, "period error {}", errors.period);
    assert!(
        errors.amplitude < 0.01,
        "amplitude error {}",
        errors.amplitude
    );
}

fn disks(pipeline: &str) -> (Vec<(f64, f64)>, f64) {
    let mut series = history(
        "two_disks.ron",
        Some(pipeline),
        &["total_energy", "momentum_x", "momentum_y"],
        10,
    );
    let largest = series[1..]
        .iter()
        .flatten()
        .map(|(_, p)| p.abs())
        .fold(0.0, f64::max);
    (series.swap_remove(0), largest)
}

const LINEAR: &str = r#"(system: "basis/linear")"#;
const LME: &str = r#"(system: "basis/lme", params: (gamma: 3.5))"#;
const USL: &str =
    r#"(system: "predictor/usl"), (system: "stress/linear_elastic"), (system: "advection/usl")"#;
const NEWMARK: &str = r#"(system: "predictor/newmark"), (system: "stress/linear_elastic"),
    (system: "corrector/newmark"), (system: "advection/newmark")"#;

fn check_disks(basis: &str, integrator: &str, allowed_rise: f64) {
    let (energy, momentum) = disks(&format!("{basis}, {integrator}"));
    // Each disk carries 130 kg·0.14 m/s ≈ 18 kg m/s in opposite directions: the total must stay
    // at round-off.
    assert!(momentum < 1e-12, "momentum {momentum:e}");
    let e0 = energy[0].1;
    let peak = energy.iter().map(|(_, e)| *e).fold(0.0, f64::max);
    assert!(
        peak <= e0 * (1.0 + allowed_rise),
        "energy rose to {peak} from {e0}"
    );
    let end = energy.last().unwrap().1;
    assert!(end < e0, "no energy lost through impact: {end} vs {e0}");
}

#[test]
fn two_disks_newmark_conserves_momentum_and_never_gains_energy() {
    // The predictor-corrector is dissipative by construction: the energy must not rise at all
    // (round-off allowance only).
    check_disks(LINEAR, NEWMARK, 1e-12);
    check_disks(LME, NEWMARK, 1e-12);
}

#[test]
fn two_disks_usl_conserves_momentum_and_energy_stays_bounded() {
    // USL exchanges kinetic and stored energy with an O(Δt) phase lag, so their sum oscillates
    // slightly before it decays: measured +0.026% (linear) and +0.021% (LME) before impact.
    // 0.1% bounds that oscillation; a real instability grows far beyond it.
    check_disks(LINEAR, USL, 1e-3);
    check_disks(LME, USL, 1e-3);
}
