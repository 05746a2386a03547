//! Cohesive softening laws for `damage/eigensoftening` (a kernel, not a system).
//!
//! eigensoftening-lme-mpm.md eqs. (17)–(20): the damage is `χ = 1 − σ(w)/f_t`, the fraction of
//! tensile strength lost at crack opening `w`. Each law is tied to the fracture energy
//! `G_F = ∫ σ dw`:
//! - linear (eq. 19): `σ = f_t (1 − w/w_c)`, `w_c = 2 G_F / f_t`;
//! - exponential: `σ = f_t exp(−f_t w / G_F)`, cut to zero where it falls to `f_t/1000`
//!   (`w_c = ln(1000) G_F / f_t`; the tail lost is 0.1% of `G_F`);
//! - bilinear (Petersson): kink at `(0.8 G_F/f_t, f_t/3)`, `w_c = 3.6 G_F / f_t`.

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
    fn linear_law_matches_eq_19() {
        let law = laws()[0];
        let wc = 2.0 * 141.0 / 5.4e6;
        assert!((law.damage(0.25 * wc) - 0.25).abs() < 1e-12);
        // Dissipated fraction of G_F at χ is 2χ − χ².
        assert!((law.dissipated(0.5 * wc) / 141.0 - 0.75).abs() < 1e-12);
    }
}
