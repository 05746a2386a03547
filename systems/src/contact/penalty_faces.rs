//! The crack faces of `contact/penalty` with `between: All`: which particles of one contact group
//! lie on the two sides of a node a damage-gradient partition has split, and where they lay at
//! the start of the run.
//!
//! - Stage: contact (used by the `contact/penalty` system; not a registration itself).
//! - Implements the pair set of the penalty on the faces a partition opens within a body
//!   (dfg-partitioning-mpm.md §2.2–2.4 decides the fields; the potential is
//!   `contact::penalty_law`'s): two particles of one group are partners when some node they
//!   share holds them in different fields ([`FaceSides::across`]). The partition splits a node
//!   only where both sides could separate (the separability condition, §2.3), whose D̄_min this
//!   law publishes ([`install_crack_faces`]), so intact material never is across a face.
//! - The faces touch where their particles lay at the start of the run: the installer gives
//!   every particle its `ReferencePosition`, and the law's touch level is the particle's depth
//!   among its partners there (`penalty_law::face_touch_level`).

use super::penalty_law::PenaltyPairs;
use bevy_ecs::system::SystemParam;
use fractum_engine::prelude::*;
use rayon::prelude::*;

/// The crack faces of a contact set: which particles lie on two sides of a node of their own
/// group, and where each particle lay at the start of the run.
pub struct CrackFaces<'a, V> {
    /// Each particle's sides at the nodes where its group is split.
    pub sides: &'a FaceSides,
    /// Each particle's position at the start of the run.
    pub reference: &'a [V],
}

/// For each particle row, the nodes where a partition has split its contact group into two
/// fields and the particle's side there, sorted by node: two particles of one group lie across
/// a face when some node they share holds them on different sides. The partition only splits a
/// node where both sides could separate (the separability condition), so intact material is
/// never across a face, and this law acts exactly where the fields move apart.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct FaceSides {
    offsets: Vec<u32>,
    entries: Vec<(u32, u8)>,
}

impl FaceSides {
    /// The sides of every particle row of `c` under the node fields `fields` (by node index),
    /// for particles of the groups `groups` (by row).
    pub fn new<D: Dim>(
        c: &Connectivity<D>,
        fields: &[NodeFields],
        groups: &[ContactGroup],
    ) -> Self {
        let rows: Vec<Vec<(u32, u8)>> = (0..c.particle_count())
            .into_par_iter()
            .map(|p| {
                let group = groups[p].0;
                let mut sides: Vec<(u32, u8)> = c
                    .row(p)
                    .filter_map(|e| {
                        let node = c.nodes[e];
                        let keys = fields[node as usize].active();
                        let split = keys.iter().filter(|k| k.group() == group).count() > 1;
                        split.then(|| (node, keys[c.field(e)].side()))
                    })
                    .collect();
                sides.sort_unstable();
                sides
            })
            .collect();
        Self::from_rows(rows)
    }

    /// The sides given row by row: each row's (node, side) pairs, sorted by node.
    pub fn from_rows(rows: Vec<Vec<(u32, u8)>>) -> Self {
        let mut offsets = Vec::with_capacity(rows.len() + 1);
        offsets.push(0);
        let mut entries = Vec::new();
        for row in rows {
            entries.extend(row);
            offsets.push(entries.len() as u32);
        }
        Self { offsets, entries }
    }

    /// The nodes (sorted) where row `p`'s group is split, with its side at each.
    pub fn of(&self, p: usize) -> &[(u32, u8)] {
        match self.offsets.get(p..p + 2) {
            Some(&[from, to]) => &self.entries[from as usize..to as usize],
            _ => &[],
        }
    }

    /// Whether rows `p` and `q` lie on different sides of a node they share.
    pub fn across(&self, p: usize, q: usize) -> bool {
        let (a, b) = (self.of(p), self.of(q));
        let (mut i, mut j) = (0, 0);
        while i < a.len() && j < b.len() {
            match a[i].0.cmp(&b[j].0) {
                std::cmp::Ordering::Less => i += 1,
                std::cmp::Ordering::Greater => j += 1,
                std::cmp::Ordering::Equal => {
                    if a[i].1 != b[j].1 {
                        return true;
                    }
                    i += 1;
                    j += 1;
                }
            }
        }
        false
    }
}

/// What the crack faces are read from: the fields each node holds, and each particle's
/// position at the start of the run.
#[derive(SystemParam)]
pub struct FaceQueries<'w, 's, D: Dim> {
    fields: Query<'w, 's, &'static NodeFields, With<Node>>,
    references: Query<'w, 's, &'static ReferencePosition<D>, With<Particle>>,
}

/// The crack faces of one step, owned: each particle's sides and start-of-run position.
pub struct FaceData<V> {
    sides: FaceSides,
    reference: Vec<V>,
}

impl<V> FaceData<V> {
    /// The faces as the contact set reads them.
    pub fn view(&self) -> CrackFaces<'_, V> {
        CrackFaces {
            sides: &self.sides,
            reference: &self.reference,
        }
    }
}

/// The crack faces of this step, when the law acts on them (`between: All`) and some node
/// holds two sides of a group; `None` otherwise.
pub fn crack_faces<D: Dim>(
    between: PenaltyPairs,
    c: &Connectivity<D>,
    faces: &FaceQueries<D>,
    groups: &[ContactGroup],
) -> Option<FaceData<D::Vector>> {
    if between != PenaltyPairs::All {
        return None;
    }
    let fields = single_table(faces.fields.contiguous_iter(), "nodes")?;
    if !fields.iter().any(fractum_engine::fields::splits_a_group) {
        return None;
    }
    let reference = single_table(faces.references.contiguous_iter(), "particles")?;
    Some(FaceData {
        sides: FaceSides::new(c, fields, groups),
        reference: reference.iter().map(|x| x.0).collect(),
    })
}

/// With `between: All` this law alone takes the faces a partition opens within a group: a
/// nodal law in the same pipeline would act on them too.
pub fn check_no_nodal_law(installer: &Installer, params: &Params) -> Result<(), SceneError> {
    if installer.pipeline_has("contact/frictional") {
        return Err(params.error(
            "between",
            "`between: All` acts on crack faces and between contact groups, and so would the \
             pipeline's contact/frictional: remove contact/frictional, or give this entry \
             `between: Groups` and contact/frictional `between: CrackFaces`",
        ));
    }
    Ok(())
}

/// What the crack faces need: the separability condition's D̄_min for the field assignment
/// (no nodal law publishes it here) and each particle's position at the start of the run, where
/// the faces touch ([`ReferencePosition`]).
pub fn install_crack_faces<D: Dim>(installer: &mut Installer, separability: f64) {
    installer.insert_resource(fractum_engine::fields::Separability(separability));
    installer.add_particle_component_with(ReferencePosition::<D>::default(), |particle| {
        particle
            .get::<Position<D>>()
            .map(|x| ReferencePosition::<D>(x.0))
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two rows share a node on different sides only where their lists meet on that node.
    #[test]
    fn across_needs_a_shared_node_on_different_sides() {
        let sides = FaceSides::from_rows(vec![
            vec![(1, 0), (4, 0)],
            vec![(2, 1), (4, 1)],
            vec![(1, 0), (2, 1)],
            vec![],
        ]);
        assert!(sides.across(0, 1));
        assert!(!sides.across(0, 2));
        assert!(sides.across(1, 0) && sides.across(2, 0) == sides.across(0, 2));
        assert!(!sides.across(0, 3) && !sides.across(3, 3));
    }
}
