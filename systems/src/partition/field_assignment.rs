//! Assignment of particle–node pairs to velocity fields: the partition stage's work inside the
//! step's `assign_fields` window.
//!
//! - Stage: partition, in the window `StepSet::AssignFields` (after the basis stage, before its
//!   check). Not a registration of its own: `partition/bodies` and `partition/dfg` install
//!   [`assign_fields_system`] with [`install_field_assignment`], so that every transfer of the
//!   step (particle to grid, velocity gradient, grid to particle) sees the same fields.
//! - Contact groups (Bardenhagen's multi-field method, dfg-partitioning-mpm.md §1.1.1): a pair's
//!   field is its particle's contact group.
//! - Damage-field gradient (§2.2): within a group, the node's reference direction is the
//!   gradient of the particle with the largest `‖∇D̄_p‖` among that group's particles at the node
//!   (Algorithm 1), and a pair goes to side 0 when `∇D̄_p · ∇D̄_i ≥ 0`, to side 1 otherwise
//!   (Algorithm 2). Particles without a `DamageGradient` (`partition/bodies`) all take side 0.
//! - Separability before the stress (§2.3): the two sides of a group at a node stay separate
//!   fields only when they could separate, i.e. some particle there has failed and both sides'
//!   mass-weighted mean damage exceeds D̄_min (the contact law's `separability`, published as
//!   the engine's `Separability` resource). Otherwise the node keeps one field for the group, so
//!   that intact material moves, and is strained, exactly as a single field. The paper's
//!   update-stress-last order merges such pairs at the contact step, before the velocity
//!   gradient; in this pipeline the stress stage precedes contact, so the merge is made here.
//!   Without it, gradient noise in uniform damage splits intact nodes and the strain of the
//!   step is taken from the split fields. Damage here is `max(D, s)` with the surface flag, as
//!   in eq. 21, from the previous step like the gradients.
//!
//! Each node lists the keys present in ascending key order (`NodeFields`); the slot of a pair
//! is the position of its key in that list. Both passes run in parallel (over nodes, then over
//! particle rows) and the result is independent of the number of threads.

use fractum_engine::fields::{FieldSplits, Separability, splits_a_group};
use fractum_engine::health::{Blowup, Health};
use fractum_engine::prelude::*;
use fractum_engine::stage::StepSet;
use rayon::prelude::*;

/// Adds [`assign_fields_system`] to the step's field-assignment window; one partition system
/// per pipeline assigns the fields.
pub fn install_field_assignment<D: Dim>(installer: &mut Installer) -> Result<(), SceneError> {
    installer.add_systems_to(StepSet::AssignFields, assign_fields_system::<D>)
}

/// What the separability condition needs at assignment: each particle's damage (`max(D, s)`
/// with the surface flag, when there is one) and mass, and D̄_min.
#[derive(Clone, Copy, Debug)]
pub struct Separation<'a> {
    /// Damage per particle row.
    pub damage: &'a [Damage],
    /// Surface flag per particle row, when the pipeline detects surfaces.
    pub surface: Option<&'a [SurfaceFlag]>,
    /// Mass per particle row.
    pub mass: &'a [Mass],
    /// D̄_min.
    pub threshold: f64,
}

impl Separation<'_> {
    /// The damage of particle row `p` that the separability condition uses: `max(D, s)`.
    fn damage_of(&self, p: usize) -> f64 {
        let d = self.damage[p].0;
        self.surface.map_or(d, |s| d.max(s[p].0))
    }
}

/// The field assignment's per-step buffers, kept between steps by its system so that a step
/// does not allocate them.
#[derive(Clone, Debug, Default)]
pub struct FieldScratch<V: Copy> {
    /// Per particle row: its contact group when its damage gradient is zero, else [`GRADED`].
    plain: Vec<u16>,
    /// Algorithm 1's references; meaningful only at the nodes given two fields or more.
    references: Vec<NodeReferences<V>>,
    /// Per node: some particle with a damage gradient has it in its row.
    graded_nodes: Vec<bool>,
    /// Per particle row: the row touches a node with two fields or more.
    touched: Vec<bool>,
    /// The rows of the particles with a damage gradient.
    graded: Vec<usize>,
}

/// The class of a particle with a non-zero damage gradient in [`FieldScratch::plain`] (no group
/// number reaches it: groups are `u8`).
const GRADED: u16 = u16::MAX;

/// The particle columns the assignment reads: groups, damage and masses, and the damage
/// gradients and surface flags where a partition system gave particles them.
#[derive(bevy_ecs::system::SystemParam)]
pub struct AssignmentParticles<'w, 's, D: Dim> {
    particles:
        Query<'w, 's, (&'static ContactGroup, &'static Damage, &'static Mass), With<Particle>>,
    gradients: Query<'w, 's, &'static DamageGradient<D>, With<Particle>>,
    surface: Query<'w, 's, &'static SurfaceFlag, With<Particle>>,
}

/// The field assignment of every step, on the connectivity the basis stage has just built. A
/// node that would need more than `MAX_FIELDS` fields stops the run, reported with the basis
/// stage (whose check follows the window).
pub fn assign_fields_system<D: Dim>(
    clock: Res<SimClock>,
    separability: Option<Res<Separability>>,
    mut health: ResMut<Health>,
    mut connectivity: ResMut<Connectivity<D>>,
    particles: AssignmentParticles<D>,
    mut nodes: Query<&mut NodeFields, With<Node>>,
    mut scratch: Local<FieldScratch<D::Vector>>,
) {
    let AssignmentParticles {
        particles,
        gradients,
        surface,
    } = particles;
    let Some((groups, damage, mass)) = single_table(particles.contiguous_iter(), "particles")
    else {
        return;
    };
    let gradients = single_table(gradients.contiguous_iter(), "particles");
    let Some(fields) = single_table_mut(nodes.contiguous_iter_mut(), "nodes") else {
        return;
    };
    // The separability condition's inputs, only when the pipeline asks for it.
    let separation = separability.map(|s| Separation {
        damage,
        surface: single_table(surface.contiguous_iter(), "particles"),
        mass,
        threshold: s.0,
    });
    let result = assign_fields(
        &mut scratch,
        &mut connectivity,
        groups,
        gradients,
        separation.as_ref(),
        fields,
    );
    if let Err(e) = result {
        health.fail(Blowup::new(
            clock.step + 1,
            StepSet::AssignFields.reported_as(),
            e.to_string(),
        ));
    }
}

/// Adds [`record_field_splits`] after the field assignment (a partition that splits nodes by
/// damage installs it, with the [`FieldSplits`] state).
pub fn install_split_record<D: Dim>(installer: &mut Installer) -> Result<(), SceneError> {
    installer.init_state::<FieldSplits>();
    installer.add_systems_to(
        StepSet::AssignFields,
        record_field_splits.after(assign_fields_system::<D>),
    )
}

/// Records in [`FieldSplits`] the first step at which some node (a node this rank owns, in a
/// distributed run) holds both sides of a contact group. Looked for only until then: afterwards the system reads one resource.
pub fn record_field_splits(
    clock: Res<SimClock>,
    mut splits: ResMut<FieldSplits>,
    owned: fractum_engine::decomposition::OwnedRows,
    nodes: Query<&NodeFields, With<Node>>,
) {
    if splits.first.is_some() {
        return;
    }
    let Some(fields) = single_table(nodes.contiguous_iter(), "nodes") else {
        return;
    };
    // In a distributed run, the nodes this rank owns: a run's first split is the least of
    // its ranks'.
    if fields
        .par_iter()
        .enumerate()
        .any(|(n, f)| owned.node(n) && splits_a_group(f))
    {
        splits.first = Some(clock.step + 1);
    }
}

/// A node that would need more than [`MAX_FIELDS`] velocity fields.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TooManyFields {
    /// Node index.
    pub node: usize,
    /// Keys present at the node.
    pub keys: Vec<FieldKey>,
}

impl std::fmt::Display for TooManyFields {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let groups: Vec<String> = self
            .keys
            .iter()
            .map(|k| format!("group {} side {}", k.group(), k.side()))
            .collect();
        write!(
            f,
            "node {} holds {} velocity fields ({}); a node holds at most {MAX_FIELDS}: fewer \
             contact groups may meet at one place",
            self.node,
            self.keys.len(),
            groups.join(", ")
        )
    }
}

/// Algorithm 1's reference gradient of each contact group present at one node.
#[derive(Clone, Copy, Debug)]
struct NodeReferences<V: Copy> {
    count: usize,
    groups: [u8; MAX_FIELDS],
    gradients: [V; MAX_FIELDS],
    /// The group's two sides are inseparable here and share side 0.
    merged: [bool; MAX_FIELDS],
}

impl<V: VectorOps> NodeReferences<V> {
    fn empty() -> Self {
        Self {
            count: 0,
            groups: [0; MAX_FIELDS],
            gradients: [V::ZERO; MAX_FIELDS],
            merged: [false; MAX_FIELDS],
        }
    }

    /// The field key of a particle of `group` with damage gradient `gradient` here.
    fn key(&self, group: u8, gradient: V) -> FieldKey {
        match (0..self.count).find(|&k| self.groups[k] == group) {
            Some(k) if self.merged[k] => FieldKey::new(group, 0),
            Some(k) => field_key(group, gradient, self.gradients[k]),
            None => field_key(group, gradient, V::ZERO),
        }
    }

    /// Marks the groups whose two sides here fail the separability condition (§2.3).
    fn merge_inseparable(
        &mut self,
        entries: &[(u32, u32)],
        weights: &[f64],
        groups: &[ContactGroup],
        gradient: &impl Fn(usize) -> V,
        separation: &Separation,
    ) {
        // Per group slot and side: Σ N m D, Σ N m, max D.
        let mut sums = [[(0.0, 0.0, 0.0f64); 2]; MAX_FIELDS];
        for &(e, p) in entries {
            let (g, p) = (groups[p as usize].0, p as usize);
            let Some(k) = (0..self.count).find(|&k| self.groups[k] == g) else {
                continue;
            };
            let side = field_key(g, gradient(p), self.gradients[k]).side() as usize;
            let nm = weights[e as usize] * separation.mass[p].0;
            let d = separation.damage_of(p);
            let s = &mut sums[k][side];
            *s = (s.0 + nm * d, s.1 + nm, s.2.max(d));
        }
        for (merged, [a, b]) in self.merged.iter_mut().zip(sums).take(self.count) {
            if a.1 > 0.0 && b.1 > 0.0 {
                let failed = a.2.max(b.2) >= 1.0;
                let damaged = (a.0 / a.1).min(b.0 / b.1) > separation.threshold;
                *merged = !(failed && damaged);
            }
        }
    }
}

/// The field key of a particle of `group` with damage gradient `gradient` at a node whose
/// reference gradient for that group is `reference` (Algorithm 2).
pub fn field_key<V: VectorOps>(group: u8, gradient: V, reference: V) -> FieldKey {
    let side = u8::from(gradient.dot(reference) < 0.0);
    FieldKey::new(group, side)
}

/// Assigns every entry of `c` to a field slot and lists each node's fields in `node_fields`.
///
/// `gradients` are the particles' damage-field gradients (`None`: one field per contact group);
/// `scratch` holds buffers reused from call to call (a default one will do).
pub fn assign_fields<D: Dim>(
    scratch: &mut FieldScratch<D::Vector>,
    c: &mut Connectivity<D>,
    groups: &[ContactGroup],
    gradients: Option<&[DamageGradient<D>]>,
    separation: Option<&Separation>,
    node_fields: &mut [NodeFields],
) -> Result<(), TooManyFields> {
    let FieldScratch {
        plain,
        references,
        graded_nodes,
        touched,
        graded,
    } = scratch;
    let single_group = classify_particles::<D>(groups, gradients, plain);
    references.resize(node_fields.len(), NodeReferences::empty());
    mark_graded_nodes(c, plain, node_fields.len(), graded, graded_nodes);
    let gradient = |p: usize| gradients.map_or(D::Vector::ZERO, |g| g[p].0);
    let c_ref: &Connectivity<D> = c;
    let (plain, graded_nodes): (&[u16], &[bool]) = (plain, graded_nodes);
    // The failure at the lowest node, whatever the thread count; no per-node results kept.
    let failure = node_fields
        .par_iter_mut()
        .zip(references.par_iter_mut())
        .enumerate()
        .map(|(node, (fields, refs))| {
            let entries = c_ref.entries_of_node(node);
            // One group and no damage gradient at the node (most nodes): one field, side 0,
            // which is what the general path below finds, without its three passes. With one
            // group in the whole body of particles, the node's mark says so without a scan.
            let one = match single_group {
                Some(group) => (!graded_nodes[node] && !entries.is_empty()).then_some(group),
                None => one_plain_group(entries, plain),
            };
            if let Some(group) = one {
                fields.count = 1;
                fields.keys = [FieldKey::default(); MAX_FIELDS];
                fields.keys[0] = FieldKey::new(group, 0);
                return None;
            }
            *refs = reference_gradients::<D>(entries, groups, &gradient);
            if let (Some(separation), Some(_)) = (separation, gradients) {
                refs.merge_inseparable(entries, &c_ref.weights, groups, &gradient, separation);
            }
            match node_keys(entries, groups, refs, &gradient) {
                Ok((keys, count)) => {
                    fields.count = count as u8;
                    fields.keys = keys;
                    None
                }
                Err(keys) => Some(TooManyFields { node, keys }),
            }
        })
        .filter_map(|result| result)
        .min_by_key(|failure| failure.node);
    if let Some(failure) = failure {
        return Err(failure);
    }
    mark_touched_rows(c, node_fields, touched);
    assign_slots(c, groups, &gradient, references, node_fields, touched);
    Ok(())
}

/// Marks the nodes in the rows of the particles with a damage gradient (usually a few, near
/// damage and surfaces).
fn mark_graded_nodes<D: Dim>(
    c: &Connectivity<D>,
    plain: &[u16],
    node_count: usize,
    graded: &mut Vec<usize>,
    graded_nodes: &mut Vec<bool>,
) {
    // The graded rows are found in parallel; only the marking from their rows is serial.
    graded.clear();
    graded.par_extend(
        (0..plain.len())
            .into_par_iter()
            .filter(|&p| plain[p] == GRADED),
    );
    graded_nodes.clear();
    graded_nodes.resize(node_count, false);
    for &p in graded.iter() {
        for &node in &c.nodes[c.row_offsets[p]..c.row_offsets[p + 1]] {
            graded_nodes[node as usize] = true;
        }
    }
}

/// Marks the particle rows that touch a node with two fields or more, from those nodes'
/// entries.
fn mark_touched_rows<D: Dim>(
    c: &Connectivity<D>,
    node_fields: &[NodeFields],
    touched: &mut Vec<bool>,
) {
    touched.clear();
    touched.resize(c.row_offsets.len().saturating_sub(1), false);
    for (node, _) in node_fields.iter().enumerate().filter(|(_, f)| f.count >= 2) {
        for &(_, p) in c.entries_of_node(node) {
            touched[p as usize] = true;
        }
    }
}

/// Each particle row's class: its group when its damage gradient is zero, else [`GRADED`].
/// Returns the group when every particle has the same one.
fn classify_particles<D: Dim>(
    groups: &[ContactGroup],
    gradients: Option<&[DamageGradient<D>]>,
    plain: &mut Vec<u16>,
) -> Option<u8> {
    plain.clear();
    match gradients {
        Some(gradients) => plain.par_extend(groups.par_iter().zip(gradients).map(|(g, d)| {
            if d.0 == D::Vector::ZERO {
                u16::from(g.0)
            } else {
                GRADED
            }
        })),
        None => plain.extend(groups.iter().map(|g| u16::from(g.0))),
    }
    let first = groups.first()?.0;
    groups.par_iter().all(|g| g.0 == first).then_some(first)
}

/// The distinct keys of a node's entries in ascending order, or all of them (sorted) when they
/// are more than [`MAX_FIELDS`].
fn node_keys<V: VectorOps>(
    entries: &[(u32, u32)],
    groups: &[ContactGroup],
    refs: &NodeReferences<V>,
    gradient: &impl Fn(usize) -> V,
) -> Result<([FieldKey; MAX_FIELDS], usize), Vec<FieldKey>> {
    // In a small array: no allocation per node.
    let mut keys = [FieldKey::default(); MAX_FIELDS];
    let mut count = 0;
    let key_of = |p: u32| refs.key(groups[p as usize].0, gradient(p as usize));
    for &(_, p) in entries {
        let key = key_of(p);
        let at = keys[..count].partition_point(|&k| k < key);
        if at < count && keys[at] == key {
            continue;
        }
        if count == MAX_FIELDS {
            let mut all: Vec<FieldKey> = entries.iter().map(|&(_, p)| key_of(p)).collect();
            all.sort_unstable();
            all.dedup();
            return Err(all);
        }
        keys.copy_within(at..count, at + 1);
        keys[at] = key;
        count += 1;
    }
    Ok((keys, count))
}

/// The slot of every entry: the position of its key in its node's list. A node with one field
/// gives slot 0 whatever the key, so only the `touched` rows (those that touch a node with two
/// fields or more) look their keys up.
fn assign_slots<D: Dim>(
    c: &mut Connectivity<D>,
    groups: &[ContactGroup],
    gradient: &(impl Fn(usize) -> D::Vector + Sync),
    references: &[NodeReferences<D::Vector>],
    node_fields: &[NodeFields],
    touched: &[bool],
) {
    let Connectivity {
        row_offsets: rows,
        nodes,
        fields,
        ..
    } = c;
    // Rows in fixed blocks, each block one contiguous part of the slot table.
    const BLOCK: usize = 1024;
    let particles = rows.len().saturating_sub(1);
    let mut blocks = Vec::with_capacity(particles.div_ceil(BLOCK));
    let mut rest: &mut [u8] = fields;
    for start in (0..particles).step_by(BLOCK) {
        let end = (start + BLOCK).min(particles);
        let (head, tail) = rest.split_at_mut(rows[end] - rows[start]);
        blocks.push((start..end, head));
        rest = tail;
    }
    blocks.into_par_iter().for_each(|(block, slots)| {
        let base = rows[block.start];
        slots.fill(0);
        for p in block {
            if !touched[p] {
                continue;
            }
            let row = &mut slots[rows[p] - base..rows[p + 1] - base];
            let entries = &nodes[rows[p]..rows[p + 1]];
            let g = groups[p].0;
            for (slot, &node) in row.iter_mut().zip(entries) {
                let fields = &node_fields[node as usize];
                if fields.count <= 1 {
                    continue;
                }
                let key = references[node as usize].key(g, gradient(p));
                *slot = fields.active().iter().position(|&k| k == key).unwrap_or(0) as u8;
            }
        }
    });
}

/// The group of every particle at the node when there is one group and no particle there has a
/// damage gradient (from the particles' classes); `None` otherwise (or for a node without
/// particles).
fn one_plain_group(entries: &[(u32, u32)], plain: &[u16]) -> Option<u8> {
    let class = plain[entries.first()?.1 as usize];
    let one = class != GRADED && entries.iter().all(|&(_, p)| plain[p as usize] == class);
    // Every class but GRADED is a u8 group.
    one.then_some(class as u8)
}

/// Algorithm 1 for one node: for each contact group present, the particle gradient of largest
/// magnitude (the first such particle in row order on a tie).
fn reference_gradients<D: Dim>(
    entries: &[(u32, u32)],
    groups: &[ContactGroup],
    gradient: &impl Fn(usize) -> D::Vector,
) -> NodeReferences<D::Vector> {
    let mut refs = NodeReferences::<D::Vector>::empty();
    let mut norms = [f64::NEG_INFINITY; MAX_FIELDS];
    for &(_, p) in entries {
        let (g, d) = (groups[p as usize].0, gradient(p as usize));
        let k = match (0..refs.count).find(|&k| refs.groups[k] == g) {
            Some(k) => k,
            None if refs.count < MAX_FIELDS => {
                refs.groups[refs.count] = g;
                refs.count += 1;
                refs.count - 1
            }
            // More groups than slots: the key count check reports the node.
            None => continue,
        };
        let norm = d.dot(d);
        if norm > norms[k] {
            norms[k] = norm;
            refs.gradients[k] = d;
        }
    }
    refs
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two particles on one node with opposite damage gradients, plus one of another group.
    fn connectivity() -> Connectivity<Two> {
        let mut c = Connectivity::default();
        let g = DVec2::ZERO;
        c.rebuild(
            &[
                vec![(0, 0.5, g), (1, 0.5, g)],
                vec![(0, 1.0, g)],
                vec![(0, 0.5, g), (1, 0.5, g)],
            ],
            2,
        );
        c
    }

    /// The run of [`record_field_splits`] alone: two groups at a node are not a split, both
    /// sides of one group are, and the first step with one is kept.
    #[test]
    fn the_first_split_of_a_group_is_recorded_once() {
        let mut world = fractum_engine::testing::tiny_world::<Two>(2, 1.0, 0.1);
        world.init_resource::<FieldSplits>();
        let fields = |keys: &[FieldKey]| {
            let mut f = NodeFields {
                count: keys.len() as u8,
                ..NodeFields::default()
            };
            f.keys[..keys.len()].copy_from_slice(keys);
            f
        };
        let two_groups = fields(&[FieldKey::new(0, 0), FieldKey::new(1, 0)]);
        fractum_engine::testing::give_nodes(&mut world, two_groups);
        fractum_engine::testing::run_system(&mut world, record_field_splits);
        assert_eq!(world.resource::<FieldSplits>().first, None);
        let node = world
            .query_filtered::<Entity, With<Node>>()
            .iter(&world)
            .next()
            .unwrap();
        let split = fields(&[FieldKey::new(0, 0), FieldKey::new(0, 1)]);
        world.entity_mut(node).insert(split);
        world.resource_mut::<SimClock>().step = 41;
        fractum_engine::testing::run_system(&mut world, record_field_splits);
        assert_eq!(world.resource::<FieldSplits>().first, Some(42));
        world.resource_mut::<SimClock>().step = 99;
        fractum_engine::testing::run_system(&mut world, record_field_splits);
        assert_eq!(world.resource::<FieldSplits>().first, Some(42));
    }

    #[test]
    fn groups_alone_give_one_field_per_group() {
        let mut c = connectivity();
        let groups = [ContactGroup(0), ContactGroup(0), ContactGroup(3)];
        let mut fields = vec![NodeFields::default(); 2];
        assign_fields(
            &mut FieldScratch::default(),
            &mut c,
            &groups,
            None,
            None,
            &mut fields,
        )
        .unwrap();
        assert_eq!(
            fields[0].active(),
            &[FieldKey::new(0, 0), FieldKey::new(3, 0)]
        );
        assert_eq!(c.fields, vec![0, 0, 0, 1, 1]);
    }

    #[test]
    fn opposite_gradients_split_a_group_at_the_node() {
        let mut c = connectivity();
        let groups = [ContactGroup(0); 3];
        // Particle 1 has the largest gradient: it sets node 0's reference (Algorithm 1).
        let gradients = [
            DamageGradient(DVec2::new(-0.5, 0.1)),
            DamageGradient(DVec2::new(2.0, 0.0)),
            DamageGradient(DVec2::new(0.2, 0.0)),
        ];
        let mut fields = vec![NodeFields::default(); 2];
        assign_fields(
            &mut FieldScratch::default(),
            &mut c,
            &groups,
            Some(&gradients),
            None,
            &mut fields,
        )
        .unwrap();
        assert_eq!(
            fields[0].active(),
            &[FieldKey::new(0, 0), FieldKey::new(0, 1)]
        );
        // Node 1 sees particles 0 and 2 only: particle 0 (|g| larger) is its reference.
        assert_eq!(
            fields[1].active(),
            &[FieldKey::new(0, 0), FieldKey::new(0, 1)]
        );
        // Rows: p0 → (node 0: side 1, node 1: side 0); p1 → node 0 side 0; p2 → (0, 1).
        assert_eq!(c.fields, vec![1, 0, 0, 0, 1]);
    }

    /// The same split, with the separability condition at assignment: intact sides stay one
    /// field; once a particle has failed and both sides are damaged beyond D̄_min they split.
    #[test]
    fn inseparable_sides_stay_one_field() {
        let groups = [ContactGroup(0); 3];
        let gradients = [
            DamageGradient(DVec2::new(-0.5, 0.1)),
            DamageGradient(DVec2::new(2.0, 0.0)),
            DamageGradient(DVec2::new(0.2, 0.0)),
        ];
        let mass = [Mass(1.0); 3];
        let assign = |damage: &[f64]| {
            let mut c = connectivity();
            let mut fields = vec![NodeFields::default(); 2];
            let damage: Vec<Damage> = damage.iter().map(|&d| Damage(d)).collect();
            let separation = Separation {
                damage: &damage,
                surface: None,
                mass: &mass,
                threshold: 0.25,
            };
            assign_fields(
                &mut FieldScratch::default(),
                &mut c,
                &groups,
                Some(&gradients),
                Some(&separation),
                &mut fields,
            )
            .unwrap();
            (fields, c.fields)
        };
        let (fields, slots) = assign(&[0.0, 0.0, 0.0]);
        assert_eq!(fields[0].active(), &[FieldKey::new(0, 0)]);
        assert_eq!(fields[1].active(), &[FieldKey::new(0, 0)]);
        assert_eq!(slots, vec![0; 5]);
        // Particle 0 failed and particle 1 damaged: node 0's sides (p0 | p1) separate; node 1
        // (p0 | p2) does not, as p2 is intact.
        let (fields, slots) = assign(&[1.0, 0.5, 0.0]);
        assert_eq!(
            fields[0].active(),
            &[FieldKey::new(0, 0), FieldKey::new(0, 1)]
        );
        assert_eq!(fields[1].active(), &[FieldKey::new(0, 0)]);
        assert_eq!(slots, vec![1, 0, 0, 0, 0]);
    }

    #[test]
    fn more_fields_than_slots_names_the_node() {
        let mut c = Connectivity::<Two>::default();
        let g = DVec2::ZERO;
        c.rebuild(&vec![vec![(1, 1.0, g)]; 5], 2);
        let groups: Vec<_> = (0..5).map(ContactGroup).collect();
        let mut fields = vec![NodeFields::default(); 2];
        let e = assign_fields(
            &mut FieldScratch::default(),
            &mut c,
            &groups,
            None,
            None,
            &mut fields,
        )
        .unwrap_err();
        assert_eq!(e.node, 1);
        assert!(e.to_string().contains("node 1 holds 5 velocity fields"));
    }

    /// Algorithms 1–2 written out plainly (no shortcuts), without separability: the fields of
    /// each node and the slot of each entry.
    fn plain_assignment(
        rows: &[Vec<u32>],
        groups: &[ContactGroup],
        gradients: &[DamageGradient<Two>],
        node_count: usize,
    ) -> (Vec<Vec<FieldKey>>, Vec<u8>) {
        let key_at = |node: u32, p: usize| {
            let g = groups[p].0;
            // The largest gradient of the group at the node, the first in row order on a tie.
            let mut reference = (f64::NEG_INFINITY, DVec2::ZERO);
            for (q, row) in rows.iter().enumerate() {
                let norm = gradients[q].0.length_squared();
                if groups[q].0 == g && row.contains(&node) && norm > reference.0 {
                    reference = (norm, gradients[q].0);
                }
            }
            field_key(g, gradients[p].0, reference.1)
        };
        let mut keys = vec![Vec::new(); node_count];
        for (p, row) in rows.iter().enumerate() {
            for &node in row {
                keys[node as usize].push(key_at(node, p));
            }
        }
        for k in &mut keys {
            k.sort_unstable();
            k.dedup();
        }
        let slots = rows
            .iter()
            .enumerate()
            .flat_map(|(p, row)| row.iter().map(move |&n| (n, p)))
            .map(|(n, p)| {
                let at = keys[n as usize].iter().position(|&k| k == key_at(n, p));
                at.unwrap_or(0) as u8
            })
            .collect();
        (keys, slots)
    }

    proptest::proptest! {
        /// The shortcuts (one-group nodes, nodes without graded particles, untouched rows)
        /// give what Algorithms 1–2 give, with one contact group and with two.
        #[test]
        fn shortcuts_agree_with_the_plain_algorithms(
            rows in proptest::collection::vec(
                proptest::collection::btree_set(0u32..6, 1..4), 1..12),
            two_groups in proptest::bool::ANY,
            seeds in proptest::collection::vec((0u8..2, -2i8..3, -2i8..3), 12),
        ) {
            let rows: Vec<Vec<u32>> = rows.into_iter().map(|r| r.into_iter().collect()).collect();
            let n = rows.len();
            let groups: Vec<_> = seeds[..n]
                .iter()
                .map(|s| ContactGroup(if two_groups { s.0 } else { 0 }))
                .collect();
            // Mostly zero gradients, as away from damage.
            let gradients: Vec<_> = seeds[..n]
                .iter()
                .map(|s| DamageGradient(DVec2::new(f64::from(s.1.max(0)), f64::from(s.2))))
                .collect();
            let mut c = Connectivity::<Two>::default();
            let weighted: Vec<Vec<_>> = rows
                .iter()
                .map(|r| r.iter().map(|&node| (node, 0.25, DVec2::ZERO)).collect())
                .collect();
            c.rebuild(&weighted, 6);
            let mut fields = vec![NodeFields::default(); 6];
            let mut scratch = FieldScratch::default();
            // Twice with one scratch: the buffers kept between calls change nothing.
            for _ in 0..2 {
                assign_fields(&mut scratch, &mut c, &groups, Some(&gradients), None, &mut fields)
                    .unwrap();
                let (keys, slots) = plain_assignment(&rows, &groups, &gradients, 6);
                for (node, k) in keys.iter().enumerate() {
                    proptest::prop_assert_eq!(fields[node].active(), k.as_slice());
                }
                proptest::prop_assert_eq!(&c.fields, &slots);
            }
        }
    }
}
