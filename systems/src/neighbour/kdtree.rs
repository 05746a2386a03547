//! ε-neighbourhoods from a kd-tree over the particle positions, with a skin.
//!
//! - Stage: neighbour. Registration name: `neighbour/kdtree`.
//! - B_ε(x_p) of eigensoftening-lme-mpm.md §2.3 (eqs. 11–15), radius ε = C_ε h. A kiddo kd-tree
//!   over the particle positions is queried with radius ε(1 + skin); the candidate lists are
//!   kept until some particle has moved more than ε·skin/2 since the last build (two particles
//!   then cannot have closed a gap larger than the skin), as the DFG paper's neighbour lists do
//!   (§2.5). Every step the candidates are filtered to the exact radius, so the lists do not
//!   depend on when the tree was rebuilt.
//! - Lists are sorted, without duplicates, and include the particle itself.
//! - On a graded grid `h` is the smallest cell width (the fine zone, where cracks are meant to
//!   run).

use super::{NeighbourParams, PARAM_DOCS, filter_row, parse_params};
use crate::spatial::Spatial;
use fractum_engine::prelude::*;
use rayon::prelude::*;

/// Registration of `neighbour/kdtree`.
pub const REGISTRATION: Registration = Registration {
    name: "neighbour/kdtree",
    summary: "ε-neighbourhoods from a kd-tree over particles, rebuilt when particles move past a skin",
    params: PARAM_DOCS,
    requires: &[],
    install: generic_install!(install),
};

fn install<D: Spatial>(installer: &mut Installer, params: &Params) -> Result<(), SceneError> {
    let parsed = parse_params(params)?;
    let h = installer.world().resource::<Grid<D>>().spacing;
    let cells = parsed.epsilon_cells(h);
    // The candidates within ε(1 + skin), and the neighbours within ε.
    super::declare_lists(
        installer,
        "neighbour/kdtree",
        &[cells * (1.0 + parsed.skin), cells],
    );
    installer.declare_particle_reach("the ε-neighbourhood", parsed.epsilon(h));
    installer.insert_resource(parsed);
    installer.init_resource::<Neighbourhoods>();
    installer.init_row_state::<KdTreeCandidates<D>>();
    installer.add_systems(kdtree_neighbours::<D>);
    Ok(())
}

/// Candidate lists within ε(1 + skin) of where each particle was at the last build.
#[derive(Resource, Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct KdTreeCandidates<D: Dim> {
    /// Positions at the last build.
    pub anchors: Vec<D::Vector>,
    /// Candidate rows per particle, sorted, within the radius ε(1 + skin) of the last build.
    pub candidates: Neighbourhoods,
}

impl<D: Dim> Default for KdTreeCandidates<D> {
    fn default() -> Self {
        Self {
            anchors: Vec::new(),
            candidates: Neighbourhoods::default(),
        }
    }
}

/// The `neighbour/kdtree` system.
pub fn kdtree_neighbours<D: Spatial>(
    grid: Res<Grid<D>>,
    params: Res<NeighbourParams>,
    mut state: ResMut<KdTreeCandidates<D>>,
    mut neighbourhoods: ResMut<Neighbourhoods>,
    particles: Query<(&Position<D>, &BodyId), With<Particle>>,
) {
    let (positions, bodies) =
        single_table(particles.contiguous_iter(), "particles").unwrap_or((&[], &[]));
    let epsilon = params.epsilon(grid.spacing);
    let skin = params.skin * epsilon;
    let KdTreeCandidates {
        anchors,
        candidates,
    } = &mut *state;
    let moved = |(anchor, x): (&D::Vector, &Position<D>)| (x.0 - *anchor).length() > 0.5 * skin;
    let stale =
        anchors.len() != positions.len() || anchors.par_iter().zip(positions.par_iter()).any(moved);
    if stale {
        crate::spatial::build_candidates(positions, epsilon + skin, candidates);
        anchors.clear();
        anchors.extend(positions.iter().map(|p| p.0));
        neighbourhoods.rebuilds += 1;
    }
    let candidates = &*candidates;
    neighbourhoods.fill_rows(positions.len(), epsilon, |p, out| {
        let row = candidates.of(p);
        filter_row(p, row, positions, bodies, epsilon, params.same_body, out);
    });
}

// The checkpoint key of this system's state (stable across builds).
impl<D: Dim> fractum_engine::checkpoint::State for KdTreeCandidates<D> {
    const KEY: &'static str = "kdtree/candidates";
}

// In a distributed run the rows hold other particles after each step: the lists are rebuilt.
impl<D: Dim> fractum_engine::checkpoint::RowState for KdTreeCandidates<D> {
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
        fractum_engine::testing::assert_defaults::<NeighbourParams>(&REGISTRATION);
    }
    use fractum_engine::testing::*;

    #[test]
    fn lists_hold_the_particles_within_epsilon_including_self() {
        let mut world = tiny_world::<Two>(4, 0.25, 1e-3);
        world.insert_resource(NeighbourParams {
            c_epsilon: 1.0,
            skin: 0.25,
            same_body: false,
            radius: None,
        });
        world.insert_resource(Neighbourhoods::default());
        world.insert_resource(KdTreeCandidates::<Two>::default());
        for x in [0.1, 0.3, 0.36, 0.7] {
            spawn_particle(&mut world, DVec2::new(x, 0.5), DVec2::ZERO, 1.0, 0.01);
        }
        run_system(&mut world, kdtree_neighbours::<Two>);
        let n = world.resource::<Neighbourhoods>().clone();
        assert_eq!(n.radius, 0.25);
        assert_eq!(n.of(0), &[0, 1]);
        assert_eq!(n.of(1), &[0, 1, 2]);
        assert_eq!(n.of(2), &[1, 2]);
        assert_eq!(n.of(3), &[3]);
        assert_eq!(n.rebuilds, 1);
        // A small move keeps the tree; the lists still follow the exact radius.
        let mut q = world.query::<(&ParticleId, &mut Position<Two>)>();
        for (id, mut x) in q.iter_mut(&mut world) {
            if id.0 == 2 {
                x.0.x += 0.02;
            }
        }
        run_system(&mut world, kdtree_neighbours::<Two>);
        let n = world.resource::<Neighbourhoods>().clone();
        assert_eq!(n.rebuilds, 1);
        assert_eq!(n.of(0), &[0, 1]);
        assert_eq!(n.of(2), &[1, 2]);
    }

    #[test]
    fn lists_use_the_distance_in_3d() {
        let mut world = tiny_world::<Three>(4, 0.25, 1e-3);
        world.insert_resource(NeighbourParams {
            c_epsilon: 1.0,
            skin: 0.25,
            same_body: false,
            radius: None,
        });
        world.insert_resource(Neighbourhoods::default());
        world.insert_resource(KdTreeCandidates::<Three>::default());
        // Within 0.25 in x and y, but 0.3 apart along z.
        spawn_particle(
            &mut world,
            DVec3::new(0.5, 0.5, 0.2),
            DVec3::ZERO,
            1.0,
            0.01,
        );
        spawn_particle(
            &mut world,
            DVec3::new(0.5, 0.5, 0.5),
            DVec3::ZERO,
            1.0,
            0.01,
        );
        spawn_particle(
            &mut world,
            DVec3::new(0.6, 0.5, 0.6),
            DVec3::ZERO,
            1.0,
            0.01,
        );
        run_system(&mut world, kdtree_neighbours::<Three>);
        let n = world.resource::<Neighbourhoods>().clone();
        assert_eq!(n.of(0), &[0]);
        assert_eq!(n.of(1), &[1, 2]);
    }
}
