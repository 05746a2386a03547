//! How the step's integrator turns a grid impulse into particle motion.
//!
//! A law that changes nodal momentum outside the stress (contact, or a user's own grid law)
//! must know what velocity the nodes hold when it runs, where in the step it may act, and how
//! its impulse reaches the particles. Those are the integrator's facts, so the integrator
//! publishes them: its installer inserts a [`GridIntegration`] resource, and a grid law reads
//! it instead of asking which predictor, corrector or advection system is in the pipeline (in
//! the spirit of rapier's `IntegrationParameters`). Both stock integrators publish one;
//! `Installer::add_impulse_systems` places a law's systems where the description says.

use crate::dim::VectorOps;
use bevy_ecs::prelude::Resource;

/// Where in the step a law acting on the end-of-step nodal velocities runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImpulseWindow {
    /// Before the stress update, in the step's `grid_update_correction` window: the stress
    /// stage takes the velocity gradient from the corrected velocities.
    BeforeStress,
    /// After the stress (and damage and partition) stages, in the law's own stage: the
    /// end-of-step velocity depends on the new stress.
    AfterStress,
}

/// The integrator's description of how a grid impulse becomes particle motion.
#[derive(Resource, Clone, Copy, Debug, PartialEq)]
pub enum GridIntegration {
    /// Update-stress-last (dfg-partitioning-mpm.md eqs. 6–10). After the predictor the nodes
    /// hold the end-of-step velocities `v̄ⁿ⁺¹` and accelerations, and the stress is taken from
    /// those velocities, so an impulse acts before the stress. An impulse `Δp` changes the
    /// node's velocity by `Δp/m` and its acceleration by `Δp/(mΔt)` in place (the particles
    /// take both through the advection), and stands for the force `Δp/Δt`.
    UpdateStressLast,
    /// The explicit Newmark predictor-corrector (eigensoftening-lme-mpm.md Appendix A, eq. 2).
    /// After the predictor the nodes hold `ṽ`; the end-of-step velocity is `ṽ + γΔt f/m` with
    /// the forces of the new stress, so an impulse acts after the stress. An impulse splits in
    /// two: the part the predicted velocities alone call for (a collision) is a kick that
    /// corrects `ṽ` at once and that the particles take as `Σ N J/m` (`NodeContactImpulse`);
    /// the rest is the force `(Δp − J)/(γΔt)` (`NodeContactForce`), which the corrector
    /// integrates with the others.
    PredictorCorrector {
        /// Newmark's γ.
        gamma: f64,
    },
}

impl GridIntegration {
    /// Where a law acting on the end-of-step velocities runs.
    pub fn impulse_window(self) -> ImpulseWindow {
        match self {
            Self::UpdateStressLast => ImpulseWindow::BeforeStress,
            Self::PredictorCorrector { .. } => ImpulseWindow::AfterStress,
        }
    }

    /// The time over which a nodal force changes the end-of-step velocity: `Δt` with
    /// update-stress-last, `γΔt` with Newmark.
    pub fn force_window(self, dt: f64) -> f64 {
        match self {
            Self::UpdateStressLast => dt,
            Self::PredictorCorrector { gamma } => gamma * dt,
        }
    }

    /// Whether the end-of-step velocity needs the forces of the new stress (and so a law must
    /// gather them).
    pub fn needs_stress_forces(self) -> bool {
        matches!(self, Self::PredictorCorrector { .. })
    }

    /// The end-of-step velocity of a field of mass `mass` whose nodes hold `velocity` when the
    /// law runs, under the forces `force` of the new stress: `velocity` itself with
    /// update-stress-last (the forces are already in it), `ṽ + γΔt f/m` with Newmark (zero for
    /// an empty field). The Newmark corrector uses it too, so the formula is written once.
    pub fn end_of_step_velocity<V: VectorOps>(
        self,
        mass: f64,
        velocity: V,
        force: V,
        dt: f64,
    ) -> V {
        match self {
            Self::UpdateStressLast => velocity,
            Self::PredictorCorrector { .. } if mass > 0.0 => {
                velocity + force * self.force_window(dt) / mass
            }
            Self::PredictorCorrector { .. } => V::ZERO,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec2;

    #[test]
    fn newmark_corrects_with_gamma_dt_and_usl_keeps_the_velocity() {
        let newmark = GridIntegration::PredictorCorrector { gamma: 0.5 };
        let (v, f) = (DVec2::new(1.0, 2.0), DVec2::new(4.0, -8.0));
        assert_eq!(newmark.force_window(0.1), 0.05);
        assert_eq!(
            newmark.end_of_step_velocity(2.0, v, f, 0.1),
            DVec2::new(1.1, 1.8)
        );
        assert_eq!(newmark.end_of_step_velocity(0.0, v, f, 0.1), DVec2::ZERO);
        assert_eq!(newmark.impulse_window(), ImpulseWindow::AfterStress);
        let usl = GridIntegration::UpdateStressLast;
        assert_eq!(usl.end_of_step_velocity(2.0, v, f, 0.1), v);
        assert_eq!(usl.force_window(0.1), 0.1);
        assert_eq!(usl.impulse_window(), ImpulseWindow::BeforeStress);
        assert!(newmark.needs_stress_forces() && !usl.needs_stress_forces());
    }
}
