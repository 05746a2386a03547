//! Checks on a [`Spec`] that need no world: every value in range, every name resolved. They
//! run for specs read from a file and for specs built in code alike; each error names the
//! field path, which a file's spec turns into a place in the text.

use super::SceneError;
use super::format::{Placement, Probe};
use super::seed::cell_points;
use super::shape::Shape;
use super::spec::{Body, Condition, Spec};
use fractum_engine::boundary::PiecewiseLinear;
use fractum_engine::dim::{Dim, VectorOps};
use fractum_engine::simulation::{End, TimeStep};

/// Checks on a spec that need no world: every value in range, every name resolved.
pub(crate) struct Checks<'s, D: Dim> {
    pub(crate) spec: &'s Spec<D>,
}

impl<'s, D: Dim> Checks<'s, D> {
    /// The checks of `spec`.
    pub(crate) fn new(spec: &'s Spec<D>) -> Self {
        Self { spec }
    }

    /// Checks every value of the spec; the first problem is the error.
    pub(crate) fn all(&self) -> Result<(), SceneError> {
        self.grid()?;
        self.materials()?;
        self.thickness()?;
        self.bodies()?;
        self.boundaries()?;
        self.probes()?;
        if !self.spec.body_force.is_finite() {
            return Err(self
                .spec
                .source
                .error("body_force", "expected finite numbers"));
        }
        self.time()
    }

    fn grid(&self) -> Result<(), SceneError> {
        let g = &self.spec.grid;
        if !(g.spacing.is_finite() && g.spacing > 0.0) {
            return Err(self
                .spec
                .source
                .error("grid.spacing", "expected a positive spacing"));
        }
        if !g.min.is_finite() {
            return Err(self
                .spec
                .source
                .error("grid.min", "expected finite coordinates"));
        }
        if (0..D::N).any(|a| g.cells[a] == 0) {
            return Err(self
                .spec
                .source
                .error("grid.max", "expected at least one cell along each axis"));
        }
        if g.cells
            .as_ref()
            .iter()
            .try_fold(1usize, |n, c| n.checked_mul(*c))
            .is_none_or(|n| n > 100_000_000)
        {
            return Err(self
                .spec
                .source
                .error("grid.spacing", "the grid would have more than 10^8 cells"));
        }
        Ok(())
    }

    fn materials(&self) -> Result<(), SceneError> {
        for m in &self.spec.materials {
            let field = |f: &str| format!("materials.{}.{f}", m.name);
            if !(m.density.is_finite() && m.density > 0.0) {
                return Err(self
                    .spec
                    .source
                    .error(&field("density"), "expected a positive density (kg/m³)"));
            }
            if !(m.youngs_modulus.is_finite() && m.youngs_modulus > 0.0) {
                return Err(self
                    .spec
                    .source
                    .error(&field("youngs_modulus"), "expected a positive modulus (Pa)"));
            }
            if !(m.poisson_ratio > -1.0 && m.poisson_ratio < 0.5) {
                return Err(self
                    .spec
                    .source
                    .error(&field("poisson_ratio"), "expected a value in (-1, 0.5)"));
            }
            if !(m.wave_speed().is_finite() && m.wave_speed() > 0.0) {
                return Err(self.spec.source.error(
                    &field("density"),
                    format!(
                        "the wave speed √(E/ρ) of this density and modulus is {:e} m/s; expected a \
                         finite, positive speed",
                        m.wave_speed()
                    ),
                ));
            }
            if self
                .spec
                .materials
                .iter()
                .filter(|other| other.name == m.name)
                .count()
                > 1
            {
                return Err(self.spec.source.error(
                    "materials",
                    format!("material \"{}\" is defined twice", m.name),
                ));
            }
        }
        if self.spec.materials.len() > u16::MAX as usize {
            return Err(self.spec.source.error("materials", "too many materials"));
        }
        Ok(())
    }

    fn thickness(&self) -> Result<(), SceneError> {
        if D::N == 2 && !(self.spec.thickness.is_finite() && self.spec.thickness > 0.0) {
            return Err(self
                .spec
                .source
                .error("thickness", "expected a positive thickness (m)"));
        }
        if D::N == 3 && self.spec.thickness != 1.0 {
            return Err(self.spec.source.error(
                "thickness",
                "a thickness is for 2D scenes; a 3D body has its own depth",
            ));
        }
        Ok(())
    }

    fn shape(&self, field: &str, shape: &Shape) -> Result<(), SceneError> {
        if shape.is_boolean() {
            if let Some(expected) = shape.problem() {
                return Err(self
                    .spec
                    .source
                    .error(field, format!("expected {expected}")));
            }
            for (k, operand) in shape.operands().into_iter().enumerate() {
                self.shape(&format!("{field}{}", shape.operand_path(k)), operand)?;
            }
            return Ok(());
        }
        if shape.dimension() != D::N {
            let allowed = match D::N {
                2 => {
                    "Rectangle, Disk, Polygon, Mesh (of triangles and quadrilaterals), Points, Image (a picture) and their Union, \
                     Intersection, Difference"
                }
                _ => {
                    "Box, Sphere, Cylinder, Prism, Surface, Mesh (of tetrahedra and hexahedra), Points, Image (a stack) and their \
                     Union, Intersection, Difference"
                }
            };
            return Err(self.spec.source.error(
                field,
                format!(
                    "{} is a {} shape and the scene is {}; its shapes are {allowed}",
                    shape.kind(),
                    fractum_engine::dim::Dimension::of_count(shape.dimension())
                        .map_or("3D", |d| d.describe()),
                    D::NAME
                ),
            ));
        }
        if let Some(expected) = shape.problem() {
            return Err(self
                .spec
                .source
                .error(field, format!("expected {expected}")));
        }
        Ok(())
    }

    /// Refuses a point set where a shape must have an inside (a crack, a load region).
    fn has_inside(&self, field: &str, shape: &Shape) -> Result<(), SceneError> {
        if shape.holds_points() {
            return Err(self.spec.source.error(
                field,
                "a point set has no inside, so it cannot mark a crack or a region; use a shape \
                 or a mesh",
            ));
        }
        Ok(())
    }

    fn bodies(&self) -> Result<(), SceneError> {
        if self.spec.bodies.is_empty() {
            return Err(self
                .spec
                .source
                .error("bodies", "expected at least one body"));
        }
        if self.spec.bodies.len() > u16::MAX as usize {
            return Err(self.spec.source.error("bodies", "too many bodies"));
        }
        for (b, body) in self.spec.bodies.iter().enumerate() {
            self.body(b, body)?;
        }
        Ok(())
    }

    /// Body `b`: its name, material, seeding, shapes, loads, velocity and `wins_over`.
    fn body(&self, b: usize, body: &Body<D>) -> Result<(), SceneError> {
        let field = |f: &str| format!("bodies[{b}].{f}");
        if let Some(name) = &body.name
            && let Some(first) = self.spec.bodies[..b]
                .iter()
                .position(|other| other.name.as_ref() == Some(name))
        {
            return Err(self.spec.source.error(
                &field("name"),
                format!(
                    "the name \"{name}\" is already that of bodies[{first}]; probes and \
                     contact groups name bodies, so each needs its own name"
                ),
            ));
        }
        self.spec
            .material_index(&body.material, &field("material"))?;
        self.seeding(b, body)?;
        self.shape(&field("shape"), &body.shape)?;
        self.inside_grid(&field("shape"), &body.shape)?;
        for (k, crack) in body.cracks.iter().enumerate() {
            self.shape(&field(&format!("cracks[{k}]")), crack)?;
            self.has_inside(&field(&format!("cracks[{k}]")), crack)?;
        }
        self.loads(b, body)?;
        if let Some(expected) = body.velocity.problem() {
            return Err(self
                .spec
                .source
                .error(&field("velocity"), format!("expected {expected}")));
        }
        self.winners(b)
    }

    /// How body `b` is seeded: particles per cell and placement that its shape can take, and
    /// the materials its image's phases name.
    fn seeding(&self, b: usize, body: &Body<D>) -> Result<(), SceneError> {
        let field = |f: &str| format!("bodies[{b}].{f}");
        if body.particles_per_cell == 0 || body.particles_per_cell > 16 {
            return Err(self
                .spec
                .source
                .error(&field("particles_per_cell"), "expected 1 to 16"));
        }
        if let Some(path) = body.shape.misplaced_element_seeding() {
            return Err(self.spec.source.error(
                &format!("{}{path}", field("shape")),
                "a point set, an image, or a mesh seeded by `Elements`, places the body's \
                 particles, so it must be the body's shape or the first operand of an \
                 Intersection or Difference (a mesh elsewhere takes `seeding: Grid`; an \
                 image may crop as a later operand)",
            ));
        }
        if let Some(image) = body.shape.image() {
            let path = body.shape.image_path();
            for (k, phase) in image.phases().iter().enumerate() {
                if let Some(name) = &phase.material {
                    let at = format!("{}{path}.phases[{k}].material", field("shape"));
                    self.spec.material_index(name, &at)?;
                }
            }
        }
        let elements = body.shape.point_set().is_none() && body.shape.image().is_none();
        if body.shape.seeds_itself() && elements {
            if !(1..=2).contains(&body.particles_per_cell) {
                return Err(self.spec.source.error(
                    &field("particles_per_cell"),
                    "a mesh seeded by `Elements` takes 1 (one particle per element, at its \
                     centroid) or 2 (three per triangle, four per quadrilateral or \
                     tetrahedron, eight per hexahedron)",
                ));
            }
        } else if body.placement == Placement::Rings {
            if !matches!(body.shape, Shape::Disk { .. }) {
                return Err(self.spec.source.error(
                    &field("placement"),
                    "Rings placement seeds Disk shapes only; use Uniform or Gauss",
                ));
            }
        } else if cell_points(body.placement, body.particles_per_cell).is_none() {
            return Err(self.spec.source.error(
                &field("particles_per_cell"),
                "Gauss placement supports 1, 2 or 3 particles per cell per direction",
            ));
        }
        Ok(())
    }

    /// Body `b`'s loads: regions with particles in them, finite forces, valid ramps.
    fn loads(&self, b: usize, body: &Body<D>) -> Result<(), SceneError> {
        for (k, load) in body.loads.iter().enumerate() {
            let at = |f: &str| format!("bodies[{b}].loads[{k}].{f}");
            if let Some(region) = &load.region {
                self.shape(&at("region"), region)?;
                self.has_inside(&at("region"), region)?;
            }
            if !load.total.is_finite() {
                return Err(self
                    .spec
                    .source
                    .error(&at("force"), "expected finite components"));
            }
            if !load.ramp.is_empty() {
                PiecewiseLinear::new(load.ramp.clone())
                    .map_err(|e| self.spec.source.error(&at("ramp"), format!("expected {e}")))?;
            }
        }
        Ok(())
    }

    fn inside_grid(&self, field: &str, shape: &Shape) -> Result<(), SceneError> {
        let (lo, hi) = shape.bounds();
        let (glo, ghi) = (self.spec.grid.min.to_3d(), self.spec.grid.max().to_3d());
        if (0..D::N).any(|a| lo[a] < glo[a] || hi[a] > ghi[a]) {
            let show = |v: [f64; 3]| {
                format!(
                    "({})",
                    v[..D::N]
                        .iter()
                        .map(|c| c.to_string())
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            };
            return Err(self.spec.source.error(
                field,
                format!(
                    "the body extends outside the grid: it spans {} to {}, the grid {} to {}",
                    show(lo.to_array()),
                    show(hi.to_array()),
                    show(glo),
                    show(ghi)
                ),
            ));
        }
        Ok(())
    }

    fn boundaries(&self) -> Result<(), SceneError> {
        for (r, region) in self.spec.boundaries.iter().enumerate() {
            let field = |f: &str| format!("boundaries[{r}].{f}");
            if !valid_region_name(&region.name) {
                return Err(self
                    .spec
                    .source
                    .error(&field("name"), "expected letters, digits, `_` or `-` only"));
            }
            if self.spec.boundaries[..r]
                .iter()
                .any(|x| x.name == region.name)
            {
                return Err(self.spec.source.error(
                    &field("name"),
                    format!("region \"{}\" is defined twice", region.name),
                ));
            }
            if !(region.min.is_finite() && region.max.is_finite()) {
                return Err(self
                    .spec
                    .source
                    .error(&field("nodes"), "expected finite coordinates"));
            }
            match &region.condition {
                Condition::Fixed => {}
                Condition::Roller { normal } => {
                    if *normal >= D::N {
                        return Err(self
                            .spec
                            .source
                            .error(&field("condition.normal"), axis_message::<D>()));
                    }
                }
                Condition::Velocity(components) => {
                    let axes = ["x", "y", "z"];
                    if components.iter().all(Option::is_none) {
                        return Err(self.spec.source.error(
                            &field("condition"),
                            format!("expected at least one of {}", D::AXES.join(", ")),
                        ));
                    }
                    for (a, points) in components.iter().enumerate() {
                        let Some(points) = points else { continue };
                        let at = field(&format!("condition.{}", axes[a]));
                        if a >= D::N {
                            return Err(self.spec.source.error(&at, axis_message::<D>()));
                        }
                        PiecewiseLinear::new(points.clone())
                            .map_err(|e| self.spec.source.error(&at, format!("expected {e}")))?;
                    }
                }
            }
        }
        Ok(())
    }

    fn probes(&self) -> Result<(), SceneError> {
        for (k, probe) in self.spec.output.probes.iter().enumerate() {
            match probe {
                Probe::Reaction(name) | Probe::Displacement(name) => {
                    self.spec.region_index(name, k)?;
                }
                Probe::Force(name) => {
                    self.spec.body_index(name, k)?;
                }
                Probe::CentreOfMassVelocity => {}
                Probe::Track {
                    name,
                    body,
                    at,
                    relative_to,
                } => {
                    if let Some(other) = relative_to {
                        self.spec.body_index(other, k)?;
                    }
                    let field = format!("output.probes[{k}]");
                    if name.is_empty()
                        || !name
                            .chars()
                            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
                    {
                        return Err(self.spec.source.error(
                            &format!("{field}.name"),
                            "expected letters, digits, `_` or `-` only",
                        ));
                    }
                    self.spec.body_index(body, k)?;
                    if at.0.len() != D::N || at.0.iter().any(|v| !v.is_finite()) {
                        return Err(self.spec.source.error(
                            &format!("{field}.at"),
                            format!("expected a point of {} finite coordinates", D::N),
                        ));
                    }
                }
            }
        }
        Ok(())
    }

    fn time(&self) -> Result<(), SceneError> {
        match self.spec.end {
            End::Time(t) if !(t.is_finite() && t > 0.0) => {
                return Err(self
                    .spec
                    .source
                    .error("time.end", "expected a positive end time"));
            }
            End::Steps(0) => {
                return Err(self
                    .spec
                    .source
                    .error("time.end", "expected at least one step"));
            }
            _ => {}
        }
        self.quasi_static()?;
        match self.spec.time_step {
            TimeStep::Fixed(dt) if !(dt.is_finite() && dt > 0.0) => Err(self
                .spec
                .source
                .error("time.step", "expected a positive time step")),
            TimeStep::Fixed(dt) if !dt.is_normal() => Err(self.spec.source.error(
                "time.step",
                format!(
                    "the time step {dt:e} s is below the smallest normal number {:e}",
                    f64::MIN_POSITIVE
                ),
            )),
            TimeStep::Cfl(f) if !(f > 0.0 && f <= 1.0) => Err(self
                .spec
                .source
                .error("time.step", "expected a CFL factor in (0, 1]")),
            _ => Ok(()),
        }
    }
}

impl<D: Dim> Checks<'_, D> {
    /// Mass scaling of at least 1 (a factor below 1 would shorten the step and buy nothing), and
    /// a kinetic limit that is a fraction.
    fn quasi_static(&self) -> Result<(), SceneError> {
        let Some(q) = self.spec.quasi_static else {
            return Ok(());
        };
        if !(q.mass_scaling.is_finite() && q.mass_scaling >= 1.0) {
            return Err(self.spec.source.error(
                "time.quasi_static.mass_scaling",
                format!(
                    "expected a finite factor of at least 1 on every density, got {}",
                    q.mass_scaling
                ),
            ));
        }
        if !(q.kinetic_limit > 0.0 && q.kinetic_limit <= 1.0) {
            return Err(self.spec.source.error(
                "time.quasi_static.kinetic_limit",
                format!(
                    "expected a fraction of the stored energy in (0, 1], got {} (0.05 is usual)",
                    q.kinetic_limit
                ),
            ));
        }
        Ok(())
    }
}

fn axis_message<D: Dim>() -> String {
    format!(
        "the scene is {}: its axes are {}",
        D::NAME,
        D::AXES.join(", ").to_uppercase()
    )
}

fn valid_region_name(name: &str) -> bool {
    !name.is_empty()
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
}

/// `"a", "b"`, or `none`.
pub(crate) fn quoted<'a>(names: impl Iterator<Item = &'a str>) -> String {
    let names: Vec<String> = names.map(|n| format!("\"{n}\"")).collect();
    if names.is_empty() {
        "none".into()
    } else {
        names.join(", ")
    }
}
