//! Validating a parsed scene and building the world and step schedule from it.
//!
//! Every check runs before anything is stepped, and every failure is a [`SceneError`] that
//! points at the offending text.

use super::format::*;
use super::seed::{cell_points, particles_in_shape, point_in_shape, shape_bounds};
use super::{SceneError, SceneFile};
use crate::boundary::{BoundaryConditions, BoundaryRegion, PiecewiseLinear, Reactions};
use crate::components::{
    BodyId, ContactGroup, Damage, NodeBundle, ParticleBundle, Velocity, WaveSpeed,
};
use crate::connectivity::Connectivity;
use crate::dim::Vector;
use crate::health::remove_escaped_particles;
use crate::output::{OutputPlan, ProbeKind};
use crate::registry::{Installer, Params, Registry};
use crate::resources::{BodyForce, Grid, Material, Materials, SimClock, TimeStepLimit};
use crate::simulation::{Simulation, add_stage_checks, step_schedule};
use crate::stage::Stage;
use crate::stage::StageCheck;
use bevy_ecs::prelude::World;
use bevy_ecs::schedule::IntoScheduleConfigs;

/// The pipeline as installed: system names per stage, in stage order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PipelineSummary {
    /// `(stage, systems)` for every stage with at least one system.
    pub by_stage: Vec<(Stage, Vec<String>)>,
}

/// Everything built from a scene.
pub struct Built {
    /// The simulation, ready to step.
    pub simulation: Simulation,
    /// The installed pipeline.
    pub pipeline: PipelineSummary,
    /// What to write during the run.
    pub output: OutputPlan,
    /// Particles per body, in scene order.
    pub body_particles: Vec<usize>,
}

/// Validates `file` and builds its simulation with systems from `registry`.
pub fn build_simulation(file: &SceneFile, registry: &Registry) -> Result<Built, SceneError> {
    let scene = &file.scene;
    let grid = grid_of(file)?;
    let materials = materials_of(file)?;
    let mut world = World::new();
    world.insert_resource(grid);
    spawn_nodes(&mut world, &grid);
    let body_particles = spawn_bodies(file, &grid, &materials, &mut world)?;
    let boundaries = boundaries_of(file, &grid)?;
    let output = output_plan(file, &boundaries)?;
    let body_force = Vector::new(scene.body_force.0, scene.body_force.1);
    if !body_force.is_finite() {
        return Err(file.error("body_force", "expected finite numbers"));
    }
    world.insert_resource(Materials(materials));
    world.insert_resource(BodyForce(body_force));
    world.insert_resource(Reactions(vec![Vector::ZERO; boundaries.regions.len()]));
    world.insert_resource(boundaries);
    world.insert_resource(SimClock::default());
    let policy = file.scene.safety.on_leave_grid;
    world.insert_resource(policy);
    world.init_resource::<Connectivity>();
    let mut schedule = step_schedule();
    let pipeline = install_pipeline(file, registry, &mut schedule, &mut world)?;
    let mut output = output;
    output.system_columns = world
        .get_resource::<crate::series::SeriesColumns>()
        .map(|c| c.names.clone())
        .unwrap_or_default();
    let limit = world.get_resource_or_init::<TimeStepLimit>().clone();
    check_time(file, &grid, &world.resource::<Materials>().0, &limit)?;
    add_stage_checks(
        &mut schedule,
        pipeline.by_stage.iter().map(|(stage, _)| *stage),
    );
    if policy == LeaveGrid::Remove {
        schedule.add_systems(remove_escaped_particles.in_set(StageCheck(Stage::Advection)));
    }
    let simulation =
        Simulation::new(world, schedule, scene.time.step, scene.time.end).map_err(|e| {
            file.error(
                "pipeline",
                format!(
                    "systems in one stage touch the same data without an order between them; \
                 order them or split them into stages:\n{e}"
                ),
            )
        })?;
    Ok(Built {
        simulation,
        pipeline,
        output,
        body_particles,
    })
}

fn finite_pair(p: Pair) -> bool {
    p.0.is_finite() && p.1.is_finite()
}

fn grid_of(file: &SceneFile) -> Result<Grid, SceneError> {
    let g = &file.scene.grid;
    if !(g.spacing.is_finite() && g.spacing > 0.0) {
        return Err(file.error("grid.spacing", "expected a positive spacing"));
    }
    if !finite_pair(g.min) {
        return Err(file.error("grid.min", "expected finite coordinates"));
    }
    if !(finite_pair(g.max) && g.max.0 > g.min.0 && g.max.1 > g.min.1) {
        return Err(file.error(
            "grid.max",
            "expected a corner above and to the right of `min`",
        ));
    }
    let span = [g.max.0 - g.min.0, g.max.1 - g.min.1];
    let mut cells = [0usize; 2];
    for (axis, length) in span.iter().enumerate() {
        let count = length / g.spacing;
        if (count - count.round()).abs() > 1e-6 * count.max(1.0) {
            return Err(file.error(
                "grid.max",
                format!(
                    "the box must hold a whole number of cells: {length} / {} = {count} along {}",
                    g.spacing,
                    ["x", "y"][axis]
                ),
            ));
        }
        cells[axis] = count.round() as usize;
    }
    if cells[0] * cells[1] > 100_000_000 {
        return Err(file.error("grid.spacing", "the grid would have more than 10^8 cells"));
    }
    Ok(Grid {
        min: Vector::new(g.min.0, g.min.1),
        spacing: g.spacing,
        cells,
    })
}

fn materials_of(file: &SceneFile) -> Result<Vec<Material>, SceneError> {
    let mut out = Vec::new();
    for (name, m) in &file.scene.materials {
        let field = |f: &str| format!("materials.{name}.{f}");
        if !(m.density.is_finite() && m.density > 0.0) {
            return Err(file.error(&field("density"), "expected a positive density (kg/m³)"));
        }
        if !(m.youngs_modulus.is_finite() && m.youngs_modulus > 0.0) {
            return Err(file.error(&field("youngs_modulus"), "expected a positive modulus (Pa)"));
        }
        if !(m.poisson_ratio > -1.0 && m.poisson_ratio < 0.5) {
            return Err(file.error(&field("poisson_ratio"), "expected a value in (-1, 0.5)"));
        }
        out.push(Material {
            name: name.clone(),
            density: m.density,
            youngs_modulus: m.youngs_modulus,
            poisson_ratio: m.poisson_ratio,
        });
    }
    if out.len() > u16::MAX as usize {
        return Err(file.error("materials", "too many materials"));
    }
    Ok(out)
}

fn spawn_nodes(world: &mut World, grid: &Grid) {
    let nodes: Vec<NodeBundle> = (0..grid.node_count())
        .map(|i| NodeBundle::new(i as u32, grid.node_position(i)))
        .collect();
    world.spawn_batch(nodes);
}

fn check_shape(
    file: &SceneFile,
    field: &str,
    shape: &Shape,
    grid: &Grid,
) -> Result<(), SceneError> {
    let valid = match shape {
        Shape::Rectangle { min, max } => {
            finite_pair(*min) && finite_pair(*max) && max.0 > min.0 && max.1 > min.1
        }
        Shape::Disk { center, radius } => {
            finite_pair(*center) && radius.is_finite() && *radius > 0.0
        }
        Shape::Polygon { vertices } => {
            vertices.len() >= 3 && vertices.iter().all(|v| finite_pair(*v))
        }
    };
    if !valid {
        let expected = match shape {
            Shape::Rectangle { .. } => "a rectangle with `max` above and to the right of `min`",
            Shape::Disk { .. } => "a disk with a positive radius",
            Shape::Polygon { .. } => "a polygon with at least 3 finite vertices",
        };
        return Err(file.error(field, format!("expected {expected}")));
    }
    let (lo, hi) = shape_bounds(shape);
    let (glo, ghi) = (grid.min, grid.max());
    if lo.x < glo.x || lo.y < glo.y || hi.x > ghi.x || hi.y > ghi.y {
        return Err(file.error(
            field,
            format!(
                "the body extends outside the grid: it spans ({}, {}) to ({}, {}), the grid \
                 ({}, {}) to ({}, {})",
                lo.x, lo.y, hi.x, hi.y, glo.x, glo.y, ghi.x, ghi.y
            ),
        ));
    }
    Ok(())
}

fn spawn_bodies(
    file: &SceneFile,
    grid: &Grid,
    materials: &[Material],
    world: &mut World,
) -> Result<Vec<usize>, SceneError> {
    let mut counts = Vec::new();
    let mut next_id: u32 = 0;
    if file.scene.bodies.is_empty() {
        return Err(file.error("bodies", "expected at least one body"));
    }
    for (b, body) in file.scene.bodies.iter().enumerate() {
        let field = |f: &str| format!("bodies[{b}].{f}");
        let Some(material) = materials.iter().position(|m| m.name == body.material) else {
            let known: Vec<_> = materials
                .iter()
                .map(|m| format!("\"{}\"", m.name))
                .collect();
            return Err(file.error(
                &field("material"),
                format!(
                    "unknown material \"{}\"; the scene defines: {}",
                    body.material,
                    if known.is_empty() {
                        "none".into()
                    } else {
                        known.join(", ")
                    }
                ),
            ));
        };
        if body.particles_per_cell == 0 || body.particles_per_cell > 16 {
            return Err(file.error(&field("particles_per_cell"), "expected 1 to 16"));
        }
        if cell_points(body.placement, body.particles_per_cell).is_none() {
            return Err(file.error(
                &field("particles_per_cell"),
                "Gauss placement supports 1, 2 or 3 particles per cell per direction",
            ));
        }
        check_shape(file, &field("shape"), &body.shape, grid)?;
        if !body.velocity.is_valid() {
            return Err(file.error(
                &field("velocity"),
                "expected finite numbers (and a positive wavelength)",
            ));
        }
        let seeded = particles_in_shape(&body.shape, grid, body.particles_per_cell, body.placement);
        if seeded.is_empty() {
            return Err(file.error(
                &field("shape"),
                "no particle falls inside this shape; make it larger than a cell or use more \
                 particles per cell",
            ));
        }
        let density = materials[material].density;
        let wave_speed = materials[material].wave_speed();
        let bundles: Vec<ParticleBundle> = seeded
            .iter()
            .map(|&(x, volume)| {
                let mut p =
                    ParticleBundle::new(next_id, x, density * volume, volume, material as u16);
                next_id += 1;
                let v = body.velocity.at(x.x, x.y);
                p.velocity = Velocity(Vector::new(v.0, v.1));
                p.body = BodyId(b as u16);
                p.wave_speed = WaveSpeed(wave_speed);
                if body.cracks.iter().any(|crack| point_in_shape(crack, x)) {
                    p.damage = Damage(1.0);
                }
                p.group = ContactGroup(body.contact_group);
                p
            })
            .collect();
        counts.push(bundles.len());
        world.spawn_batch(bundles);
    }
    Ok(counts)
}

fn check_time(
    file: &SceneFile,
    grid: &Grid,
    materials: &[Material],
    limit: &TimeStepLimit,
) -> Result<(), SceneError> {
    let time = &file.scene.time;
    match time.end {
        End::Time(t) if !(t.is_finite() && t > 0.0) => {
            return Err(file.error("time.end", "expected a positive end time"));
        }
        End::Steps(0) => return Err(file.error("time.end", "expected at least one step")),
        _ => {}
    }
    // Fastest signal: wave speed of each body's material plus its initial speed.
    let (fastest, culprit) = file
        .scene
        .bodies
        .iter()
        .filter_map(|b| {
            let m = materials.iter().find(|m| m.name == b.material)?;
            // The linear field is bounded by its gradient times the grid's diagonal.
            let extent = (grid.max() - grid.min).length();
            Some((
                m.wave_speed() + b.velocity.max_speed(extent),
                m.name.clone(),
            ))
        })
        .fold(
            (0.0, String::new()),
            |acc, x| if x.0 > acc.0 { x } else { acc },
        );
    let stable = limit.stable_step(grid.spacing, fastest);
    let restriction = if limit.reason.is_empty() {
        String::new()
    } else {
        format!(" × {} ({})", limit.factor, limit.reason)
    };
    match time.step {
        TimeStep::Fixed(dt) if !(dt.is_finite() && dt > 0.0) => {
            Err(file.error("time.step", "expected a positive time step"))
        }
        TimeStep::Fixed(dt) if dt > stable => Err(file.error(
            "time.step",
            format!(
                "the time step {dt:e} s exceeds the stable limit {stable:e} s = h / (√2 (c + |v|)){restriction} \
                 with h = {} m and c + |v| = {fastest:.6e} m/s (material \"{culprit}\"); use \
                 `Fixed({:.3e})` or less, or `Cfl(0.5)`",
                grid.spacing,
                0.9 * stable
            ),
        )),
        TimeStep::Cfl(f) if !(f > 0.0 && f <= 1.0) => {
            Err(file.error("time.step", "expected a CFL factor in (0, 1]"))
        }
        _ => Ok(()),
    }
}

fn valid_region_name(name: &str) -> bool {
    !name.is_empty()
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
}

fn boundaries_of(file: &SceneFile, grid: &Grid) -> Result<BoundaryConditions, SceneError> {
    let mut regions: Vec<BoundaryRegion> = Vec::new();
    for (r, spec) in file.scene.boundaries.iter().enumerate() {
        let field = |f: &str| format!("boundaries[{r}].{f}");
        if !valid_region_name(&spec.name) {
            return Err(file.error(&field("name"), "expected letters, digits, `_` or `-` only"));
        }
        if regions.iter().any(|x| x.name == spec.name) {
            return Err(file.error(
                &field("name"),
                format!("region \"{}\" is defined twice", spec.name),
            ));
        }
        let Region::Box { min, max } = spec.nodes;
        let tol = 1e-9 * grid.spacing;
        let nodes: Vec<u32> = (0..grid.node_count())
            .filter(|&i| {
                let x = grid.node_position(i);
                x.x >= min.0 - tol && x.x <= max.0 + tol && x.y >= min.1 - tol && x.y <= max.1 + tol
            })
            .map(|i| i as u32)
            .collect();
        if nodes.is_empty() {
            return Err(file.error(&field("nodes"), "no grid node lies in this box"));
        }
        let function = |points: &Option<Vec<Pair>>, axis: &str| match points {
            None => Ok(None),
            Some(p) => PiecewiseLinear::new(p.clone()).map(Some).map_err(|e| {
                file.error(
                    &field(&format!("condition.{axis}")),
                    format!("expected {e}"),
                )
            }),
        };
        let velocity = match &spec.condition {
            Condition::Fixed => [
                Some(PiecewiseLinear::constant(0.0)),
                Some(PiecewiseLinear::constant(0.0)),
            ],
            Condition::Roller { normal: Axis::X } => [Some(PiecewiseLinear::constant(0.0)), None],
            Condition::Roller { normal: Axis::Y } => [None, Some(PiecewiseLinear::constant(0.0))],
            Condition::Velocity { x, y } => {
                if x.is_none() && y.is_none() {
                    return Err(file.error(&field("condition"), "expected `x`, `y` or both"));
                }
                [function(x, "x")?, function(y, "y")?]
            }
        };
        regions.push(BoundaryRegion {
            name: spec.name.clone(),
            nodes,
            velocity,
        });
    }
    Ok(BoundaryConditions { regions })
}

/// Index of the boundary region a probe names.
fn region_index(
    file: &SceneFile,
    boundaries: &BoundaryConditions,
    name: &str,
    probe: usize,
) -> Result<usize, SceneError> {
    boundaries
        .regions
        .iter()
        .position(|r| r.name == name)
        .ok_or_else(|| {
            let known: Vec<_> = boundaries
                .regions
                .iter()
                .map(|r| format!("\"{}\"", r.name))
                .collect();
            file.error(
                &format!("output.probes[{probe}]"),
                format!(
                    "no boundary region named \"{name}\"; the scene defines: {}",
                    if known.is_empty() {
                        "none".into()
                    } else {
                        known.join(", ")
                    }
                ),
            )
        })
}

fn output_plan(
    file: &SceneFile,
    boundaries: &BoundaryConditions,
) -> Result<OutputPlan, SceneError> {
    let spec = &file.scene.output;
    let mut probes = Vec::new();
    for (k, probe) in spec.probes.iter().enumerate() {
        match probe {
            Probe::Reaction(name) => {
                let index = region_index(file, boundaries, name, k)?;
                probes.push(ProbeKind::Reaction {
                    name: name.clone(),
                    index,
                });
            }
            Probe::CentreOfMassVelocity => probes.push(ProbeKind::CentreOfMassVelocity),
            Probe::Force(name) => {
                let bodies = &file.scene.bodies;
                let Some(index) = bodies.iter().position(|b| b.name.as_deref() == Some(name))
                else {
                    let known: Vec<_> = bodies
                        .iter()
                        .filter_map(|b| b.name.as_ref())
                        .map(|n| format!("\"{n}\""))
                        .collect();
                    return Err(file.error(
                        &format!("output.probes[{k}]"),
                        format!(
                            "no body named \"{name}\"; the named bodies are: {}",
                            if known.is_empty() {
                                "none".into()
                            } else {
                                known.join(", ")
                            }
                        ),
                    ));
                };
                probes.push(ProbeKind::Force {
                    name: name.clone(),
                    index: index as u16,
                });
            }
            Probe::Displacement(name) => {
                let index = region_index(file, boundaries, name, k)?;
                probes.push(ProbeKind::Displacement {
                    name: name.clone(),
                    index,
                });
            }
        }
    }
    Ok(OutputPlan {
        vtu_every: spec.vtu_every,
        csv_every: spec.csv_every,
        probes,
        last_good_frame: spec.last_good_frame,
        system_columns: Vec::new(),
    })
}

fn install_pipeline(
    file: &SceneFile,
    registry: &Registry,
    schedule: &mut bevy_ecs::schedule::Schedule,
    world: &mut World,
) -> Result<PipelineSummary, SceneError> {
    let entries = &file.scene.pipeline;
    let mut chosen = Vec::new();
    for (k, entry) in entries.iter().enumerate() {
        let field = format!("pipeline[{k}].system");
        let Some(registration) = registry.get(&entry.system) else {
            return Err(file.error(
                &field,
                format!(
                    "unknown system \"{}\"; known systems: {}",
                    entry.system,
                    registry.names().join(", ")
                ),
            ));
        };
        if chosen
            .iter()
            .any(|(_, r): &(usize, &crate::registry::Registration)| r.name == registration.name)
        {
            return Err(file.error(
                &field,
                format!("system \"{}\" is listed twice", entry.system),
            ));
        }
        chosen.push((k, registration));
    }
    for stage in Stage::REQUIRED {
        if !chosen.iter().any(|(_, r)| r.stage() == Some(stage)) {
            let options: Vec<_> = registry
                .iter()
                .filter(|r| r.stage() == Some(stage))
                .map(|r| r.name)
                .collect();
            return Err(file.error(
                "pipeline",
                format!(
                    "the pipeline has no system for the required stage `{stage}`; add one of: {}",
                    options.join(", ")
                ),
            ));
        }
    }
    for (k, registration) in &chosen {
        for needed in registration.requires {
            // `stage/*` asks for any system of that stage.
            let satisfied = match needed.strip_suffix("/*") {
                Some(stage) => chosen
                    .iter()
                    .any(|(_, r)| r.stage().is_some_and(|s| s.name() == stage)),
                None => chosen.iter().any(|(_, r)| r.name == *needed),
            };
            if !satisfied {
                return Err(file.error(
                    &format!("pipeline[{k}].system"),
                    format!(
                        "system \"{}\" needs {} in the pipeline",
                        registration.name,
                        match needed.strip_suffix("/*") {
                            Some(stage) => format!("a `{stage}` system"),
                            None => format!("\"{needed}\""),
                        }
                    ),
                ));
            }
        }
    }
    let mut summary = PipelineSummary::default();
    for stage in Stage::ORDER {
        let names: Vec<String> = chosen
            .iter()
            .filter(|(_, r)| r.stage() == Some(stage))
            .map(|(_, r)| r.name.to_string())
            .collect();
        if !names.is_empty() {
            summary.by_stage.push((stage, names));
        }
    }
    for (k, registration) in chosen {
        let field = format!("pipeline[{k}].params");
        let raw = entries[k].params.as_deref().map(|r| r.trim().get_ron());
        let origin = file.location_of(&field);
        let params = Params::new(raw, &file.name, origin, field);
        let stage = registration.stage().unwrap_or(Stage::PostStep);
        let mut installer = Installer::new(stage, schedule, world);
        (registration.install)(&mut installer, &params)?;
    }
    Ok(summary)
}
