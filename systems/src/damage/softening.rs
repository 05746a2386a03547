//! Cohesive softening laws for `damage/eigensoftening` (a kernel, not a system).
//!
//! eigensoftening-lme-mpm.md eqs. (17)–(20): the damage is `χ = 1 − σ(w)/f_t`, the fraction of
//! tensile strength lost at crack opening `w`. Each law is tied to the fracture energy
//! `G_F = ∫ σ dw`:
//! - linear (eq. 19): `σ = f_t (1 − w/w_c)`, `w_c = 2 G_F / f_t`;
//! - exponential: `σ = f_t exp(−f_t w / G_F)`, cut to zero where it falls to `f_t/1000`
//!   (`w_c = ln(1000) G_F / f_t`; the tail lost is 0.1% of `G_F`);
//! - bilinear (Petersson): kink at `(0.8 G_F/f_t, f_t/3)`, `w_c = 3.6 G_F / f_t`.
//!
//! [`SofteningLaw::cohesive_opening`] is the kernel of eigensoftening's `traction: Cohesive`:
//! the opening at which a crack band, whose elastic strain and crack strain share one
//! traction, carries the law's stress.

use serde::Deserialize;

/// Shape of the softening law.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
#[serde(deny_unknown_fields)]
pub enum SofteningShape {
    /// Linear.
    #[default]
    Linear,
    /// Exponential.
    Exponential,
    /// Bilinear (Petersson).
    Bilinear,
}

/// A softening law with its strength and fracture energy.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SofteningLaw {
    /// Shape.
    pub shape: SofteningShape,
    /// Tensile strength f_t (Pa).
    pub tensile_strength: f64,
    /// Fracture energy G_F (J/m²).
    pub fracture_energy: f64,
}

const EXPONENTIAL_CUT: f64 = 1000.0;

impl SofteningLaw {
    /// Opening at which the law reaches zero stress.
    pub fn critical_opening(&self) -> f64 {
        let (ft, gf) = (self.tensile_strength, self.fracture_energy);
        match self.shape {
            SofteningShape::Linear => 2.0 * gf / ft,
            SofteningShape::Exponential => EXPONENTIAL_CUT.ln() * gf / ft,
            SofteningShape::Bilinear => 3.6 * gf / ft,
        }
    }

    /// Residual stress `σ(w)`.
    pub fn stress(&self, w: f64) -> f64 {
        let (ft, gf) = (self.tensile_strength, self.fracture_energy);
        let w = w.max(0.0);
        if w >= self.critical_opening() {
            return 0.0;
        }
        match self.shape {
            SofteningShape::Linear => ft * (1.0 - w / self.critical_opening()),
            SofteningShape::Exponential => ft * (-ft * w / gf).exp(),
            SofteningShape::Bilinear => {
                let (w1, s1) = (0.8 * gf / ft, ft / 3.0);
                if w <= w1 {
                    ft + (s1 - ft) * w / w1
                } else {
                    s1 * (self.critical_opening() - w) / (self.critical_opening() - w1)
                }
            }
        }
    }

    /// Damage `χ(w) = 1 − σ(w)/f_t`.
    pub fn damage(&self, w: f64) -> f64 {
        (1.0 - self.stress(w) / self.tensile_strength).clamp(0.0, 1.0)
    }

    /// Opening that gives damage `chi` (inverse of [`SofteningLaw::damage`]).
    pub fn opening(&self, chi: f64) -> f64 {
        // σ is strictly decreasing up to w_c, so bisection is exact to round-off.
        let (mut lo, mut hi) = (0.0, self.critical_opening());
        if chi >= 1.0 {
            return hi;
        }
        for _ in 0..100 {
            let mid = 0.5 * (lo + hi);
            if self.damage(mid) < chi {
                lo = mid
            } else {
                hi = mid
            }
        }
        0.5 * (lo + hi)
    }

    /// Steepest descent of the law, `max |dσ/dw|` (at `w = 0` for every shape).
    pub fn initial_slope(&self) -> f64 {
        let (ft, gf) = (self.tensile_strength, self.fracture_energy);
        match self.shape {
            SofteningShape::Linear => ft / self.critical_opening(),
            SofteningShape::Exponential => ft * ft / gf,
            SofteningShape::Bilinear => (ft - ft / 3.0) / (0.8 * gf / ft),
        }
    }

    /// Largest band width over which a crack band of normal modulus `modulus` softens without
    /// snap-back: `modulus / initial_slope`. A wider band cannot follow the law and fails at
    /// once.
    pub fn snap_back_band(&self, modulus: f64) -> f64 {
        modulus / self.initial_slope()
    }

    /// Opening `w ≥ previous` of a crack band of width `band` whose elastic normal stress,
    /// were it uncracked, would be `trial` (the undamaged largest principal stress), for a
    /// normal modulus `modulus` (λ + 2μ).
    ///
    /// The band's normal strain is elastic plus crack strain, `ε = t / M + w / h`, with one
    /// traction `t` that the law sets: `t = σ(w)`. So `w` solves `g(w) = σ(w) + M w / h =
    /// trial`. `g` is convex for the three laws (their slopes only flatten), so starting from
    /// `previous` with `g < trial` there is one upward crossing, found by bisection; where
    /// `g(previous) ≥ trial` the band is unloading or elastic and keeps its opening. Beyond the
    /// snap-back band width the crossing lies at `w ≥ w_c`: the band fails at once.
    pub fn cohesive_opening(&self, trial: f64, modulus: f64, band: f64, previous: f64) -> f64 {
        let stiffness = modulus / band;
        let g = |w: f64| self.stress(w) + stiffness * w;
        if g(previous) >= trial {
            return previous;
        }
        // g(hi) ≥ stiffness · hi ≥ trial.
        let (mut lo, mut hi) = (previous, (trial / stiffness).max(self.critical_opening()));
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if mid <= lo || mid >= hi {
                break;
            }
            if g(mid) < trial { lo = mid } else { hi = mid }
        }
        hi
    }

    /// Energy dissipated per unit crack area up to opening `w`, `∫₀ʷ σ dw` (J/m²), in closed
    /// form.
    pub fn dissipated(&self, w: f64) -> f64 {
        let (ft, gf) = (self.tensile_strength, self.fracture_energy);
        let w = w.clamp(0.0, self.critical_opening());
        match self.shape {
            SofteningShape::Linear => ft * (w - w * w / (2.0 * self.critical_opening())),
            SofteningShape::Exponential => gf * (1.0 - (-ft * w / gf).exp()),
            SofteningShape::Bilinear => {
                // Trapezoids under the two straight pieces.
                let w1 = 0.8 * gf / ft;
                if w <= w1 {
                    0.5 * (ft + self.stress(w)) * w
                } else {
                    0.5 * (ft + ft / 3.0) * w1 + 0.5 * (ft / 3.0 + self.stress(w)) * (w - w1)
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn laws() -> [SofteningLaw; 3] {
        [
            SofteningShape::Linear,
            SofteningShape::Exponential,
            SofteningShape::Bilinear,
        ]
        .map(|shape| SofteningLaw {
            shape,
            tensile_strength: 5.4e6,
            fracture_energy: 141.0,
        })
    }

    #[test]
    fn each_law_dissipates_its_fracture_energy() {
        for law in laws() {
            let total = law.dissipated(law.critical_opening());
            let expected = if law.shape == SofteningShape::Exponential {
                0.999
            } else {
                1.0
            };
            assert!(
                (total / law.fracture_energy - expected).abs() < 1e-9,
                "{:?}: {total}",
                law.shape
            );
        }
    }

    #[test]
    fn damage_starts_at_zero_grows_monotonically_and_inverts() {
        for law in laws() {
            assert_eq!(law.damage(0.0), 0.0);
            assert_eq!(law.damage(law.critical_opening()), 1.0);
            let mut previous = 0.0;
            for k in 1..=100 {
                let w = law.critical_opening() * k as f64 / 100.0;
                let chi = law.damage(w);
                assert!(chi >= previous);
                previous = chi;
                if chi < 1.0 {
                    assert!((law.opening(chi) - w).abs() < 1e-9 * law.critical_opening());
                }
            }
        }
    }

    #[test]
    fn cohesive_opening_gives_the_law_its_traction_and_the_band_its_strain() {
        let modulus = 31e9;
        for law in laws() {
            let band = 0.5 * law.snap_back_band(modulus);
            let stiffness = modulus / band;
            let mut previous = 0.0;
            // Trial stresses rising from below f_t to past g(w_c) = M w_c / h: each opening
            // satisfies σ(w) + M w / h = trial and never closes; the law is followed exactly.
            let (start, end) = (
                0.8 * law.tensile_strength,
                1.1 * stiffness * law.critical_opening(),
            );
            for k in 0..=60 {
                let trial = start + (end - start) * k as f64 / 60.0;
                let w = law.cohesive_opening(trial, modulus, band, previous);
                assert!(w >= previous);
                if trial <= law.tensile_strength {
                    assert_eq!(w, 0.0);
                } else if w < law.critical_opening() {
                    let residual = law.stress(w) + stiffness * w - trial;
                    assert!(residual.abs() < 1e-9 * trial, "{:?}: {residual}", law.shape);
                }
                previous = w;
            }
            assert!(previous >= law.critical_opening());
            // Unloading keeps the opening.
            assert_eq!(law.cohesive_opening(0.0, modulus, band, previous), previous);
        }
    }

    #[test]
    fn a_band_wider_than_the_snap_back_limit_opens_past_w_c_at_once() {
        let law = laws()[0];
        let modulus = 31e9;
        let band = 2.0 * law.snap_back_band(modulus);
        let w = law.cohesive_opening(1.001 * law.tensile_strength, modulus, band, 0.0);
        assert!(w >= law.critical_opening());
    }

    #[test]
    fn linear_law_matches_eq_19() {
        let law = laws()[0];
        let wc = 2.0 * 141.0 / 5.4e6;
        assert!((law.damage(0.25 * wc) - 0.25).abs() < 1e-12);
        // Dissipated fraction of G_F at χ is 2χ − χ².
        assert!((law.dissipated(0.5 * wc) / 141.0 - 0.75).abs() < 1e-12);
    }
}
