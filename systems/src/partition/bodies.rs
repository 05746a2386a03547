//! One velocity field per contact group: the traditional multi-field method.
//!
//! - Stage: partition. Registration name: `partition/bodies`. Needs a contact system.
//! - Implements dfg-partitioning-mpm.md §1.1.1 (after Bardenhagen et al.): the material of each
//!   contact group (`contact_group` of its body) maps to its own velocity field at every node,
//!   so two bodies in different groups interact only through the contact stage (eqs. 11–16).
//! - The assignment is `partition::field_assignment`, installed in the step's `assign_fields`
//!   window: it runs right after the basis stage of every step, so that the particle-to-grid
//!   transfer already sees the fields. The particles carry no damage gradient, so every pair of
//!   a group takes side 0. The groups never change, so there is nothing left for the partition
//!   stage itself to do.

use super::field_assignment::install_field_assignment;
use fractum_engine::prelude::*;

/// Registration of `partition/bodies`.
pub const REGISTRATION: Registration = Registration {
    name: "partition/bodies",
    summary: "one velocity field per contact group (multi-field contact, §1.1.1)",
    params: &[],
    requires: &["contact/*"],
    install: generic_install!(install),
};

fn install<D: Dim>(installer: &mut Installer, params: &Params) -> Result<(), SceneError> {
    crate::no_params(params)?;
    install_field_assignment::<D>(installer)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::basis::linear::linear_basis;
    use crate::partition::field_assignment::assign_fields_system;
    use crate::predictor::usl::{UslPredictorParams, usl_predictor};
    use fractum_engine::testing::*;

    /// Two particles of different groups in one cell: after the assignment every node they
    /// share holds two fields, each with its own particle's mass and velocity.
    #[test]
    fn each_group_gets_its_own_field() {
        let mut world = tiny_world::<Two>(2, 0.5, 1e-3);
        world.insert_resource(UslPredictorParams::default());
        let a = spawn_particle(&mut world, DVec2::new(0.2, 0.25), DVec2::X, 1.0, 0.01);
        let b = spawn_particle(&mut world, DVec2::new(0.3, 0.25), -DVec2::X, 3.0, 0.01);
        world.entity_mut(a).insert(ContactGroup(0));
        world.entity_mut(b).insert(ContactGroup(5));
        run_system(&mut world, linear_basis::<Two>);
        run_system(&mut world, assign_fields_system::<Two>);
        run_system(&mut world, usl_predictor::<Two>);
        let fields = node_values::<NodeFields>(&mut world);
        let masses = node_values::<NodeMass>(&mut world);
        let velocities = node_values::<NodeVelocity<Two>>(&mut world);
        assert_eq!(
            fields[0].active(),
            &[FieldKey::new(0, 0), FieldKey::new(5, 0)]
        );
        // Node 0 at the origin: N = (1 − x/h)(1 − y/h).
        assert!((masses[0].0[0] - 0.6 * 0.5).abs() < 1e-14);
        assert!((masses[0].0[1] - 3.0 * 0.4 * 0.5).abs() < 1e-14);
        assert_eq!(velocities[0].0[..2], [DVec2::X, -DVec2::X]);
        // A node far from both holds nothing.
        assert_eq!(fields[8].count, 0);
    }
}
