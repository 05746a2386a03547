//! Weibull-distributed, size-dependent particle strength (a kernel and its scene option, not a
//! system): the `weibull` option of `damage/rankine` and `damage/time_to_failure`.
//!
//! dfg-partitioning-mpm.md eq. (25): `σ_f / σ̄_f = ((V̄ / V) ln R / ln ½)^{1/m}`, with `V` the
//! particle volume, `σ̄_f` the strength at the reference volume `V̄` (there it is the median:
//! `R = ½` gives `σ_f = σ̄_f`), `m` the Weibull modulus and `R` uniform in (0, 1). The strength
//! then follows the weakest-link law `P(σ_f ≤ s) = 1 − 2^{−(V/V̄)(s/σ̄_f)^m}`, so the chance that
//! some flaw of a body fails at a given stress does not depend on how finely it is cut into
//! particles.
//!
//! `R` comes from the particle's id and the scene's seed through a counter-based generator
//! (SplitMix64 finalisation of `seed`, then of the id mixed in), so every particle gets the same
//! strength whatever the thread count, particle order or pipeline; another seed is another
//! realisation. In 2D the particle volume of eq. (25) is the particle's area times the option's
//! `thickness` (the paper's plane-strain examples state one); the scene's own `thickness` only
//! scales the outputs.

use fractum_engine::prelude::*;
use serde::Deserialize;

/// The `weibull` option as written in the scene.
#[derive(Deserialize, Clone, Copy, Debug, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct WeibullOption {
    /// Weibull modulus m (> 0; larger is less scattered).
    pub modulus: f64,
    /// Reference volume V̄ (m³) at which the damage law's `tensile_strength` is the median.
    pub reference_volume: f64,
    /// Seed of the realisation.
    pub seed: u64,
    /// 2D only: the thickness (m) that makes a particle's area a volume in eq. (25).
    #[serde(default)]
    pub thickness: Option<f64>,
}

/// SplitMix64's finaliser: a bijection of `u64` whose output bits each depend on every input
/// bit (Steele, Lea & Flood 2014).
fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// The uniform number `R` in the open interval (0, 1) of particle `id` in realisation `seed`.
pub fn uniform(seed: u64, id: u32) -> f64 {
    let bits =
        mix(mix(seed).wrapping_add(0x9e37_79b9_7f4a_7c15_u64.wrapping_mul(u64::from(id) + 1)));
    // The top 53 bits, offset by half a unit: never 0, never 1.
    ((bits >> 11) as f64 + 0.5) / (1u64 << 53) as f64
}

/// Eq. (25): the strength of a particle of volume `volume` drawn at `r` ∈ (0, 1).
pub fn weibull_strength(
    median: f64,
    reference_volume: f64,
    modulus: f64,
    volume: f64,
    r: f64,
) -> f64 {
    median * (reference_volume / volume * r.ln() / 0.5f64.ln()).powf(1.0 / modulus)
}

/// A validated Weibull option, ready to give particles their strengths.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Weibull {
    /// The option as written.
    pub option: WeibullOption,
    /// Factor from a particle's `InitialVolume` to its volume in eq. (25): in 2D the option's
    /// thickness over the scene's, in 3D 1.
    pub volume_factor: f64,
}

impl Weibull {
    /// Checks `option` for a scene of dimension `dimension` and scene thickness
    /// `scene_thickness`; `error` locates a message at a field of the option.
    pub fn new(
        option: WeibullOption,
        dimension: usize,
        scene_thickness: f64,
        error: impl Fn(&str, &str) -> SceneError,
    ) -> Result<Self, SceneError> {
        let positive = |v: f64| v.is_finite() && v > 0.0;
        if !positive(option.modulus) {
            return Err(error("modulus", "expected a Weibull modulus m > 0"));
        }
        if !positive(option.reference_volume) {
            return Err(error(
                "reference_volume",
                "expected a reference volume V̄ > 0 (m³)",
            ));
        }
        let volume_factor = match (dimension, option.thickness) {
            (2, Some(t)) if positive(t) => t / scene_thickness,
            (2, Some(_)) => return Err(error("thickness", "expected a thickness > 0 (m)")),
            (2, None) => {
                return Err(error(
                    "",
                    "a 2D scene must give the `thickness` (m) that makes a particle's area the \
                     volume of eq. 25, e.g. `thickness: 1.0e-3`",
                ));
            }
            (_, Some(_)) => {
                return Err(error(
                    "thickness",
                    "a thickness is for 2D scenes; in 3D the particle volume is a volume",
                ));
            }
            (_, None) => 1.0,
        };
        Ok(Self {
            option,
            volume_factor,
        })
    }

    /// The strength of the particle with id `id` and initial volume `initial_volume` (the
    /// scene's), for median strength `median` at the reference volume.
    pub fn strength(&self, median: f64, id: u32, initial_volume: f64) -> f64 {
        let o = &self.option;
        let volume = initial_volume * self.volume_factor;
        weibull_strength(
            median,
            o.reference_volume,
            o.modulus,
            volume,
            uniform(o.seed, id),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_numbers_stay_inside_the_open_interval_and_depend_on_seed_and_id() {
        let draws: Vec<f64> = (0..10_000).map(|id| uniform(7, id)).collect();
        assert!(draws.iter().all(|&r| r > 0.0 && r < 1.0));
        let mean = draws.iter().sum::<f64>() / draws.len() as f64;
        // Standard error of the mean of 10⁴ uniforms: 0.0029.
        assert!((mean - 0.5).abs() < 0.012, "mean {mean}");
        assert_ne!(uniform(7, 3), uniform(8, 3));
        assert_ne!(uniform(7, 3), uniform(7, 4));
        assert_eq!(uniform(7, 3), uniform(7, 3));
    }

    #[test]
    fn the_median_sits_at_the_reference_volume_and_smaller_particles_are_stronger() {
        assert!((weibull_strength(100.0, 2.0, 6.0, 2.0, 0.5) - 100.0).abs() < 1e-12);
        // Half the volume, same draw: 2^{1/m} stronger.
        let small = weibull_strength(100.0, 2.0, 6.0, 1.0, 0.5);
        assert!((small / 100.0 - 2f64.powf(1.0 / 6.0)).abs() < 1e-12);
        // A low draw (a likely flaw) is weak, a high one strong.
        assert!(weibull_strength(100.0, 2.0, 6.0, 2.0, 0.9) < 100.0);
        assert!(weibull_strength(100.0, 2.0, 6.0, 2.0, 0.1) > 100.0);
    }

    /// 10⁴ particles of one volume: the sample median and the modulus fitted to the sample
    /// (least squares on the Weibull plot, `ln(−ln(1 − F))` against `ln σ`) come back within 5%.
    #[test]
    fn ten_thousand_strengths_reproduce_the_median_and_the_modulus() {
        let (median, v_ref, m, v) = (570.0e6, 1.0e-9, 6.0, 4.0e-9);
        let mut s: Vec<f64> = (0..10_000)
            .map(|id| weibull_strength(median, v_ref, m, v, uniform(42, id)))
            .collect();
        s.sort_by(f64::total_cmp);
        let n = s.len() as f64;
        // The median at volume V is σ̄ (V̄/V)^{1/m}.
        let expected_median = median * (v_ref / v).powf(1.0 / m);
        let sample_median = 0.5 * (s[4999] + s[5000]);
        assert!(
            (sample_median / expected_median - 1.0).abs() < 0.05,
            "median {sample_median:e} against {expected_median:e}"
        );
        let points: Vec<(f64, f64)> = s
            .iter()
            .enumerate()
            .map(|(i, &x)| {
                let f = (i as f64 + 0.5) / n;
                (x.ln(), (-(1.0 - f).ln()).ln())
            })
            .collect();
        let (mx, my) = points
            .iter()
            .fold((0.0, 0.0), |(a, b), (x, y)| (a + x / n, b + y / n));
        let (sxy, sxx) = points.iter().fold((0.0, 0.0), |(a, b), (x, y)| {
            (a + (x - mx) * (y - my), b + (x - mx) * (x - mx))
        });
        let fitted = sxy / sxx;
        assert!((fitted / m - 1.0).abs() < 0.05, "fitted modulus {fitted}");
    }

    #[test]
    fn options_are_checked_for_the_dimension() {
        let option = WeibullOption {
            modulus: 6.0,
            reference_volume: 1e-9,
            seed: 1,
            thickness: Some(2e-3),
        };
        let error = |field: &str, message: &str| {
            SceneError::at("scene.ron", Default::default(), field, message)
        };
        let w = Weibull::new(option, 2, 1e-3, error).unwrap();
        assert_eq!(w.volume_factor, 2.0);
        assert!(Weibull::new(option, 3, 1.0, error).is_err());
        let flat = WeibullOption {
            thickness: None,
            ..option
        };
        assert!(Weibull::new(flat, 2, 1.0, error).is_err());
        assert!(Weibull::new(flat, 3, 1.0, error).is_ok());
        let bad = WeibullOption {
            modulus: -1.0,
            ..flat
        };
        let e = Weibull::new(bad, 3, 1.0, error).unwrap_err();
        assert!(e.to_string().contains("modulus"), "{e}");
    }
}
