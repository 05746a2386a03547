//! The state at the start of every step, kept for a blow-up's last good frame
//! (`frames/particles_last_good_<step>.vtu`).
//!
//! A run keeps it every step and writes it only when a step fails, so the copy is what costs:
//! the engine's own particle columns are copied as the world stores them (a memory copy, two
//! components per vector in 2D, a symmetric stress as its own few numbers) and converted into a
//! [`ParticleFrame`] only when the frame is written. The columns systems register are read as a
//! frame reads them. The written frame is the frame [`super::particle_frame`] would have given
//! at the start of the step, value for value.

use super::ParticleFrame;
use super::frames::write_engine_columns;
use super::frames::{EngineColumns, EngineSlices, frame_thickness, system_columns};
use bevy_ecs::prelude::*;
use fractum_engine::components::{
    BodyId, Damage, Mass, MaterialId, Particle, ParticleId, Position, StrainEnergyDensity, Stress,
    Velocity, Volume,
};
use fractum_engine::dim::{Dim, Dimension};
use fractum_engine::storage::single_table;
use fractum_engine::with_dim;
use std::any::Any;

/// The particle state at the start of a step, refilled in place each step (no allocation once
/// the arrays have grown), turned into a frame by [`Self::frame`].
#[derive(Default)]
pub struct LastGoodState {
    /// The world's dimension at the last refill; `None` before the first.
    dimension: Option<Dimension>,
    /// The engine's columns, an [`EngineRows`] of the world's dimension.
    engine: Option<Box<dyn Any + Send + Sync>>,
    /// The registered columns (and the velocity field), as a frame computes them; its engine
    /// columns stay empty.
    systems: ParticleFrame,
    /// A rank's owned particles at the refill, when the world is a rank's.
    owned: Option<Vec<bool>>,
}

/// The engine's own particle columns, as the world stores them.
#[derive(Default)]
struct EngineRows<D: Dim> {
    id: Vec<ParticleId>,
    body: Vec<BodyId>,
    material: Vec<MaterialId>,
    position: Vec<Position<D>>,
    velocity: Vec<Velocity<D>>,
    mass: Vec<Mass>,
    volume: Vec<Volume>,
    stress: Vec<Stress<D>>,
    damage: Vec<Damage>,
    energy: Vec<StrainEnergyDensity>,
}

impl<D: Dim> EngineRows<D> {
    fn refill(&mut self, columns: EngineSlices<'_, D>) {
        fn copy<T: Copy>(out: &mut Vec<T>, column: &[T]) {
            out.clear();
            out.extend_from_slice(column);
        }
        let (id, body, material, x, v, m, vol, s, d, w) = columns;
        copy(&mut self.id, id);
        copy(&mut self.body, body);
        copy(&mut self.material, material);
        copy(&mut self.position, x);
        copy(&mut self.velocity, v);
        copy(&mut self.mass, m);
        copy(&mut self.volume, vol);
        copy(&mut self.stress, s);
        copy(&mut self.damage, d);
        copy(&mut self.energy, w);
    }

    fn slices(&self) -> EngineSlices<'_, D> {
        (
            &self.id,
            &self.body,
            &self.material,
            &self.position,
            &self.velocity,
            &self.mass,
            &self.volume,
            &self.stress,
            &self.damage,
            &self.energy,
        )
    }
}

impl LastGoodState {
    /// Keeps the state of `world` (the particles' engine and registered columns, a rank's
    /// ownership), replacing what was kept.
    pub fn refill(&mut self, world: &mut World) {
        let dimension = *world.resource::<Dimension>();
        with_dim!(dimension, D => self.refill_of::<D>(world));
    }

    fn refill_of<D: Dim>(&mut self, world: &mut World) {
        if self.dimension != Some(D::DIMENSION) || self.engine.is_none() {
            self.engine = Some(Box::new(EngineRows::<D>::default()));
            self.dimension = Some(D::DIMENSION);
        }
        let rows = self.engine_rows_mut::<D>();
        let mut state = world.query_filtered::<EngineColumns<D>, With<Particle>>();
        let query = state.query(world);
        let count = match single_table(query.contiguous_iter(), "particles") {
            Some(columns) => {
                rows.refill(columns);
                columns.0.len()
            }
            None => {
                rows.refill(Default::default());
                0
            }
        };
        system_columns::<D>(world, &mut self.systems, count);
        self.systems.thickness = frame_thickness::<D>(world);
        let ownership = world.get_resource::<fractum_engine::decomposition::Ownership>();
        match (ownership, &mut self.owned) {
            (Some(ownership), Some(owned)) => owned.clone_from(&ownership.particles),
            (Some(ownership), None) => self.owned = Some(ownership.particles.clone()),
            (None, owned) => *owned = None,
        }
    }

    fn engine_rows_mut<D: Dim>(&mut self) -> &mut EngineRows<D> {
        self.engine
            .as_mut()
            .and_then(|rows| rows.downcast_mut::<EngineRows<D>>())
            .expect("the rows were made for the world's dimension")
    }

    /// The kept state as a frame: what [`super::particle_frame`] gave when it was kept (a
    /// rank's piece: the particles it owned). `None` before the first refill.
    pub fn frame(&self) -> Option<ParticleFrame> {
        let dimension = self.dimension?;
        Some(with_dim!(dimension, D => self.frame_of::<D>()))
    }

    fn frame_of<D: Dim>(&self) -> ParticleFrame {
        let rows = self
            .engine
            .as_ref()
            .and_then(|rows| rows.downcast_ref::<EngineRows<D>>())
            .expect("the rows were made for the kept dimension");
        let mut frame = self.systems.clone();
        write_engine_columns::<D>(rows.slices(), &mut frame);
        if let Some(owned) = &self.owned {
            frame.retain_rows(owned);
        }
        frame
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::{FrameColumns, particle_frame};
    use fractum_engine::components::ParticleBundle;
    use fractum_engine::dim::{SymOps, Three, Two, VectorOps};
    use fractum_engine::testing::tiny_world;

    /// A `D` world of `particles` particles with distinct states and a registered column.
    fn world_of<D: Dim>(particles: usize) -> World {
        let mut world = tiny_world::<D>(4, 0.25, 1e-3);
        for k in 0..particles {
            let x = D::Vector::from_fn(|a| 0.1 + 0.05 * (k + a) as f64);
            let v = D::Vector::from_fn(|a| k as f64 - a as f64);
            let mut bundle = ParticleBundle::<D>::new(k as u32, x, 1.0 + k as f64, 0.01, 0);
            bundle.velocity.0 = v;
            bundle.damage.0 = 0.1 * k as f64;
            bundle.stress.0 = <D::Sym as SymOps<D::Vector, D::Matrix>>::from_fn(|i, j| {
                (k + i + 2 * j + 2 * i * j) as f64
            });
            world.spawn(bundle);
        }
        let mut columns = FrameColumns::default();
        columns.scalar::<Damage>("twice_damage", |d| 2.0 * d.0);
        world.insert_resource(columns);
        world
    }

    /// The kept state, written after the world has moved on, is the frame of the world when it
    /// was kept, in 2D and 3D; a refill over another state (more particles) replaces it whole.
    #[test]
    fn the_kept_state_is_the_frame_at_the_refill() {
        fn check<D: Dim>() {
            let mut kept = LastGoodState::default();
            assert!(kept.frame().is_none());
            kept.refill(&mut world_of::<D>(9));
            let mut world = world_of::<D>(5);
            kept.refill(&mut world);
            let expected = particle_frame(&mut world);
            let mut query = world.query::<&mut Position<D>>();
            for mut x in query.iter_mut(&mut world) {
                x.0 = D::Vector::from_fn(|_| 0.9);
            }
            let frame = kept.frame().unwrap();
            assert_eq!(frame.id.len(), 5);
            assert_eq!(format!("{expected:?}"), format!("{frame:?}"));
            assert_ne!(
                format!("{:?}", particle_frame(&mut world)),
                format!("{frame:?}")
            );
        }
        check::<Two>();
        check::<Three>();
    }

    /// A rank's kept state is its piece: the particles it owned at the refill.
    #[test]
    fn a_ranks_kept_state_is_its_owned_particles() {
        let mut world = world_of::<Two>(4);
        let layout = fractum_engine::decomposition::Layout {
            axis: 0,
            slabs: vec![0..2, 2..4],
            halo: 1,
        };
        let mut ownership = fractum_engine::decomposition::Ownership::new(layout, 0, 2, 0..5);
        ownership.particles = vec![true, false, true, false];
        world.insert_resource(ownership);
        let mut kept = LastGoodState::default();
        kept.refill(&mut world);
        let frame = kept.frame().unwrap();
        assert_eq!(frame.position.len(), 2);
        assert_eq!(
            format!("{:?}", particle_frame(&mut world)),
            format!("{frame:?}")
        );
    }
}
