//! The bounds a pipeline's damage laws put on per-particle tensile strengths
//! ([`Strength`](crate::components::Strength)), kept after the build as [`StrengthChecks`] so
//! that strengths changed later (a strength scale set from Python before the first step) meet
//! the checks the install put the scene's own strengths to.

use crate::components::MaterialId;
use bevy_ecs::prelude::Resource;

/// One law's check on strengths: given `(material, strength)` pairs of particles, the message
/// naming the first strength the law cannot take, if any. A law checks only the materials it
/// governs and passes the others.
pub type StrengthCheck = Box<dyn Fn(&[(MaterialId, f64)]) -> Result<(), String> + Send + Sync>;

/// The checks the pipeline's damage laws registered at install ([`StrengthChecks::add`]);
/// absent, or empty, when no law bounds its strengths.
#[derive(Resource, Default)]
pub struct StrengthChecks(Vec<StrengthCheck>);

impl StrengthChecks {
    /// Registers a law's check.
    pub fn add(
        &mut self,
        check: impl Fn(&[(MaterialId, f64)]) -> Result<(), String> + Send + Sync + 'static,
    ) {
        self.0.push(Box::new(check));
    }

    /// Runs every registered check on `strengths`; the first refusal's message.
    pub fn check(&self, strengths: &[(MaterialId, f64)]) -> Result<(), String> {
        self.0.iter().try_for_each(|check| check(strengths))
    }

    /// How many checks are registered.
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// Whether no check is registered.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_check_runs_and_the_first_refusal_is_reported() {
        let mut checks = StrengthChecks::default();
        assert!(checks.is_empty());
        checks.add(|s| match s.iter().find(|(_, v)| *v > 10.0) {
            Some((_, v)) => Err(format!("{v} is above 10")),
            None => Ok(()),
        });
        checks.add(|s| match s.iter().find(|(m, _)| m.0 == 1) {
            Some(_) => Err("material 1 is not taken".to_string()),
            None => Ok(()),
        });
        assert_eq!(checks.len(), 2);
        assert_eq!(checks.check(&[(MaterialId(0), 5.0)]), Ok(()));
        assert_eq!(
            checks.check(&[(MaterialId(1), 12.0)]),
            Err("12 is above 10".to_string())
        );
        assert_eq!(
            checks.check(&[(MaterialId(1), 1.0)]),
            Err("material 1 is not taken".to_string())
        );
    }
}
