//! The system registry: names such as `basis/linear` mapped to installers.
//!
//! A [`Registration`] describes one algorithm: its name (`stage/algorithm`), a one-line summary,
//! its parameters, the systems it needs alongside it, and an install function. The install
//! function receives an [`Installer`] that can add systems to the registration's own stage only,
//! and a [`Params`] holding the raw RON of the pipeline entry's `params`, which it parses into
//! its own typed struct. Users register their own algorithms from their own crates the same way.

mod installer;
mod params;
pub mod pending;
pub mod templates;

pub use crate::stage::PipelineEntrySet;
pub use installer::Installer;
pub use params::Params;

use crate::stage::Stage;
use crate::text::SceneError;
use bevy_ecs::prelude::Component;
use std::collections::BTreeMap;

/// A particle component a system adds: mutable, and serde both ways so that checkpoints can
/// carry it (derive `serde::Serialize` and `serde::Deserialize`).
pub trait ParticleState:
    Component<Mutability = bevy_ecs::component::Mutable> + crate::checkpoint::State
{
}

impl<C: Component<Mutability = bevy_ecs::component::Mutable> + crate::checkpoint::State>
    ParticleState for C
{
}

/// Documentation of one parameter, shown by `fractum systems`.
#[derive(Clone, Copy, Debug)]
pub struct ParamDoc {
    /// Field name in `params: (...)`.
    pub name: &'static str,
    /// Type as a user writes it, e.g. `f64`.
    pub ty: &'static str,
    /// Default value, or `None` when the parameter is required. An optional parameter with no
    /// value says what its absence means after `none`: `Some("none: no surface detection")`
    /// (`fractum systems` shows it as optional).
    pub default: Option<&'static str>,
    /// What it means, with units.
    pub doc: &'static str,
}

/// Installs a registration's systems and resources for one pipeline entry.
pub type InstallFn = fn(&mut Installer, &Params) -> Result<(), SceneError>;

/// The [`InstallFn`] of an install function written once for both dimensions,
/// `fn install<D: Dim>(installer: &mut Installer, params: &Params) -> Result<(), SceneError>`:
/// the registry calls its instance for the scene's dimension, so that the installer names `D`
/// (`installer.add_systems(my_system::<D>)`) instead of repeating `with_dim!`.
///
/// ```
/// use fractum_engine::generic_install;
/// use fractum_engine::prelude::*;
///
/// fn kick<D: Dim>(mut particles: Query<&mut Velocity<D>, With<Particle>>) {
///     for mut v in &mut particles {
///         v.0 = v.0 * 2.0;
///     }
/// }
///
/// fn install<D: Dim>(installer: &mut Installer, _: &Params) -> Result<(), SceneError> {
///     installer.add_systems(kick::<D>);
///     Ok(())
/// }
///
/// pub const REGISTRATION: Registration = Registration {
///     name: "advection/kick",
///     summary: "Doubles every particle's velocity.",
///     params: &[],
///     requires: &[],
///     install: generic_install!(install),
/// };
/// ```
#[macro_export]
macro_rules! generic_install {
    ($($install:ident)::+) => {
        |installer: &mut $crate::registry::Installer,
         params: &$crate::registry::Params|
         -> ::std::result::Result<(), $crate::text::SceneError> {
            $crate::with_dim!(installer.dimension(), D => $($install)::+::<D>(installer, params))
        }
    };
}

/// One registered algorithm.
#[derive(Clone, Copy, Debug)]
pub struct Registration {
    /// `stage/algorithm`, e.g. `basis/linear`.
    pub name: &'static str,
    /// One line: what it does.
    pub summary: &'static str,
    /// Its parameters.
    pub params: &'static [ParamDoc],
    /// Other systems that must be in the same pipeline (e.g. a predictor's matching advection);
    /// `stage/*` asks for any system of that stage.
    pub requires: &'static [&'static str],
    /// Adds its systems to the schedule.
    pub install: InstallFn,
}

impl Registration {
    /// The stage named by the prefix of [`Registration::name`].
    pub fn stage(&self) -> Option<Stage> {
        self.name
            .split_once('/')
            .and_then(|(s, _)| Stage::from_name(s))
    }
}

/// Why a registration was refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum RegistryError {
    /// The name is not `stage/algorithm` with a known stage.
    #[error("system name `{0}` must be `stage/algorithm` with a stage among: {1}")]
    BadName(String, String),
    /// The name is taken.
    #[error("a system named `{0}` is already registered")]
    Duplicate(String),
}

/// Every algorithm the engine can install, by name.
#[derive(Clone, Debug, Default)]
pub struct Registry {
    entries: BTreeMap<&'static str, Registration>,
}

impl Registry {
    /// An empty registry.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a registration.
    pub fn register(&mut self, registration: Registration) -> Result<(), RegistryError> {
        let stage_ok = registration.stage().is_some()
            && registration
                .name
                .split_once('/')
                .is_some_and(|(_, algo)| !algo.is_empty() && !algo.contains('/'));
        if !stage_ok {
            let stages: Vec<_> = Stage::ORDER.iter().map(|s| s.name()).collect();
            return Err(RegistryError::BadName(
                registration.name.to_string(),
                stages.join(", "),
            ));
        }
        if self.entries.contains_key(registration.name) {
            return Err(RegistryError::Duplicate(registration.name.to_string()));
        }
        self.entries.insert(registration.name, registration);
        Ok(())
    }

    /// The registration with this name.
    pub fn get(&self, name: &str) -> Option<&Registration> {
        self.entries.get(name)
    }

    /// All registrations, ordered by stage then name.
    pub fn iter(&self) -> impl Iterator<Item = &Registration> {
        let mut all: Vec<_> = self.entries.values().collect();
        all.sort_by_key(|r| (r.stage(), r.name));
        all.into_iter()
    }

    /// All names, ordered by stage then name.
    pub fn names(&self) -> Vec<&'static str> {
        self.iter().map(|r| r.name).collect()
    }
}

/// The materials a pipeline entry applies to (`materials: [...]` on the entry), by material
/// index. Stress and damage systems keep the filter their installer hands them and leave the
/// particles of other materials alone; the engine checks that the entries of one stage never
/// share a material and that every material has a stress system.
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct MaterialFilter(Option<Vec<bool>>);

impl MaterialFilter {
    /// Every material.
    pub fn all() -> Self {
        Self(None)
    }

    /// Only the materials whose index is `true` in `mask`.
    pub fn only(mask: Vec<bool>) -> Self {
        Self(Some(mask))
    }

    /// Whether the entry applies to particles of `material`.
    pub fn applies(&self, material: crate::components::MaterialId) -> bool {
        self.0
            .as_ref()
            .is_none_or(|mask| mask.get(material.0 as usize).copied().unwrap_or(false))
    }

    /// Whether the filter lets every material through.
    pub fn is_all(&self) -> bool {
        self.0.is_none()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::text::Location;

    fn nothing(_: &mut Installer, _: &Params) -> Result<(), SceneError> {
        Ok(())
    }

    fn registration(name: &'static str) -> Registration {
        Registration {
            name,
            summary: "test",
            params: &[],
            requires: &[],
            install: nothing,
        }
    }

    #[test]
    fn names_must_start_with_a_stage() {
        let mut registry = Registry::new();
        assert!(registry.register(registration("basis/test")).is_ok());
        assert!(matches!(
            registry.register(registration("basis/test")),
            Err(RegistryError::Duplicate(_))
        ));
        assert!(matches!(
            registry.register(registration("shape/test")),
            Err(RegistryError::BadName(..))
        ));
        assert!(registry.register(registration("basis/")).is_err());
        registry.register(registration("advection/a")).unwrap();
        assert_eq!(registry.names(), vec!["basis/test", "advection/a"]);
    }

    #[test]
    fn param_errors_point_inside_the_params() {
        #[derive(serde::Deserialize, Debug)]
        #[serde(deny_unknown_fields)]
        #[allow(dead_code)]
        struct P {
            k: f64,
        }
        let params = Params::new(
            Some("(\n  k: -1.0)"),
            "s.ron",
            Location { line: 4, col: 13 },
            "pipeline[0].params".into(),
        );
        let p: P = params.parse().unwrap();
        assert_eq!(p.k, -1.0);
        let e = params.error("k", "must be positive");
        assert_eq!(
            e.to_string(),
            "s.ron:5:6: `pipeline[0].params.k`: must be positive"
        );
        assert!(
            Params::none()
                .parse::<P>()
                .unwrap_err()
                .message
                .contains("`k`")
        );
    }
}
