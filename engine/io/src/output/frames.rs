//! Frames: the particle and grid state a VTU frame shows, collected from the world.
//!
//! A particle frame holds the engine's own columns (ids, positions, velocities, masses,
//! volumes, stresses, damage, stored energy), then every column a system registered beside its
//! components ([`super::FrameColumns`]), then the velocity field of each particle when some
//! system assigns fields.

use super::{GridFrame, ParticleFrame};
use bevy_ecs::prelude::*;
use fractum_engine::components::{
    BodyId, Damage, Mass, MaterialId, Node, NodeFields, Particle, ParticleId, Position,
    StrainEnergyDensity, Stress, Velocity, Volume,
};
use fractum_engine::dim::{Dim, Dimension, SymOps, VectorOps};
use fractum_engine::resources::Thickness;
use fractum_engine::storage::single_table;
use fractum_engine::with_dim;
use rayon::prelude::*;

/// Collects the particle state for a VTU frame (the world's [`Dimension`] says which
/// components it has).
pub fn particle_frame(world: &mut World) -> ParticleFrame {
    let mut frame = ParticleFrame::default();
    refill_particle_frame(world, &mut frame);
    frame
}

/// [`particle_frame`] into `frame`, reusing its arrays: code that collects a frame again and
/// again (every step, say) fills the same arrays each time, so it neither allocates nor faults
/// in fresh pages. The engine's columns are copied in parallel (rayon's current pool), each
/// value exactly as [`particle_frame`] gives it. (A run's last good frame keeps the raw
/// columns instead and converts them only on a failure: [`super::LastGoodState`].)
pub fn refill_particle_frame(world: &mut World, frame: &mut ParticleFrame) {
    let dimension = *world.resource::<Dimension>();
    with_dim!(dimension, D => refill_particle_frame_of::<D>(world, frame));
}

/// The engine's own particle columns a frame shows.
pub(super) type EngineColumns<D> = (
    &'static ParticleId,
    &'static BodyId,
    &'static MaterialId,
    &'static Position<D>,
    &'static Velocity<D>,
    &'static Mass,
    &'static Volume,
    &'static Stress<D>,
    &'static Damage,
    &'static StrainEnergyDensity,
);

/// The engine's own particle columns as the world stores them, one slice per component.
pub(super) type EngineSlices<'a, D> = (
    &'a [ParticleId],
    &'a [BodyId],
    &'a [MaterialId],
    &'a [Position<D>],
    &'a [Velocity<D>],
    &'a [Mass],
    &'a [Volume],
    &'a [Stress<D>],
    &'a [Damage],
    &'a [StrainEnergyDensity],
);

fn refill_particle_frame_of<D: Dim>(world: &mut World, f: &mut ParticleFrame) {
    let mut state = world.query_filtered::<EngineColumns<D>, With<Particle>>();
    let query = state.query(world);
    let rows = match single_table(query.contiguous_iter(), "particles") {
        Some(columns) => {
            write_engine_columns::<D>(columns, f);
            columns.0.len()
        }
        None => {
            write_engine_columns::<D>(Default::default(), f);
            0
        }
    };
    system_columns::<D>(world, f, rows);
    if let Some(ownership) = world.get_resource::<fractum_engine::decomposition::Ownership>() {
        // A rank's frame is its piece of the run's: the particles it owns.
        f.retain_rows(&ownership.particles);
    }
    f.thickness = frame_thickness::<D>(world);
}

/// The thickness a frame of a `D` world carries: the scene's in 2D, none in 3D.
pub(super) fn frame_thickness<D: Dim>(world: &World) -> Option<f64> {
    if D::N == 2 {
        world.get_resource::<Thickness>().map(|t| t.0)
    } else {
        None
    }
}

/// Fills the frame's engine columns from the components, converted as VTK expects (vectors
/// with three components, stresses as 3×3), into the frame's own arrays.
pub(super) fn write_engine_columns<D: Dim>(columns: EngineSlices<'_, D>, f: &mut ParticleFrame) {
    let (id, body, material, x, v, m, vol, s, d, w) = columns;
    copy_column(id, &mut f.id, |c| c.0);
    copy_column(body, &mut f.body, |c| c.0);
    copy_column(material, &mut f.material, |c| c.0);
    copy_column(x, &mut f.position, |c| c.0.to_3d());
    copy_column(v, &mut f.velocity, |c| c.0.to_3d());
    copy_column(m, &mut f.mass, |c| c.0);
    copy_column(vol, &mut f.volume, |c| c.0);
    copy_column(s, &mut f.stress, |c| c.0.as_3x3());
    copy_column(d, &mut f.damage, |c| c.0);
    copy_column(w, &mut f.strain_energy_density, |c| c.0);
}

/// `out[p] = value(&column[p])` for every row, in parallel, into `out`'s own allocation.
fn copy_column<C: Sync, T: Send>(
    column: &[C],
    out: &mut Vec<T>,
    value: impl Fn(&C) -> T + Sync + Send,
) {
    column.par_iter().map(value).collect_into_vec(out);
}

/// The grid nodes that carry mass, with each velocity field's key, mass, velocity and normal.
pub fn grid_frame(world: &mut World) -> GridFrame {
    let dimension = *world.resource::<Dimension>();
    with_dim!(dimension, D => grid_frame_of::<D>(world))
}

fn grid_frame_of<D: Dim>(world: &mut World) -> GridFrame {
    let grid = world
        .resource::<fractum_engine::resources::Grid<D>>()
        .clone();
    let mut query = world.query_filtered::<(
        &fractum_engine::components::NodeIndex,
        &NodeFields,
        &fractum_engine::components::NodeMass,
        &fractum_engine::components::NodeVelocity<D>,
        Option<&fractum_engine::components::NodeNormal<D>>,
    ), With<Node>>();
    let mut f = GridFrame::default();
    // A rank's grid frame is its piece of the run's: the nodes it owns.
    let owned = world
        .get_resource::<fractum_engine::decomposition::Ownership>()
        .map(|o| &o.nodes);
    for (index, fields, mass, velocity, normal) in query.iter(world) {
        if owned.is_some_and(|o| !o.get(index.0 as usize).copied().unwrap_or(false)) {
            continue;
        }
        // Normals exist where a contact system gave nodes them; zero elsewhere.
        let normal = normal.copied().unwrap_or_default();
        if mass.0.iter().sum::<f64>() <= 0.0 {
            continue;
        }
        f.index.push(index.0);
        f.position
            .push(grid.node_position(index.0 as usize).to_3d());
        f.fields.push(fields.count);
        f.key.push(std::array::from_fn(|k| {
            if k < usize::from(fields.count) {
                i32::from(fields.keys[k].0)
            } else {
                -1
            }
        }));
        f.mass.push(mass.0);
        f.velocity.push(velocity.0.map(|v| v.to_3d()));
        f.normal.push(normal.0.map(|v| v.to_3d()));
    }
    f
}

/// The columns the installed systems registered ([`super::FrameColumns`]), then the
/// velocity field of each particle at its nearest node (the key `2 × group + side` of the field
/// its largest-weight node puts it in) when some system assigns fields.
/// `rows` is the number of particle rows of the world.
pub(super) fn system_columns<D: Dim>(world: &mut World, f: &mut ParticleFrame, rows: usize) {
    // The frame's previous arrays, by name, for the readers to refill.
    let mut columns: Vec<(String, super::ColumnValues)> = std::mem::take(&mut f.scalars)
        .into_iter()
        .map(|(name, v)| (name, super::ColumnValues::Scalar(v)))
        .chain(
            std::mem::take(&mut f.vectors)
                .into_iter()
                .map(|(name, v)| (name, super::ColumnValues::Vector(v))),
        )
        .collect();
    let mut field_buffer = columns
        .iter()
        .position(|(name, _)| name == "velocity_field")
        .and_then(|k| match columns.swap_remove(k).1 {
            super::ColumnValues::Scalar(v) => Some(v),
            super::ColumnValues::Vector(_) => None,
        })
        .unwrap_or_default();
    match world.get_resource::<super::FrameColumns>().cloned() {
        Some(registered) => registered.read_into(world, &mut columns),
        None => columns.clear(),
    }
    for (name, values) in columns {
        match values {
            super::ColumnValues::Scalar(v) => f.scalars.push((name, v)),
            super::ColumnValues::Vector(v) => f.vectors.push((name, v)),
        }
    }
    if !world.contains_resource::<fractum_engine::fields::FieldsAssigned>() {
        return;
    }
    let mut nodes = world.query_filtered::<&NodeFields, With<Node>>();
    let nodes = nodes.query(world);
    let node_fields = single_table(nodes.contiguous_iter(), "nodes").unwrap_or(&[]);
    let c = world.resource::<fractum_engine::connectivity::Connectivity<D>>();
    if c.row_offsets.len() != rows + 1 {
        return;
    }
    c.row_offsets
        .par_windows(2)
        .map(|row| {
            largest_weight_entry(&c.weights[row[0]..row[1]]).map_or(f64::NAN, |k| {
                let e = row[0] + k;
                f64::from(node_fields[c.nodes[e] as usize].keys[c.field(e)].0)
            })
        })
        .collect_into_vec(&mut field_buffer);
    f.scalars.push(("velocity_field".into(), field_buffer));
}

/// The position of the largest of `weights` in the total order of `f64::total_cmp`, the first
/// on a tie; `None` for no weights. A plain loop: a frame asks it of every particle row, and
/// the last good frame of a run with velocity fields asks it every step.
fn largest_weight_entry(weights: &[f64]) -> Option<usize> {
    // `f64::total_cmp`'s order as integers: the sign-magnitude bits with the magnitude's bits
    // flipped for negative numbers (what `total_cmp` compares), computed once per weight.
    let key = |w: f64| {
        let bits = w.to_bits() as i64;
        bits ^ (((bits >> 63) as u64) >> 1) as i64
    };
    let mut best = (0, key(*weights.first()?));
    for (k, &w) in weights.iter().enumerate().skip(1) {
        let candidate = key(w);
        if candidate > best.1 {
            best = (k, candidate);
        }
    }
    Some(best.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::FrameColumns;
    use fractum_engine::dim::Two;
    use fractum_engine::testing::{spawn_particle, tiny_world};
    use glam::DVec2;

    /// A 2D world of `particles` particles with distinct states, and two registered columns.
    fn world_with(particles: usize, registered: bool) -> World {
        let mut world = tiny_world::<Two>(4, 0.25, 1e-3);
        for k in 0..particles {
            let x = DVec2::new(0.1 + 0.05 * k as f64, 0.3);
            let v = DVec2::new(k as f64, -1.0);
            let p = spawn_particle(&mut world, x, v, 1.0 + k as f64, 0.01);
            world.get_mut::<Damage>(p).unwrap().0 = 0.1 * k as f64;
        }
        if registered {
            let mut columns = FrameColumns::default();
            columns.scalar::<Damage>("twice_damage", |d| 2.0 * d.0);
            columns.vector::<Velocity<Two>>("velocity_again", |v| v.0.to_3d());
            world.insert_resource(columns);
        }
        world
    }

    /// A frame refilled in place, over arrays that held another state (more particles, other
    /// columns), is the frame collected afresh, on one thread and on two.
    #[test]
    fn a_refilled_frame_is_the_fresh_frame() {
        let mut world = world_with(5, true);
        let fresh = particle_frame(&mut world);
        assert_eq!(fresh.id.len(), 5);
        assert_eq!(fresh.scalars[0].1[3], 2.0 * 0.1 * 3.0);
        assert_eq!(fresh.vectors[0].1[4], [4.0, -1.0, 0.0]);
        let mut reused = particle_frame(&mut world_with(9, false));
        reused.scalars.push(("stale".into(), vec![1.0; 9]));
        refill_particle_frame(&mut world, &mut reused);
        assert_eq!(format!("{fresh:?}"), format!("{reused:?}"));
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(2)
            .build()
            .unwrap();
        let mut on_two = ParticleFrame::default();
        pool.install(|| refill_particle_frame(&mut world, &mut on_two));
        assert_eq!(format!("{fresh:?}"), format!("{on_two:?}"));
    }

    /// The loop picks what `Iterator::max_by` with the index as tie-break picks (the frame's
    /// earlier rule): the first of equal weights, a NaN above every number, `None` for an empty
    /// row.
    #[test]
    fn the_largest_weight_entry_is_the_first_of_the_largest() {
        let by_max =
            |w: &[f64]| (0..w.len()).max_by(|&a, &b| w[a].total_cmp(&w[b]).then(b.cmp(&a)));
        let rows: [&[f64]; 9] = [
            &[],
            &[0.5],
            &[0.1, 0.4, 0.4, 0.1],
            &[0.0, -0.0, 0.0],
            &[0.2, f64::NAN, 0.9],
            &[0.25; 9],
            &[0.01, 0.02, 0.6, 0.3, 0.6, 0.07],
            &[-1.0, -0.5, -2.0],
            &[f64::NEG_INFINITY, -f64::NAN, 1e-300, f64::INFINITY],
        ];
        for row in rows {
            assert_eq!(largest_weight_entry(row), by_max(row), "{row:?}");
        }
        assert_eq!(largest_weight_entry(&[0.1, 0.4, 0.4, 0.1]), Some(1));
        assert_eq!(largest_weight_entry(&[0.0, -0.0, 0.0]), Some(0));
    }
}
