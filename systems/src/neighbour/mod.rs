//! Neighbour stage: ε-neighbourhoods of the particles for non-local damage.
pub mod kdtree;
pub mod node_linked;

use fractum_engine::prelude::*;
use serde::Deserialize;

/// Parameters shared by the neighbourhood builders.
#[derive(Resource, Deserialize, Clone, Copy, Debug, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct NeighbourParams {
    /// ε = C_ε h.
    pub c_epsilon: f64,
    /// Skin as a fraction of ε (kd-tree only): lists are rebuilt when a particle has moved more
    /// than half of it.
    pub skin: f64,
    /// Only particles of the same body are neighbours.
    pub same_body: bool,
    /// ε in metres, in place of `c_epsilon × h`: a length of the material that stays put
    /// when the grid is refined (a non-local law's averaging radius).
    pub radius: Option<f64>,
}

impl NeighbourParams {
    /// The radius ε (m) on a grid whose (smallest) spacing is `h`.
    pub fn epsilon(&self, h: f64) -> f64 {
        self.radius.unwrap_or(self.c_epsilon * h)
    }

    /// ε in cells of spacing `h`.
    pub fn epsilon_cells(&self, h: f64) -> f64 {
        self.epsilon(h) / h
    }
}

impl Default for NeighbourParams {
    fn default() -> Self {
        Self {
            c_epsilon: 2.0,
            skin: 0.25,
            same_body: false,
            radius: None,
        }
    }
}

/// Parameter documentation shared by both builders.
pub const PARAM_DOCS: &[ParamDoc] = &[
    ParamDoc {
        name: "c_epsilon",
        ty: "f64",
        default: Some("2.0"),
        doc: "neighbourhood radius ε = c_epsilon × h (h: grid spacing)",
    },
    ParamDoc {
        name: "skin",
        ty: "f64",
        default: Some("0.25"),
        doc: "kd-tree only: search ε(1 + skin), rebuild when a particle moved more than ε·skin/2",
    },
    ParamDoc {
        name: "same_body",
        ty: "bool",
        default: Some("false"),
        doc: "only particles of the same body are neighbours",
    },
    ParamDoc {
        name: "radius",
        ty: "f64",
        default: Some("c_epsilon × h"),
        doc: "ε (m), fixed whatever the grid; give this or c_epsilon",
    },
];

/// Which of the two ways of giving ε a scene wrote.
#[derive(Deserialize, Default)]
#[serde(default)]
struct GivenRadius {
    c_epsilon: Option<f64>,
}

/// Parses and checks the shared parameters.
pub fn parse_params(params: &Params) -> Result<NeighbourParams, SceneError> {
    let parsed: NeighbourParams = params.parse()?;
    params.require_positive("c_epsilon", parsed.c_epsilon, "expected a positive factor")?;
    if let Some(radius) = parsed.radius {
        params.require_positive("radius", radius, "expected ε > 0 (m)")?;
        let given: GivenRadius = params.parse()?;
        params.require(
            "radius",
            given.c_epsilon.is_none(),
            "give `radius` (ε in metres) or `c_epsilon` (ε in cells), not both",
        )?;
    }
    params.require_non_negative("skin", parsed.skin, "expected a fraction >= 0")?;
    Ok(parsed)
}

/// Declares a neighbour search's lists for the scene's memory estimate: one list per entry of
/// `reaches`, of the particles within that many cells of each, and an anchor position per
/// particle. A list's length is the volume of a ball half a cell wider than its reach at the
/// scene's mean particles per cell: the margin covers a graded grid, where the mean
/// particles per cell of the smallest width undercounts the fine zone's.
pub fn declare_lists(installer: &mut Installer, name: &str, reaches: &[f64]) {
    let d = installer.dimension().count();
    let per_cell = installer.particles_per_cell();
    let counts: Vec<f64> = reaches
        .iter()
        .map(|&reach| fractum_engine::budget::ball_volume(d, reach + 0.5) * per_cell)
        .collect();
    let widest = counts.iter().copied().fold(0.0, f64::max);
    installer.declare_particle_memory(
        format!(
            "{name}: about {} neighbours per particle",
            fractum_engine::budget::describe_count(widest)
        ),
        4.0 * counts.iter().sum::<f64>() + (8 * d) as f64,
    );
}

/// Appends to `out` the candidates of `p` within `radius` (and in `p`'s body when asked), in
/// the order given: ascending when the candidates are (each builder hands its lists over
/// sorted, without duplicates).
///
/// Every candidate is written and the end advanced only past those kept: no branch to
/// mispredict on whether a candidate is in (about a third of a kd-tree candidate list is not).
pub fn filter_row<D: Dim>(
    p: usize,
    candidates: &[u32],
    positions: &[Position<D>],
    bodies: &[BodyId],
    radius: f64,
    same_body: bool,
    out: &mut Vec<u32>,
) {
    let x = positions[p].0;
    let r2 = radius * radius;
    let start = out.len();
    out.resize(start + candidates.len(), 0);
    let slots = &mut out[start..];
    let mut kept = 0;
    for &q in candidates {
        let near = (positions[q as usize].0 - x).length_squared() <= r2;
        let keep = near && (!same_body || bodies[q as usize] == bodies[p]);
        slots[kept] = q;
        kept += usize::from(keep);
    }
    out.truncate(start + kept);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn epsilon_is_the_radius_in_metres_when_given_and_c_epsilon_cells_otherwise() {
        let cells = parse_params(&Params::inline("(c_epsilon: 1.5)")).unwrap();
        assert_eq!(cells.epsilon(0.2), 1.5 * 0.2);
        let metres = parse_params(&Params::inline("(radius: 0.25)")).unwrap();
        assert_eq!(metres.epsilon(0.2), 0.25);
        assert_eq!(metres.epsilon(0.05), 0.25);
        assert_eq!(metres.epsilon_cells(0.05), 5.0);
    }

    #[test]
    fn a_radius_and_a_factor_together_or_a_radius_not_positive_are_refused() {
        let both = parse_params(&Params::inline("(c_epsilon: 2.0, radius: 0.25)")).unwrap_err();
        assert!(both.to_string().contains("not both"), "{both}");
        let negative = parse_params(&Params::inline("(radius: -0.1)")).unwrap_err();
        assert!(negative.to_string().contains("ε > 0"), "{negative}");
    }
}
