//! `damage/overstress`: a particle fails outright once its largest principal stress exceeds a
//! strength. Stage: damage. The example system of docs/guide/own-system.md, written once for
//! 2D (plane strain) and 3D.

use fractum_engine::prelude::*;
use serde::Deserialize;

/// The system's parameters, parsed from the scene entry's `params`.
#[derive(Resource, Deserialize, Clone, Copy, Debug, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Overstress {
    /// Tensile strength (Pa).
    pub strength: f64,
}

/// Fails every particle whose largest principal stress exceeds the strength.
pub fn overstress<D: Dim>(
    limit: Res<Overstress>,
    mut particles: Query<(&Stress<D>, &mut Damage), With<Particle>>,
) {
    for (stress, mut damage) in &mut particles {
        if stress.0.largest_principal() > limit.strength {
            damage.0 = 1.0;
        }
    }
}

/// Installs the system for a scene of dimension `D` (the registry picks the scene's).
fn install<D: Dim>(installer: &mut Installer, params: &Params) -> Result<(), SceneError> {
    let parsed: Overstress = params.parse()?;
    if !(parsed.strength.is_finite() && parsed.strength > 0.0) {
        return Err(params.error("strength", "expected a positive strength (Pa)"));
    }
    installer.insert_resource(parsed);
    installer.add_systems(overstress::<D>);
    Ok(())
}

/// The registration: its name in scenes, its stage, its parameters.
pub const OVERSTRESS: Registration = Registration {
    name: "damage/overstress",
    summary: "fails a particle once its largest principal stress exceeds the strength",
    params: &[ParamDoc {
        name: "strength",
        ty: "f64",
        default: None,
        doc: "tensile strength (Pa)",
    }],
    requires: &[],
    install: generic_install!(install),
};

#[cfg(test)]
mod tests {
    use super::*;
    use fractum_engine::testing::{
        assert_documented, particle_values, run_system, spawn_particle, tiny_world,
    };

    #[test]
    fn a_particle_above_the_strength_fails_and_one_below_does_not() {
        let mut world = tiny_world::<Two>(4, 0.25, 1e-3);
        world.insert_resource(Overstress { strength: 10.0 });
        for tension in [5.0, 20.0] {
            let p = spawn_particle(&mut world, DVec2::splat(0.5), DVec2::ZERO, 1.0, 1.0);
            world.get_mut::<Stress<Two>>(p).unwrap().0.xx = tension;
        }
        run_system(&mut world, overstress::<Two>);
        let damage: Vec<f64> = particle_values::<Damage>(&mut world).iter().map(|d| d.0).collect();
        assert_eq!(damage, [0.0, 1.0]);
    }

    /// `fractum systems` documents exactly the parameters the installer parses.
    #[test]
    fn the_registration_documents_the_parameters() {
        assert_documented::<Overstress>(&OVERSTRESS);
    }
}
