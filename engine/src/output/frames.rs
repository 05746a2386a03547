//! Frames: the particle and grid state a VTU frame shows, collected from the world.
//!
//! A particle frame holds the engine's own columns (ids, positions, velocities, masses,
//! volumes, stresses, damage, stored energy), then every column a system registered beside its
//! components ([`super::FrameColumns`]), then the velocity field of each particle when some
//! system assigns fields.

use super::{GridFrame, ParticleFrame};
use crate::components::{
    BodyId, Damage, Mass, MaterialId, Node, NodeFields, Particle, ParticleId, Position,
    StrainEnergyDensity, Stress, Velocity, Volume,
};
use crate::dim::{Dim, Dimension, SymOps, VectorOps};
use crate::resources::Thickness;
use crate::with_dim;
use bevy_ecs::prelude::*;

/// Collects the particle state for a VTU frame (the world's [`Dimension`] says which
/// components it has).
pub fn particle_frame(world: &mut World) -> ParticleFrame {
    let dimension = *world.resource::<Dimension>();
    with_dim!(dimension, D => particle_frame_of::<D>(world))
}

fn particle_frame_of<D: Dim>(world: &mut World) -> ParticleFrame {
    let mut query = world.query_filtered::<(
        &ParticleId,
        &BodyId,
        &MaterialId,
        &Position<D>,
        &Velocity<D>,
        &Mass,
        &Volume,
        &Stress<D>,
        &Damage,
        &StrainEnergyDensity,
    ), With<Particle>>();
    let mut f = ParticleFrame::default();
    for (id, body, material, x, v, m, vol, s, d, w) in query.iter(world) {
        f.id.push(id.0);
        f.body.push(body.0);
        f.material.push(material.0);
        f.position.push(x.0.to_3d());
        f.velocity.push(v.0.to_3d());
        f.mass.push(m.0);
        f.volume.push(vol.0);
        f.stress.push(s.0.as_3x3());
        f.damage.push(d.0);
        f.strain_energy_density.push(w.0);
    }
    system_columns::<D>(world, &mut f);
    if D::N == 2 {
        f.thickness = world.get_resource::<Thickness>().map(|t| t.0);
    }
    f
}

/// The grid nodes that carry mass, with each velocity field's key, mass, velocity and normal.
pub fn grid_frame(world: &mut World) -> GridFrame {
    let dimension = *world.resource::<Dimension>();
    with_dim!(dimension, D => grid_frame_of::<D>(world))
}

fn grid_frame_of<D: Dim>(world: &mut World) -> GridFrame {
    let grid = world.resource::<crate::resources::Grid<D>>().clone();
    let mut query = world.query_filtered::<(
        &crate::components::NodeIndex,
        &NodeFields,
        &crate::components::NodeMass,
        &crate::components::NodeVelocity<D>,
        Option<&crate::components::NodeNormal<D>>,
    ), With<Node>>();
    let mut f = GridFrame::default();
    for (index, fields, mass, velocity, normal) in query.iter(world) {
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
fn system_columns<D: Dim>(world: &mut World, f: &mut ParticleFrame) {
    if let Some(columns) = world.get_resource::<super::FrameColumns>().cloned() {
        for (name, values) in columns.read(world) {
            match values {
                super::ColumnValues::Scalar(v) => f.scalars.push((name, v)),
                super::ColumnValues::Vector(v) => f.vectors.push((name, v)),
            }
        }
    }
    if !world.contains_resource::<crate::fields::FieldsAssigned>() {
        return;
    }
    let mut nodes = world.query_filtered::<&NodeFields, With<Node>>();
    let node_fields: Vec<NodeFields> = nodes.iter(world).copied().collect();
    let c = world.resource::<crate::connectivity::Connectivity<D>>();
    if c.row_offsets.len() != f.id.len() + 1 {
        return;
    }
    let field = (0..f.id.len())
        .map(|p| {
            c.row(p)
                .max_by(|&a, &b| c.weights[a].total_cmp(&c.weights[b]).then(b.cmp(&a)))
                .map_or(f64::NAN, |e| {
                    f64::from(node_fields[c.nodes[e] as usize].keys[c.field(e)].0)
                })
        })
        .collect();
    f.scalars.push(("velocity_field".into(), field));
}
