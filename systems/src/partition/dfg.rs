//! Damage-field-gradient (DFG) partitioning, with optional surface detection for self-contact.
//!
//! - Stage: partition. Registration name: `partition/dfg`. Needs a contact system.
//! - Implements dfg-partitioning-mpm.md §2.1–2.4:
//!   - the kernel damage field `D(x) = Σ_q D_q ω(‖x − x_q‖/r)` (eq. 17) with the cubic kernel
//!     `ω(r̄) = 1 − 3r̄² + 2r̄³` on `[0, 1]` (eq. 18), normalised by the kernel sum
//!     `S(x) = Σ_q ω` (eq. 19), and its gradient at every particle,
//!     `∇D̄ = (S ∇D − D ∇S) / S²`, stored in `DamageGradient`. The radius `r` defaults to the
//!     cell diagonal; `radius` gives it in metres, `radius_cells` in grid spacings (so that it
//!     follows the grid when a scene is refined); the sums run over the particles of the same
//!     contact group;
//!   - surface detection (§2.4, option `surface`): at the first step, particles whose kernel sum
//!     is below `surface × max S` get `SurfaceFlag = 1`, and `max(s_p, D_p)` replaces `D_p` in
//!     the field and in the separability statistics. The kernel sum of the detection runs over
//!     the particle's own body, so two bodies of one group that touch at the start (grains in
//!     contact but not bonded, a billet under a platen) have their touching faces flagged: the
//!     "paint in" §2.4 asks for at such faces, done by the scene's bodies. A solid meant to be
//!     one piece is one body. In a distributed run the ranks agree on `max S` before the first
//!     step (`SceneLargestKernelSum`), each rank's the largest over the particles it owns;
//!   - the separability statistics of eq. 21 for each field of each node (mass-weighted mean
//!     and maximum damage), stored in `NodeFieldDamage` for the contact stage.
//! - Algorithms 1 and 2 (the node's reference gradient and each pair's side) are the partition
//!   stage's field assignment (`partition::field_assignment`), which this registration installs
//!   in the step's `assign_fields` window: it runs right after the basis stage on the new
//!   connectivity, with the gradients computed here. So
//!   the fields of a step come from the damage of the previous step, as in the paper's
//!   update-stress-last order, but from the particle positions at the start of the previous
//!   step rather than its end (a lag of one step's motion, well inside a kernel radius).
//! - Each group's particles form their own kernel field: two groups never partition each
//!   other, they are already separate fields.
//! - Neighbours: candidate lists within `1.25 r` of where each particle was at the last build
//!   (`DfgNeighbours`, this system's own list, apart from the ε-neighbourhood of the damage
//!   stage), rebuilt with a kd-tree only when some particle has moved more than `0.125 r`. The
//!   kernel is zero beyond `r`, so the extra candidates add exact zeros and the results are
//!   the same, bit for bit, as with a fresh search every step.

use super::field_assignment::install_field_assignment;
use crate::spatial::Spatial;
use fractum_engine::decomposition::RankMaximum;
use fractum_engine::prelude::*;
use rayon::prelude::*;
use serde::Deserialize;

/// Registration of `partition/dfg`.
pub const REGISTRATION: Registration = Registration {
    name: "partition/dfg",
    summary: "damage-field-gradient partitioning of every group into two fields per node, with \
              optional surface detection for self-contact (§2.1-2.4, Algorithms 1-2)",
    params: &[
        ParamDoc {
            name: "radius",
            ty: "f64",
            default: Some("cell diagonal"),
            doc: "kernel radius r_p of eq. 18 (m)",
        },
        ParamDoc {
            name: "radius_cells",
            ty: "f64",
            default: Some("none: `radius` sets the kernel"),
            doc: "the kernel radius in cells (grid spacings) instead of metres, so that it \
                  follows the grid when a scene is refined; not with `radius`",
        },
        ParamDoc {
            name: "surface",
            ty: "f64",
            default: Some("none: no surface detection"),
            doc: "surface detection threshold in (0, 1): particles whose kernel sum is below \
                  this fraction of the largest are surface particles (§2.4); off when absent",
        },
    ],
    requires: &["contact/*"],
    install: generic_install!(install),
};

/// Parameters of `partition/dfg`.
#[derive(Resource, Deserialize, Clone, Copy, Debug, Default, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct DfgParams {
    /// Kernel radius; the cell diagonal when `None`.
    #[serde(default)]
    pub radius: Option<f64>,
    /// Kernel radius in grid spacings; the install turns it into `radius`.
    #[serde(default)]
    pub radius_cells: Option<f64>,
    /// Surface detection threshold, off when `None`.
    #[serde(default)]
    pub surface: Option<f64>,
}

/// Kernel-neighbour candidates of `partition/dfg`, with a skin (see the module header).
#[derive(Resource, Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct DfgNeighbours<D: Dim> {
    /// Positions at the last build.
    pub anchors: Vec<D::Vector>,
    /// Candidates of the same contact group per particle, sorted.
    pub rows: Neighbourhoods,
    /// Builds so far.
    pub rebuilds: u64,
}

impl<D: Dim> Default for DfgNeighbours<D> {
    fn default() -> Self {
        Self {
            anchors: Vec::new(),
            rows: Neighbourhoods::default(),
            rebuilds: 0,
        }
    }
}

/// The skin of the candidate lists, as a fraction of the kernel radius.
pub const SKIN: f64 = 0.25;

impl<D: Spatial> DfgNeighbours<D> {
    /// Rebuilds the lists when they are missing or some particle has moved more than half the
    /// skin since the last build.
    pub fn refresh(&mut self, positions: &[Position<D>], groups: &[ContactGroup], radius: f64) {
        let skin = SKIN * radius;
        let moved = |(anchor, x): (&D::Vector, &Position<D>)| (x.0 - *anchor).length() > 0.5 * skin;
        let stale = self.anchors.len() != positions.len()
            || self.anchors.par_iter().zip(positions.par_iter()).any(moved);
        if !stale {
            return;
        }
        let Self { rows, anchors, .. } = self;
        let mut all = Neighbourhoods::default();
        crate::spatial::build_candidates(positions, radius + skin, &mut all);
        rows.fill_rows(positions.len(), all.radius, |p, out| {
            out.extend(
                all.of(p)
                    .iter()
                    .filter(|&&q| groups[q as usize] == groups[p]),
            );
        });
        anchors.clear();
        anchors.extend(positions.iter().map(|p| p.0));
        self.rebuilds += 1;
    }
}

/// Whether surface detection has run.
#[derive(
    Resource, Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize,
)]
pub struct SurfaceDetected(pub bool);

/// The largest kernel sum of the whole scene, which surface detection compares each particle's
/// with (§2.4): given by the ranks of a distributed run before the first step, each rank seeing
/// only its part of the scene ([`fractum_engine::decomposition::RankMaximum`]); absent in one
/// process, whose system finds it over its own particles.
#[derive(Resource, Clone, Copy, Debug, PartialEq)]
pub struct SceneLargestKernelSum(pub f64);

fn install<D: Spatial>(installer: &mut Installer, params: &Params) -> Result<(), SceneError> {
    let parsed: DfgParams = params.parse()?;
    if let Some(r) = parsed.radius
        && !(r.is_finite() && r > 0.0)
    {
        return Err(params.error("radius", "expected a positive radius in m"));
    }
    let (spacing, dimensions) = (installer.world().resource::<Grid<D>>().spacing, D::N);
    let parsed = resolve_radius_cells(params, parsed, spacing)?;
    if let Some(s) = parsed.surface
        && !(s > 0.0 && s < 1.0)
    {
        return Err(params.error("surface", "expected a threshold in (0, 1)"));
    }
    if parsed.surface.is_none() && !installer.pipeline_has("damage/") && !any_damage(installer) {
        return Err(params.error(
            "surface",
            "partition/dfg has nothing to partition by: the pipeline has no damage system, no \
             body has `cracks`, and surface detection is off; add a damage system, or \
             `surface: 0.8` for self-contact, or use partition/bodies",
        ));
    }
    let radius_cells = parsed
        .radius
        .map_or((dimensions as f64).sqrt(), |r| r / spacing);
    // Its lists are not measured against this bound: half a cell more margin keeps the
    // bound it had (a ball one cell wider than the reach).
    crate::neighbour::declare_lists(
        installer,
        "partition/dfg",
        &[radius_cells * (1.0 + SKIN) + 0.5],
    );
    installer.declare_particle_reach("the damage-gradient kernel", radius_cells * spacing);
    installer.insert_resource(parsed);
    install_field_assignment::<D>(installer)?;
    installer.add_node_component(NodeFieldDamage::default());
    if parsed.surface.is_some() {
        // Whether detection has run: set by every rank at the same step. Its threshold is a
        // fraction of the largest kernel sum of the whole scene, which the ranks of a
        // distributed run agree on before the first step; a ghost's sum reads neighbours a
        // kernel radius further.
        installer.init_rank_state::<SurfaceDetected>();
        installer.declare_particle_reach("surface detection's kernel sums", radius_cells * spacing);
        installer.add_rank_maximum(RankMaximum {
            name: "partition/dfg: the largest kernel sum",
            wanted: |world| {
                world
                    .get_resource::<SurfaceDetected>()
                    .is_some_and(|d| !d.0)
            },
            local: owned_largest_kernel_sum::<D>,
            apply: |world, largest| world.insert_resource(SceneLargestKernelSum(largest)),
        });
    }
    super::field_assignment::install_split_record::<D>(installer)?;
    installer.add_particle_component(SurfaceFlag::default());
    installer.add_frame_scalar::<SurfaceFlag>("surface", |s| s.0);
    installer.init_row_state::<DfgNeighbours<D>>();
    installer.add_particle_component(DamageGradient::<D>::default());
    installer.add_frame_vector::<DamageGradient<D>>("damage_gradient", |g| g.0.to_3d());
    installer.add_systems(dfg_partition::<D>);
    Ok(())
}

/// `radius_cells` turned into `radius` for a grid of `spacing` (checked positive, and not given
/// with `radius`).
fn resolve_radius_cells(
    params: &Params,
    parsed: DfgParams,
    spacing: f64,
) -> Result<DfgParams, SceneError> {
    match (parsed.radius, parsed.radius_cells) {
        (Some(_), Some(_)) => Err(params.error(
            "radius_cells",
            "give the kernel radius once: `radius` (m) or `radius_cells` (grid spacings)",
        )),
        (None, Some(cells)) if !(cells.is_finite() && cells > 0.0) => Err(params.error(
            "radius_cells",
            "expected a positive number of grid spacings",
        )),
        (None, Some(cells)) => Ok(DfgParams {
            radius: Some(cells * spacing),
            radius_cells: None,
            ..parsed
        }),
        _ => Ok(parsed),
    }
}

/// Whether some particle starts damaged (a body's `cracks`).
fn any_damage(installer: &Installer) -> bool {
    let world = installer.world();
    world
        .try_query::<&Damage>()
        .is_some_and(|mut query| query.iter(world).any(|d| d.0 > 0.0))
}

/// The cubic kernel `ω(r̄) = 1 − 3r̄² + 2r̄³` for `r̄ ≤ 1`, else 0 (eq. 18).
pub fn kernel(r: f64) -> f64 {
    if r < 1.0 {
        1.0 - r * r * (3.0 - 2.0 * r)
    } else {
        0.0
    }
}

/// `dω/dr̄ = −6r̄ + 6r̄²` for `r̄ < 1`, else 0.
pub fn kernel_slope(r: f64) -> f64 {
    if r < 1.0 { 6.0 * r * (r - 1.0) } else { 0.0 }
}

/// Kernel sums at `x` over neighbours `(x_q, d_q)`: `(S, Σ d ω, ∇S, Σ d ∇ω)`.
pub fn kernel_sums<V: VectorOps>(
    x: V,
    neighbours: impl Iterator<Item = (V, f64)>,
    radius: f64,
) -> (f64, f64, V, V) {
    neighbours.fold(
        (0.0, 0.0, V::ZERO, V::ZERO),
        |(s, d, grad_s, grad_d), (xq, dq)| {
            let offset = x - xq;
            let distance = offset.length();
            let r = distance / radius;
            let w = kernel(r);
            let grad_w = if distance > 0.0 {
                offset * (kernel_slope(r) / (distance * radius))
            } else {
                V::ZERO
            };
            (s + w, d + dq * w, grad_s + grad_w, grad_d + grad_w * dq)
        },
    )
}

/// Gradient of the normalised damage field `D̄ = D/S` from the kernel sums (eqs. 17–19).
pub fn normalised_gradient<V: VectorOps>(sums: (f64, f64, V, V)) -> V {
    let (s, d, grad_s, grad_d) = sums;
    if s > 0.0 {
        (grad_d * s - grad_s * d) / (s * s)
    } else {
        V::ZERO
    }
}

/// Mass-weighted mean and maximum damage of each field of one node (eq. 21) from its entries
/// `(slot, N m, damage)`.
pub fn field_damage(entries: impl Iterator<Item = (usize, f64, f64)>) -> NodeFieldDamage {
    let mut weighted = [0.0; MAX_FIELDS];
    let mut mass = [0.0; MAX_FIELDS];
    let mut stats = NodeFieldDamage::default();
    for (k, nm, d) in entries {
        weighted[k] += nm * d;
        mass[k] += nm;
        stats.max[k] = stats.max[k].max(d);
    }
    for k in 0..MAX_FIELDS {
        stats.mean[k] = if mass[k] > 0.0 {
            weighted[k] / mass[k]
        } else {
            0.0
        };
    }
    stats
}

type ParticleQuery<'w, 's, D> = Query<
    'w,
    's,
    (
        &'static Position<D>,
        &'static ContactGroup,
        &'static BodyId,
        &'static Damage,
        &'static Mass,
        &'static mut SurfaceFlag,
        &'static mut DamageGradient<D>,
    ),
    With<Particle>,
>;

/// What `partition/dfg` carries from step to step: whether surfaces were detected, and its
/// neighbour candidates; and the scene's largest kernel sum where the ranks of a distributed
/// run gave it.
#[derive(bevy_ecs::system::SystemParam)]
pub struct DfgCarried<'w, D: Dim> {
    /// Present when the entry detects surfaces.
    detected: Option<ResMut<'w, SurfaceDetected>>,
    candidates: ResMut<'w, DfgNeighbours<D>>,
    scene_largest: Option<Res<'w, SceneLargestKernelSum>>,
}

/// The `partition/dfg` system.
pub fn dfg_partition<D: Spatial>(
    grid: Res<Grid<D>>,
    params: Res<DfgParams>,
    mut carried: DfgCarried<D>,
    connectivity: Res<Connectivity<D>>,
    mut particles: ParticleQuery<D>,
    mut nodes: Query<(&NodeFields, &mut NodeFieldDamage), With<Node>>,
    mut buffers: Local<(Vec<f64>, Vec<bool>, Vec<usize>)>,
) {
    let Some((positions, groups, bodies, damage, mass, surface, gradients)) =
        single_table_mut(particles.contiguous_iter_mut(), "particles")
    else {
        return;
    };
    let radius = params.radius.unwrap_or(grid.spacing * (D::N as f64).sqrt());
    carried.candidates.refresh(positions, groups, radius);
    let neighbours = &carried.candidates.rows;
    if let (Some(threshold), Some(detected)) = (params.surface, carried.detected.as_mut())
        && !detected.0
    {
        let sums = body_kernel_sums(positions, neighbours, bodies, radius);
        let largest = (carried.scene_largest.as_ref()).map_or_else(|| largest_of(&sums), |l| l.0);
        detect_surface(&sums, largest, threshold, surface);
        detected.0 = true;
    }
    let (effective, near_damage, damaged) = &mut *buffers;
    effective.clear();
    effective.par_extend(damage.par_iter().zip(&*surface).map(|(d, s)| d.0.max(s.0)));
    // Without damage among its neighbours a particle has D = ∇D = 0, and so ∇D̄ = 0: most
    // particles of a body skip the kernel sums. The lists are symmetric (one radius, one
    // distance for both orders), so the particles with a damaged neighbour are found from the
    // damaged particles alone, in a pass over those instead of over every list.
    // The damaged rows are found in parallel; only the marking from their lists is serial.
    damaged.clear();
    damaged.par_extend(
        (0..effective.len())
            .into_par_iter()
            .filter(|&q| effective[q] != 0.0),
    );
    near_damage.clear();
    near_damage.resize(positions.len(), false);
    for &q in damaged.iter() {
        for &p in neighbours.of(q) {
            near_damage[p as usize] = true;
        }
    }
    gradients.par_iter_mut().enumerate().for_each(|(p, g)| {
        if !near_damage[p] {
            // Mostly zero already: a read instead of a write.
            if g.0 != D::Vector::ZERO {
                g.0 = D::Vector::ZERO;
            }
            return;
        }
        let row = neighbours
            .of(p)
            .iter()
            .map(|&q| (positions[q as usize].0, effective[q as usize]));
        g.0 = normalised_gradient(kernel_sums(positions[p].0, row, radius));
    });
    let Some((fields, stats)) = single_table_mut(nodes.contiguous_iter_mut(), "nodes") else {
        return;
    };
    node_field_damage(&connectivity, (fields, mass, effective), stats);
}

/// Each node's damage statistics per velocity field (Algorithm 2's inputs) from the
/// particles' mass-weighted effective damage; only a node with two fields or more has a pair
/// to separate.
fn node_field_damage<D: Dim>(
    c: &Connectivity<D>,
    (fields, mass, effective): (&[NodeFields], &[Mass], &[f64]),
    stats: &mut [NodeFieldDamage],
) {
    stats.par_iter_mut().enumerate().for_each(|(node, out)| {
        match c.node_offsets.get(node..node + 2) {
            Some(&[from, to]) if fields[node].count >= 2 => {
                *out = field_damage(c.node_entries[from..to].iter().map(|&(e, p)| {
                    let (e, p) = (e as usize, p as usize);
                    (c.field(e), c.weights[e] * mass[p].0, effective[p])
                }));
            }
            // Mostly default already: a read instead of a write.
            _ if *out != NodeFieldDamage::default() => *out = NodeFieldDamage::default(),
            _ => {}
        }
    });
}

/// Each particle's kernel sum over its own body's neighbours (§2.4).
fn body_kernel_sums<D: Dim>(
    positions: &[Position<D>],
    neighbours: &Neighbourhoods,
    bodies: &[BodyId],
    radius: f64,
) -> Vec<f64> {
    (0..positions.len())
        .into_par_iter()
        .map(|p| {
            let row = neighbours
                .of(p)
                .iter()
                .filter(|&&q| bodies[q as usize] == bodies[p])
                .map(|&q| (positions[q as usize].0, 0.0));
            kernel_sums(positions[p].0, row, radius).0
        })
        .collect()
}

fn largest_of(sums: &[f64]) -> f64 {
    sums.iter().copied().fold(0.0, f64::max)
}

/// Flags the particles whose kernel sum is below `threshold` times `largest` (§2.4).
fn detect_surface(sums: &[f64], largest: f64, threshold: f64, surface: &mut [SurfaceFlag]) {
    for (flag, s) in surface.iter_mut().zip(sums) {
        flag.0 = if *s < threshold * largest { 1.0 } else { 0.0 };
    }
}

/// The largest kernel sum over the particles this rank owns, from lists built for the purpose
/// (the system's own are left to build at its step, as in one process).
fn owned_largest_kernel_sum<D: Spatial>(world: &mut World) -> f64 {
    let grid = world.resource::<Grid<D>>().clone();
    let params = *world.resource::<DfgParams>();
    let radius = params.radius.unwrap_or(grid.spacing * (D::N as f64).sqrt());
    let mut query =
        world.query_filtered::<(&Position<D>, &ContactGroup, &BodyId), With<Particle>>();
    let (positions, groups, bodies): (Vec<Position<D>>, Vec<ContactGroup>, Vec<BodyId>) =
        query.iter(world).map(|(x, g, b)| (*x, *g, *b)).collect();
    let mut lists = DfgNeighbours::<D>::default();
    lists.refresh(&positions, &groups, radius);
    let sums = body_kernel_sums(&positions, &lists.rows, &bodies, radius);
    fractum_engine::decomposition::Owned::in_world(world)
        .particles(&sums)
        .fold(0.0, |widest, s| f64::max(widest, *s))
}

// The checkpoint key of this system's state (stable across builds).
fractum_engine::checkpoint_keys! { SurfaceDetected => "dfg/surface_detected" }

impl<D: Dim> fractum_engine::checkpoint::State for DfgNeighbours<D> {
    const KEY: &'static str = "dfg/neighbours";
}

// In a distributed run the rows hold other particles after each step: the lists are rebuilt.
impl<D: Dim> fractum_engine::checkpoint::RowState for DfgNeighbours<D> {
    type Row = ();

    fn row(&self, _row: usize) {}

    fn set_rows(&mut self, _rows: Vec<()>) {
        // No anchor for any row: the next step finds the lists stale and builds them afresh.
        self.anchors.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `fractum systems` documents the fields its parameters read, and its documented defaults are theirs.
    #[test]
    fn parameter_docs_match_the_parameters() {
        fractum_engine::testing::assert_defaults::<DfgParams>(&REGISTRATION);
    }
    use fractum_engine::testing::*;

    #[test]
    fn kernel_is_smooth_and_vanishes_at_the_radius() {
        assert_eq!(kernel(0.0), 1.0);
        assert_eq!(kernel(1.0), 0.0);
        assert_eq!(kernel(0.5), 0.5);
        let h = 1e-6;
        for r in [0.1, 0.4, 0.9] {
            let numeric = (kernel(r + h) - kernel(r - h)) / (2.0 * h);
            assert!((numeric - kernel_slope(r)).abs() < 1e-8);
        }
    }

    #[test]
    fn field_damage_is_mass_weighted_per_slot() {
        let stats = field_damage([(0, 1.0, 0.0), (0, 3.0, 1.0), (1, 2.0, 0.5)].into_iter());
        assert_eq!(stats.mean[..2], [0.75, 0.5]);
        assert_eq!(stats.max[..2], [1.0, 0.5]);
    }

    /// A strip of particles 16 × 4, failed on the right half, with the partition system's own
    /// particle components.
    fn strip(surface: Option<f64>) -> World {
        strip_failed(surface, 8..16)
    }

    /// A strip of particles 16 × 4 whose columns `failed` have failed.
    fn strip_failed(surface: Option<f64>, failed: std::ops::Range<usize>) -> World {
        let mut world = tiny_world::<Two>(8, 0.25, 1e-3);
        world.insert_resource(DfgParams {
            radius: Some(0.3),
            radius_cells: None,
            surface,
        });
        world.insert_resource(SurfaceDetected::default());
        world.init_resource::<DfgNeighbours<Two>>();
        give_nodes(&mut world, NodeFieldDamage::default());
        for i in 0..16 {
            for j in 0..4 {
                let x = DVec2::new(0.0625 + 0.125 * i as f64, 0.8125 + 0.125 * j as f64);
                let id = spawn_particle(&mut world, x, DVec2::ZERO, 1.0, 0.01);
                let mut entity = world.entity_mut(id);
                entity.insert((SurfaceFlag::default(), DamageGradient::<Two>::default()));
                if failed.contains(&i) {
                    entity.insert(Damage(1.0));
                }
            }
        }
        run_system(&mut world, crate::basis::linear::linear_basis::<Two>);
        run_system(&mut world, dfg_partition::<Two>);
        world
    }

    /// The candidate lists are rebuilt only once a particle has moved half the skin, and the
    /// gradients with old candidates equal those of a fresh search.
    #[test]
    fn candidates_are_rebuilt_only_after_half_the_skin() {
        let mut world = strip(None);
        let rebuilds = |world: &World| world.resource::<DfgNeighbours<Two>>().rebuilds;
        assert_eq!(rebuilds(&world), 1);
        let shift = |world: &mut World, dx: f64| {
            for mut x in world.query::<&mut Position<Two>>().iter_mut(world) {
                x.0.x += dx;
            }
        };
        let half_skin = 0.5 * SKIN * 0.3;
        shift(&mut world, 0.8 * half_skin);
        run_system(&mut world, dfg_partition::<Two>);
        assert_eq!(rebuilds(&world), 1);
        let kept = particle_values::<DamageGradient<Two>>(&mut world);
        world.insert_resource(DfgNeighbours::<Two>::default());
        run_system(&mut world, dfg_partition::<Two>);
        let fresh = particle_values::<DamageGradient<Two>>(&mut world);
        assert_eq!(kept, fresh);
        shift(&mut world, 1.2 * half_skin);
        run_system(&mut world, dfg_partition::<Two>);
        assert_eq!(rebuilds(&world), 2);
    }

    #[test]
    fn the_gradient_points_towards_the_damage() {
        let mut world = strip(None);
        let gradients = particle_values::<DamageGradient<Two>>(&mut world);
        // Particle (i = 7, j = 1) sits next to the failed half.
        let next_to_crack = gradients[7 * 4 + 1].0;
        assert!(next_to_crack.x > 1.0, "{next_to_crack}");
        assert!(
            next_to_crack.y.abs() < 0.1 * next_to_crack.x,
            "{next_to_crack}"
        );
        // Particle (i = 2, j = 1): the kernel reaches no failed particle.
        assert_eq!(gradients[2 * 4 + 1].0, DVec2::ZERO);
    }

    /// A failed band two columns wide: the gradients on its two sides point into it, so the
    /// nodes along it split into two fields (Algorithms 1–2), each holding one failed column;
    /// eq. 21's statistics are computed per field there, and nowhere else.
    #[test]
    fn a_failed_band_splits_the_nodes_along_it() {
        let mut world = strip_failed(None, 7..9);
        run_system(
            &mut world,
            crate::partition::field_assignment::assign_fields_system::<Two>,
        );
        run_system(&mut world, dfg_partition::<Two>);
        let fields = node_values::<NodeFields>(&mut world);
        let stats = node_values::<NodeFieldDamage>(&mut world);
        let split: Vec<&NodeFieldDamage> = fields
            .iter()
            .zip(&stats)
            .filter(|(f, _)| f.count == 2)
            .map(|(_, s)| s)
            .collect();
        assert!(!split.is_empty());
        for s in split {
            assert_eq!((s.max[0], s.max[1]), (1.0, 1.0), "{s:?}");
            assert!(s.mean[0] > 0.25 && s.mean[1] > 0.25, "{s:?}");
        }
        assert!(
            fields
                .iter()
                .zip(&stats)
                .all(|(f, s)| f.count == 2 || *s == NodeFieldDamage::default())
        );
    }

    #[test]
    fn the_kernel_sum_finds_the_surface() {
        let mut world = strip(Some(0.8));
        let flags = particle_values::<SurfaceFlag>(&mut world);
        // The bottom and top rows and the ends are surface; the middle rows inside are not.
        assert_eq!(flags[4 * 4].0, 1.0);
        assert_eq!(flags[4 * 4 + 3].0, 1.0);
        assert_eq!(flags[4 * 4 + 1].0, 0.0);
        assert_eq!(flags[4 * 4 + 2].0, 0.0);
        assert_eq!(flags[1].0, 1.0);
        assert!(world.resource::<SurfaceDetected>().0);
    }
}
