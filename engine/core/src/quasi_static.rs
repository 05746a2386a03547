//! Quasi-static runs: mass scaling, and the check that users of explicit codes rely on to tell
//! a quasi-static answer from a dynamic one, the kinetic energy a small fraction of the stored
//! energy.
//!
//! An explicit scheme's stable step is `h / c` with `c = √(M/ρ)` the wave speed, so a test
//! loaded over a tenth of a second (semicircular bending at 2 mm/s) takes hundreds of thousands
//! of steps, almost all spent resolving waves that cross the specimen a thousand times before
//! the peak. **Mass scaling** multiplies every density by a factor `α ≥ 1`: the wave speed falls
//! by `√α`, the stable step grows by `√α`, and the inertia forces grow by `α`. Loads, supports,
//! and the body force's weight stay as the scene gives them (the body force, an acceleration, is
//! divided by `α` so that `α m · b/α` is the scene's weight).
//!
//! For a material without a rate (elasticity, the softening laws, friction) mass scaling by `α`
//! at loading speed `v` is the same dynamics as the unscaled run loaded at `√α v`, read on a
//! time axis stretched by `√α` (substitute `t = √α τ` in `α M ü + f(u) = f_ext`). It is sound
//! while inertia stays small against the stored energy, which is what the check measures:
//! `kinetic_fraction = K / U` in `series.csv`, `K` the kinetic energy of the scaled masses (the
//! inertia the scaled run carries) and `U` the stored energy (strain and contact). Laws with a
//! time of their own (time-to-failure damage, a shock viscosity) see the scene's real time, so
//! scaling changes their answer: their installs declare it ([`RealTimeLaws`]), and `check` and
//! the run warn when such a pipeline is mass scaled.
//!
//! [`KineticWatch`] judges the upper half of the loading: the rows whose stored energy is at
//! least half the largest so far, up to the row of that largest. The loading ends at the row
//! at which the stored energy falls below [`LOADING_ENDS_BELOW`] of its peak (the specimen has
//! lost stiffness: a crack has run, or the load is taken off; what follows, fragments flying
//! or halves ringing, says nothing about the loading). The start of a loading from rest is always dynamic (the body has not felt the
//! load yet, and little is stored); what decides a quasi-static answer is the fraction where
//! the load is near its peak. The run reports the worst row of that window when it passes the
//! limit.
//!
//! The fraction sees inertia in the loading; it cannot see how far the loader moves while an
//! unstable crack runs from a notch (a time set by the scaled wave speed, so the load's
//! overshoot past the peak grows as `√α v`). Where the answer is a peak load, compare the peak
//! at two scalings (SCENES.md, "Quasi-static loading").

use bevy_ecs::prelude::*;

/// The fraction `K / U` past which a quasi-static run is reported as dynamic, unless the scene
/// sets its own: the 5% that explicit codes' users hold a quasi-static run to (the guidance of
/// the commercial explicit codes is 5–10% over most of the process).
pub const DEFAULT_KINETIC_LIMIT: f64 = 0.05;

/// The fraction of its peak below which a falling stored energy ends the loading the
/// [`KineticWatch`] judges: a drop larger than the ringing of a quasi-static loading (its
/// kinetic energy is a few percent of the stored), smaller than what a crack that runs releases.
pub const LOADING_ENDS_BELOW: f64 = 0.9;

/// A scene's quasi-static settings, a resource of its world when the scene asks for them.
#[derive(Resource, Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct QuasiStatic {
    /// Factor on every density, `≥ 1` (1: no scaling).
    pub mass_scaling: f64,
    /// The kinetic fraction `K / U` past which the run is reported as dynamic.
    pub kinetic_limit: f64,
}

impl Default for QuasiStatic {
    fn default() -> Self {
        Self {
            mass_scaling: 1.0,
            kinetic_limit: DEFAULT_KINETIC_LIMIT,
        }
    }
}

/// `K / U`, with the stored energy `U` never taken below `floor` (the round-off floor of the
/// energy in play): finite at rest, and zero while nothing moves.
pub fn kinetic_fraction(kinetic: f64, stored: f64, floor: f64) -> f64 {
    let stored = stored.max(floor);
    if kinetic <= 0.0 || stored <= 0.0 {
        return 0.0;
    }
    kinetic / stored
}

/// One series row whose kinetic fraction passed the limit.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct KineticExcess {
    /// Step of the row.
    pub step: u64,
    /// Simulated time of the row (s).
    pub time: f64,
    /// `K / U` at the row.
    pub fraction: f64,
}

/// A series row of the upper half of the loading.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
struct LoadingRow {
    step: u64,
    time: f64,
    stored: f64,
    fraction: f64,
}

/// Follows the kinetic fraction of a quasi-static run's series rows over the upper half of its
/// loading (see the module's text), a resource the run loop updates at every row.
#[derive(Resource, Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct KineticWatch {
    /// The fraction past which the loading is reported as dynamic.
    pub limit: f64,
    /// The least stored energy the fraction is taken against (J; per scene thickness in 2D).
    pub floor: f64,
    /// The largest stored energy seen so far.
    pub peak_stored: f64,
    /// The step of the row with the largest stored energy so far.
    pub peak_step: u64,
    /// Whether the loading is over (the stored energy fell below [`LOADING_ENDS_BELOW`] of its
    /// peak).
    pub broken: bool,
    /// The rows whose stored energy is at least half the largest so far, before the break.
    upper: Vec<LoadingRow>,
}

crate::checkpoint_keys! { KineticWatch => "engine/kinetic_watch" }

impl KineticWatch {
    /// A watch that reports fractions above `limit`, taken against no less than `floor` J.
    pub fn new(limit: f64, floor: f64) -> Self {
        Self {
            limit,
            floor: floor.max(0.0),
            ..Self::default()
        }
    }

    /// Takes in one series row: its step, time, kinetic and stored energy. Returns true at the
    /// row that ends the loading (the stored energy falls below [`LOADING_ENDS_BELOW`] of its
    /// peak) when the upper half of the loading passed the limit.
    pub fn observe(&mut self, step: u64, time: f64, kinetic: f64, stored: f64) -> bool {
        if !(kinetic.is_finite() && stored.is_finite()) || self.broken {
            return false;
        }
        if stored > self.peak_stored {
            self.peak_stored = stored;
            self.peak_step = step;
            let half = 0.5 * stored;
            self.upper.retain(|row| row.stored >= half);
        }
        if stored < LOADING_ENDS_BELOW * self.peak_stored {
            self.broken = true;
            return self.excess().is_some();
        }
        if stored > self.floor {
            self.upper.push(LoadingRow {
                step,
                time,
                stored,
                fraction: kinetic_fraction(kinetic, stored, self.floor),
            });
        }
        false
    }

    /// The row of the upper half of the loading up to the largest stored energy so far (the
    /// whole of it once [`KineticWatch::broken`]) with the largest kinetic fraction, when that
    /// passes the limit. Rows after the peak are left out: a crack that runs from the peak
    /// turns stored energy into kinetic before the stored energy has fallen far.
    pub fn excess(&self) -> Option<KineticExcess> {
        self.upper
            .iter()
            .filter(|row| row.step <= self.peak_step && row.fraction > self.limit)
            .max_by(|a, b| a.fraction.total_cmp(&b.fraction))
            .map(|row| KineticExcess {
                step: row.step,
                time: row.time,
                fraction: row.fraction,
            })
    }
}

/// The pipeline's laws that read the scene's real time (a failure time, a rate), which mass
/// scaling does not stretch, so that scaling changes their answer: each install declares itself
/// with [`Installer::declare_real_time`](crate::registry::Installer::declare_real_time).
#[derive(Resource, Clone, Debug, Default, PartialEq)]
pub struct RealTimeLaws(pub Vec<RealTimeLaw>);

/// One law that reads the scene's real time.
#[derive(Clone, Debug, PartialEq)]
pub struct RealTimeLaw {
    /// The system's registration name.
    pub system: String,
    /// What in it reads the real time, in a few words.
    pub why: String,
}

impl RealTimeLaws {
    /// What `check` and the run say when the pipeline is mass scaled by `mass_scaling` (> 1)
    /// and has such laws; `None` otherwise.
    pub fn warning(&self, mass_scaling: f64) -> Option<String> {
        if mass_scaling <= 1.0 || self.0.is_empty() {
            return None;
        }
        let laws: Vec<String> = self
            .0
            .iter()
            .map(|law| format!("{} ({})", law.system, law.why))
            .collect();
        Some(format!(
            "the run is mass scaled {mass_scaling} times, and {} read{} the scene's real time, \
             which scaling does not stretch: where the scaled run's waves go {:.3} times \
             slower, these laws do not, so their answer changes with the scaling. Compare with \
             an unscaled run, or leave time.quasi_static.mass_scaling at 1.",
            laws.join(" and "),
            if self.0.len() == 1 { "s" } else { "" },
            mass_scaling.sqrt()
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_fraction_is_finite_at_rest_and_zero_while_nothing_moves() {
        assert_eq!(kinetic_fraction(0.0, 0.0, 1e-9), 0.0);
        assert_eq!(kinetic_fraction(2e-9, 0.0, 1e-9), 2.0);
        assert_eq!(kinetic_fraction(1.0, 4.0, 1e-9), 0.25);
    }

    /// Rows below the floor are quiet; the fast start of the loading is forgotten once the
    /// stored energy has doubled past it; once the stored energy has fallen below 90% of its
    /// peak (a crack ran), the ringing halves are not judged.
    #[test]
    fn the_watch_judges_the_upper_half_of_the_loading_and_not_the_fragments() {
        let mut watch = KineticWatch::new(0.05, 1e-6);
        assert!(!watch.observe(0, 0.0, 0.0, 0.0));
        assert!(!watch.observe(1, 0.1, 1e-7, 1e-7));
        // The start: a large fraction while little is stored.
        assert!(!watch.observe(2, 0.2, 0.4, 1.0));
        assert_eq!(watch.excess().map(|e| e.step), Some(2));
        assert!(!watch.observe(3, 0.3, 0.06, 2.0));
        assert!(!watch.observe(4, 0.4, 0.03, 3.0));
        // Half the peak is now 1.5: row 2 is out; rows 3 (3%) and 4 (1%) pass.
        assert_eq!(watch.excess(), None);
        assert!(!watch.observe(5, 0.5, 0.4, 4.0));
        assert_eq!(watch.excess().map(|e| e.step), Some(5));
        // 3.7 is within 90% of the peak: still the loading, but past its peak, where a crack
        // that runs turns stored energy into kinetic: not judged.
        assert!(!watch.observe(6, 0.6, 3.0, 3.7));
        // Broken: 3.5 < 3.6; the excess of row 5 is reported at the break.
        assert!(watch.observe(7, 0.7, 50.0, 3.5));
        assert!(watch.broken);
        assert!(!watch.observe(8, 0.8, 50.0, 3.9));
        let excess = watch.excess().unwrap();
        assert_eq!((excess.step, excess.fraction), (5, 0.1));
    }

    #[test]
    fn a_slow_loading_passes() {
        let mut watch = KineticWatch::new(0.05, 1e-6);
        for k in 1..=10_u32 {
            let stored = f64::from(k * k);
            assert!(!watch.observe(k.into(), f64::from(k), 0.01 * stored, stored));
        }
        assert!(!watch.observe(11, 11.0, 5.0, 80.0));
        assert!(watch.broken);
        assert_eq!(watch.excess(), None);
    }

    #[test]
    fn real_time_laws_are_named_only_when_the_run_is_scaled() {
        let mut laws = RealTimeLaws::default();
        assert_eq!(laws.warning(16.0), None);
        laws.0.push(RealTimeLaw {
            system: "damage/time_to_failure".into(),
            why: "its failure time".into(),
        });
        assert_eq!(laws.warning(1.0), None);
        let warning = laws.warning(16.0).unwrap();
        assert!(
            warning.contains("damage/time_to_failure (its failure time) reads")
                && warning.contains("4.000 times slower"),
            "{warning}"
        );
    }
}
