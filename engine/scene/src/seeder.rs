//! A scene's bodies as seeds and particles: each body's seeds (its shape's lattice points,
//! overlaps with other bodies resolved in `overlap.rs`), and the particle at each seed with
//! the material, velocity and damage its body, point file, image phases and cracks give it.

use super::SceneError;
use super::points::PointSet;
use super::seed::{Seeds, particles_in_shape};
use super::spec::{Body, Spec};
use fractum_engine::components::{
    BodyId, ContactGroup, Damage, ParticleBundle, Velocity, WaveSpeed,
};
use fractum_engine::dim::{Dim, VectorOps};

/// What a seeded particle starts with: its material index, velocity and damage.
type SeedState<D> = (usize, <D as Dim>::Vector, f64);

/// Seeds the bodies of one spec and makes their particles.
pub(crate) struct Seeder<'s, D: Dim> {
    pub(crate) spec: &'s Spec<D>,
}

impl<'s, D: Dim> Seeder<'s, D> {
    /// The seeder of `spec`.
    pub(crate) fn new(spec: &'s Spec<D>) -> Self {
        Self { spec }
    }

    /// Each body's seeds (position, volume), overlaps with other bodies resolved, in body
    /// order.
    pub(crate) fn bodies(&self) -> Result<Vec<Seeds<D>>, SceneError> {
        self.spec
            .bodies
            .iter()
            .enumerate()
            .map(|(b, body)| self.body(b, body))
            .collect()
    }

    /// Body `b`'s seeds: its shape's, less what overlaps a body that wins over it.
    fn body(&self, b: usize, body: &Body<D>) -> Result<Vec<(D::Vector, f64)>, SceneError> {
        let seeded = particles_in_shape(
            &body.shape,
            &self.spec.grid,
            body.particles_per_cell,
            body.placement,
            self.spec.thickness,
        );
        let seeded = self.resolve_overlaps(b, seeded)?;
        if seeded.is_empty() {
            return Err(self.spec.source.error(
                &format!("bodies[{b}].shape"),
                "no particle falls inside this shape; make it larger than a cell or use more \
                 particles per cell",
            ));
        }
        Ok(seeded)
    }

    /// What a particle of `body` seeded at `x` starts with: its material index, velocity and
    /// damage, from the body, its point file's attributes, its image's phases and its cracks.
    pub(crate) fn state<'a>(
        &'a self,
        b: usize,
        body: &'a Body<D>,
    ) -> Result<impl Fn(D::Vector) -> SeedState<D> + 'a, SceneError> {
        let material = self
            .spec
            .material_index(&body.material, &format!("bodies[{b}].material"))?;
        // What a point file gives of each particle overrides the body's defaults.
        let points = body.shape.point_set();
        let point_materials: Vec<usize> = match points {
            Some(set) => set
                .material_names()
                .iter()
                .map(|name| self.point_material(set, name, &format!("bodies[{b}].shape")))
                .collect::<Result<_, _>>()?,
            None => Vec::new(),
        };
        // An image's phases may name their own materials.
        let image = body.shape.image();
        let phase_materials: Vec<usize> = match image {
            Some(image) => image
                .phases()
                .iter()
                .map(|p| match &p.material {
                    Some(name) => self
                        .spec
                        .material_index(name, &format!("bodies[{b}].shape")),
                    None => Ok(material),
                })
                .collect::<Result<_, _>>()?,
            None => Vec::new(),
        };
        Ok(move |x: D::Vector| {
            let given = points.and_then(|set| set.attributes(x.to_3d().into()));
            let material = given
                .and_then(|g| g.material)
                .and_then(|name| points?.material_names().iter().position(|n| n == name))
                .map_or(material, |k| point_materials[k]);
            let material = image
                .and_then(|image| image.phase_at(x.to_3d().into()))
                .map_or(material, |k| phase_materials[k]);
            let velocity = given
                .and_then(|g| g.velocity)
                .map_or_else(|| body.velocity.at(x), |v| D::Vector::from_fn(|a| v[a]));
            let cracked = body
                .cracks
                .iter()
                .any(|crack| crack.contains(x.to_3d().into()));
            let damage = if cracked {
                1.0
            } else {
                given.and_then(|g| g.damage).unwrap_or(0.0)
            };
            (material, velocity, damage)
        })
    }

    /// The particles of body `b` at its seeds, with ids from `next_id` on.
    pub(crate) fn particles(
        &self,
        b: usize,
        body: &Body<D>,
        seeded: Vec<(D::Vector, f64)>,
        next_id: &mut u32,
    ) -> Result<Vec<ParticleBundle<D>>, SceneError> {
        if (*next_id as usize).saturating_add(seeded.len()) > u32::MAX as usize {
            return Err(self.spec.source.error("bodies", "more than 2^32 particles"));
        }
        let initial = self.state(b, body)?;
        // A quasi-static run's particles carry the scaled masses (`Spec::inertial_materials`).
        let materials = self.spec.inertial_materials();
        if let Some((x, volume, v, density)) = seeded.iter().find_map(|&(x, volume)| {
            let (material, v, _) = initial(x);
            let density = materials[material].density;
            let finite = v.is_finite() && (0.5 * density * volume * v.dot(v)).is_finite();
            (!finite).then_some((x, volume, v, density))
        }) {
            return Err(self.spec.source.error(
                &format!("bodies[{b}].velocity"),
                format!(
                    "the velocity at the particle at {:?} is {:?} m/s, whose kinetic energy ½mv² \
                     = {:e} J is not a finite number; expected finite velocities of finite energy",
                    x.to_3d(),
                    v.to_3d(),
                    0.5 * density * volume * v.dot(v)
                ),
            ));
        }
        Ok(seeded
            .iter()
            .map(|&(x, volume)| {
                let (material, velocity, damage) = initial(x);
                let m = &materials[material];
                let mut p = ParticleBundle::<D>::new(
                    *next_id,
                    x,
                    m.density * volume,
                    volume,
                    material as u16,
                );
                *next_id += 1;
                p.velocity = Velocity(velocity);
                p.body = BodyId(b as u16);
                p.wave_speed = WaveSpeed(m.wave_speed());
                p.damage = Damage(damage);
                p.group = ContactGroup(body.contact_group);
                p
            })
            .collect())
    }

    /// The scene's material a point file's `material` value names: a name (CSV) or an index
    /// into the scene's materials (VTU, as Fractum's frames write it).
    fn point_material(&self, set: &PointSet, name: &str, field: &str) -> Result<usize, SceneError> {
        if !set.materials_by_index() {
            return self.spec.material_index(name, field);
        }
        match name.parse::<usize>() {
            Ok(k) if k < self.spec.materials.len() => Ok(k),
            _ => Err(self.spec.source.error(
                field,
                format!(
                    "the point file's `material` holds {name}; expected an index of the scene's \
                     materials, 0 to {}",
                    self.spec.materials.len() - 1
                ),
            )),
        }
    }

    /// The seeds of `body` a pipeline's install sees in the memory estimate's probe: the first
    /// of each material, undamaged and damaged, so that what installers check of the
    /// particles (their contact groups, materials, seeded damage) holds as in the real build.
    pub(crate) fn sample(
        &self,
        b: usize,
        body: &Body<D>,
        seeded: &[(D::Vector, f64)],
    ) -> Result<Vec<(D::Vector, f64)>, SceneError> {
        let state = self.state(b, body)?;
        let mut kinds: Vec<(usize, bool)> = Vec::new();
        let mut sample = Vec::new();
        for &(x, volume) in seeded {
            let (material, _, damage) = state(x);
            let kind = (material, damage > 0.0);
            if !kinds.contains(&kind) {
                kinds.push(kind);
                sample.push((x, volume));
            }
        }
        Ok(sample)
    }

    /// The bodies whose particle file gives a `strength_scale` column, by index.
    pub(crate) fn scaled_bodies(&self) -> Vec<u16> {
        (self.spec.bodies.iter().enumerate())
            .filter(|(_, body)| {
                body.shape
                    .point_set()
                    .is_some_and(|s| s.has_strength_scale())
            })
            .map(|(b, _)| b as u16)
            .collect()
    }
}
