//! Velocity fields: the bookkeeping the engine keeps, and the hook a partition system fills.
//!
//! Every node has room for [`MAX_FIELDS`](crate::components::MAX_FIELDS) velocity fields. The
//! engine keeps which fields a node holds ([`NodeFields`](crate::components::NodeFields): keys
//! in ascending order, a key being `2 × contact group + side`) and which slot each particle–node
//! pair maps to (`Connectivity::fields`). Every transfer reads them; none decides them.
//!
//! Deciding them is an algorithm, and algorithms live in systems: a partition system adds its
//! assignment to the step's [`StepSet::AssignFields`](crate::stage::StepSet::AssignFields)
//! window (after the basis stage builds the connectivity), through
//! `Installer::add_systems_to`. Without one, every pair keeps slot 0 and every node one field,
//! key 0. The stock assignment (contact groups, and the DFG paper's Algorithms 1–2 with the
//! separability merge) is `fractum_systems::partition::field_assignment`.

use bevy_ecs::prelude::Resource;

/// Present when some system assigns velocity fields each step (it joined
/// [`StepSet::AssignFields`](crate::stage::StepSet::AssignFields)): frames then carry each
/// particle's `velocity_field`.
#[derive(Resource, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FieldsAssigned;

/// D̄_min of the separability condition (dfg-partitioning-mpm.md §2.3), published by the
/// contact law of the pipeline for the field assignment, which keeps the two sides of a group
/// in one field where they could not separate.
#[derive(Resource, Clone, Copy, Debug, PartialEq)]
pub struct Separability(pub f64);

/// When a damage-gradient partition first gave a node two fields of one contact group (the
/// step), kept by the partition that splits them (`partition/dfg`), so that a run can say when
/// its partition never did: a node splits only where a particle has failed (the separability
/// condition, dfg-partitioning-mpm.md §2.3), and a run in which none did moved as one field.
#[derive(
    Resource, Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize,
)]
pub struct FieldSplits {
    /// The first step with a split node, if any.
    pub first: Option<u64>,
}

crate::checkpoint_keys! { FieldSplits => "engine/field_splits" }

/// Whether some node holds two fields (both sides) of one contact group.
pub fn splits_a_group(fields: &crate::components::NodeFields) -> bool {
    let keys = fields.active();
    keys.windows(2).any(|w| w[0].group() == w[1].group())
}
