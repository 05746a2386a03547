//! Tensile degradation from a potential: the spectral split of the neo-Hookean energy, a kernel
//! that `damage/rankine` and `damage/time_to_failure` apply with `degradation: Spectral` (not a
//! system of its own).
//!
//! - eq. (22)'s energy, `W = μ/2 (tr b − 3) − μ ln J + λ/2 (ln J)²`, separates in the principal
//!   logarithmic (Hencky) strains `e_i = ½ ln b_i` of `b = F Fᵀ` (in plane strain `b_zz = 1`,
//!   `e_3 = 0`): `W = Σ_i φ(e_i) + λ/2 (Σ_i e_i)²` with `φ(e) = μ/2 (e^{2e} − 1) − μ e`, which is
//!   convex and vanishes with its slope at `e = 0`.
//! - The split keeps what resists compression and degrades the rest:
//!   `W_D = (1 − D) W⁺ + W⁻`, `W⁺ = Σ_{e_i > 0} φ(e_i) + λ/2 ⟨ln J⟩₊²`,
//!   `W⁻ = Σ_{e_i ≤ 0} φ(e_i) + λ/2 ⟨ln J⟩₋²`. Every term is once continuously differentiable
//!   in the strains (φ and `⟨x⟩²` vanish with their slopes at zero), so the stress is continuous
//!   and derives from `W_D`: at fixed damage, a particle taken round any closed strain path does
//!   no net work. (Eqs. 26–27, which scale the tensile principal *stresses*, derive from no
//!   potential: see `damage::tensile_degradation`.)
//! - Stress: the Kirchhoff stress of an isotropic energy of the principal Hencky strains is
//!   coaxial with `b`, `τ = Σ_i ∂W_D/∂e_i n_i ⊗ n_i`, with
//!   `∂W_D/∂e_i = g_i μ (b_i − 1) + g_J λ ln J` (`g = 1 − D` on the tensile terms, 1 on the
//!   compressive ones); the Cauchy stress is `τ / J`. Intact (`D = 0`) it is eq. (22)'s stress
//!   to round-off, and `W_D` its energy.
//! - A failed particle (`D = 1`) so carries no stress in all-round tension, resists compression
//!   along every axis that is shortened and in volume, and, under shear, keeps the compressive
//!   principal part (the spectral split's known transfer of some shear across a closed crack).
//!   The damage criterion (the largest principal trial stress) is unchanged.

use fractum_engine::prelude::*;

/// The stress and stored energy per reference volume of a particle with deformation gradient
/// `f`, Lamé constants `lambda`, `mu` and damage `damage`, its energy split spectrally (see the
/// module header). `None` when `J ≤ 0` (the material has inverted).
pub fn spectral_degraded<D: Dim>(
    f: D::Matrix,
    lambda: f64,
    mu: f64,
    damage: f64,
) -> Option<(D::Sym, f64)> {
    let j = f.determinant();
    // Also rejects a NaN determinant.
    if j.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    let intact = 1.0 - damage.clamp(0.0, 1.0);
    let factor = |tensile: bool| if tensile { intact } else { 1.0 };
    let ln_j = j.ln();
    let volumetric = factor(ln_j > 0.0) * lambda * ln_j;
    let b = D::left_cauchy_green(f);
    let kirchhoff = b.map_principal(|bi| factor(bi > 1.0) * mu * (bi - 1.0) + volumetric);
    let principal_energy: f64 = b
        .principal_values()
        .iter()
        .map(|&bi| factor(bi > 1.0) * 0.5 * mu * (bi - 1.0 - bi.ln()))
        .sum();
    let energy = principal_energy + factor(ln_j > 0.0) * 0.5 * lambda * ln_j * ln_j;
    Some((kirchhoff.scaled(1.0 / j), energy))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stress::neo_hookean::{neo_hookean_energy, neo_hookean_stress_of};

    /// The disk's moduli (E = 190 GPa, ν = 0.3).
    const LAME: (f64, f64) = (109.6e9, 73.077e9);

    fn close(a: f64, b: f64, scale: f64) -> bool {
        (a - b).abs() <= 1e-12 * scale
    }

    #[test]
    fn intact_it_is_the_neo_hookean_stress_and_energy() {
        let (lambda, mu) = LAME;
        let f2 = DMat2::from_cols_array(&[1.03, 0.02, -0.05, 0.96]);
        let (s, w) = spectral_degraded::<Two>(f2, lambda, mu, 0.0).unwrap();
        let reference = neo_hookean_stress_of::<Two>(f2, lambda, mu).unwrap();
        for (a, b) in s.as_3x3().iter().zip(reference.as_3x3()) {
            assert!(close(*a, b, 1e10), "{s:?} against {reference:?}");
        }
        assert!(close(w, neo_hookean_energy::<Two>(f2, lambda, mu), 1e8));
        let f3 = DMat3::from_cols_array(&[1.02, 0.01, 0.03, -0.02, 0.97, 0.01, 0.04, 0.0, 1.05]);
        let (s, w) = spectral_degraded::<Three>(f3, lambda, mu, 0.0).unwrap();
        let reference = neo_hookean_stress_of::<Three>(f3, lambda, mu).unwrap();
        for (a, b) in s.as_3x3().iter().zip(reference.as_3x3()) {
            assert!(close(*a, b, 1e10), "{s:?} against {reference:?}");
        }
        assert!(close(w, neo_hookean_energy::<Three>(f3, lambda, mu), 1e8));
    }

    #[test]
    fn a_failed_particle_carries_no_tension_and_resists_compression() {
        let (lambda, mu) = LAME;
        // All-round stretch: nothing left.
        let stretched = DMat2::from_diagonal(DVec2::new(1.02, 1.01));
        let (s, w) = spectral_degraded::<Two>(stretched, lambda, mu, 1.0).unwrap();
        assert_eq!(s.as_3x3().map(f64::abs).iter().sum::<f64>(), 0.0);
        assert_eq!(w, 0.0);
        // All-round squeeze: the intact stress and energy.
        let squeezed = DMat2::from_diagonal(DVec2::new(0.98, 0.99));
        let (s, w) = spectral_degraded::<Two>(squeezed, lambda, mu, 1.0).unwrap();
        let reference = neo_hookean_stress_of::<Two>(squeezed, lambda, mu).unwrap();
        for (a, b) in s.as_3x3().iter().zip(reference.as_3x3()) {
            assert!(close(*a, b, 1e10), "{s:?}");
        }
        assert!(close(
            w,
            neo_hookean_energy::<Two>(squeezed, lambda, mu),
            1e8
        ));
        // Opened along x, shortened along y at a volume increase: the y stress is compressive,
        // the x stress from the shortened axis alone is zero, and half damage lies between.
        let opened = DMat2::from_diagonal(DVec2::new(1.05, 0.99));
        let (failed, _) = spectral_degraded::<Two>(opened, lambda, mu, 1.0).unwrap();
        assert!(failed.xx.abs() < 1e-6 && failed.yy < 0.0, "{failed:?}");
        let (half, _) = spectral_degraded::<Two>(opened, lambda, mu, 0.5).unwrap();
        let (whole, _) = spectral_degraded::<Two>(opened, lambda, mu, 0.0).unwrap();
        assert!(close(half.xx, 0.5 * whole.xx, 1e10), "{half:?}");
        // An inverted particle has no stress.
        let inverted = DMat2::from_diagonal(DVec2::new(-1.0, 1.0));
        assert!(spectral_degraded::<Two>(inverted, lambda, mu, 1.0).is_none());
    }

    /// The stress is the derivative of the energy: `d W / d t = J σ : sym(L)` along a path,
    /// checked by central differences at damage 0.6 where every split term is active.
    #[test]
    fn the_stress_derives_from_the_split_energy() {
        let (lambda, mu) = LAME;
        let f0 = DMat3::from_cols_array(&[1.04, 0.02, 0.01, -0.03, 0.97, 0.02, 0.01, 0.0, 0.99]);
        let rate = DMat3::from_cols_array(&[0.3, -0.5, 0.2, 0.4, -0.2, 0.1, 0.0, 0.3, 0.6]);
        let at = |t: f64| (DMat3::IDENTITY + rate * t) * f0;
        let h = 1e-6;
        let energy = |t: f64| {
            spectral_degraded::<Three>(at(t), lambda, mu, 0.6)
                .unwrap()
                .1
        };
        let numeric = (energy(h) - energy(-h)) / (2.0 * h);
        let (s, _) = spectral_degraded::<Three>(f0, lambda, mu, 0.6).unwrap();
        let d = 0.5 * (rate + rate.transpose());
        let power = f0.determinant()
            * (0..3)
                .map(|i| (0..3).map(|j| s.get(i, j) * d.col(j)[i]).sum::<f64>())
                .sum::<f64>();
        assert!(
            (numeric - power).abs() < 1e-6 * power.abs(),
            "{numeric} against {power}"
        );
    }
}
