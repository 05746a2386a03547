//! Bodies that overlap. Each body is seeded on its own, so where two shapes overlap both would
//! put particles: twice the mass and two stress states in one place. Such a scene is refused,
//! naming both bodies and a particle in the overlap, unless one body names the other in
//! `wins_over`: then the winner keeps the overlap and the other's particles there are not
//! seeded (an inclusion in a matrix, a bolt through a plate).

use super::SceneError;
use super::check::Checks;
use super::seeder::Seeder;
use super::spec::Body;
use fractum_engine::dim::{Dim, VectorOps};
use glam::DVec3;

/// Whether `winner` names `loser` in its `wins_over`.
fn wins_over<D: Dim>(winner: &Body<D>, loser: &Body<D>) -> bool {
    loser
        .name
        .as_ref()
        .is_some_and(|name| winner.wins_over.contains(name))
}

/// `bodies[b] ("name")`, or `bodies[b]` for a body without a name.
fn describe<D: Dim>(b: usize, body: &Body<D>) -> String {
    match &body.name {
        Some(name) => format!("bodies[{b}] (\"{name}\")"),
        None => format!("bodies[{b}]"),
    }
}

/// A point as a scene writes it: `(x, y)` in 2D, `(x, y, z)` in 3D.
fn coordinates<D: Dim>(x: D::Vector) -> String {
    let x: [f64; 3] = x.to_3d();
    // Nine decimals: a lattice point without the last bits of its arithmetic.
    let shown: Vec<String> = x[..D::N]
        .iter()
        .map(|c| {
            let fixed = format!("{c:.9}");
            let trimmed = fixed.trim_end_matches('0').trim_end_matches('.');
            if trimmed == "-0" { "0" } else { trimmed }.to_string()
        })
        .collect();
    format!("({})", shown.join(", "))
}

/// The test "`x` lies in the shape of `body`", its bounding box (computed once) tried first.
fn inside<D: Dim>(body: &Body<D>) -> impl Fn(D::Vector) -> bool + '_ {
    let (lo, hi) = body.shape.bounds();
    move |x| {
        let p: DVec3 = x.to_3d().into();
        p.cmpge(lo).all() && p.cmple(hi).all() && body.shape.contains(p)
    }
}

impl<D: Dim> Seeder<'_, D> {
    /// The particles `seeded` for body `b` less those inside a body that wins over it. A
    /// particle inside another body that neither body names in `wins_over` is an error at
    /// `bodies[b].shape`.
    pub(super) fn resolve_overlaps(
        &self,
        b: usize,
        mut seeded: Vec<(D::Vector, f64)>,
    ) -> Result<Vec<(D::Vector, f64)>, SceneError> {
        let body = &self.spec.bodies[b];
        let seeded_any = !seeded.is_empty();
        for (a, other) in self.spec.bodies.iter().enumerate() {
            if a == b || wins_over(body, other) {
                continue;
            }
            let in_other = inside(other);
            if wins_over(other, body) {
                seeded.retain(|&(x, _)| !in_other(x));
                continue;
            }
            if let Some(&(x, _)) = seeded.iter().find(|&&(x, _)| in_other(x)) {
                // Placed at the later of the two, the body most likely added last.
                return Err(self.overlap_error(b.max(a), b.min(a), x));
            }
        }
        if seeded_any && seeded.is_empty() {
            return Err(self.spec.source.error(
                &format!("bodies[{b}].shape"),
                format!(
                    "every particle of {} lies inside bodies that win over it (`wins_over`); \
                     nothing of it would be seeded",
                    describe(b, body)
                ),
            ));
        }
        Ok(seeded)
    }

    /// Body `b` overlaps body `a` at `x`, reported at `bodies[b].shape`.
    fn overlap_error(&self, b: usize, a: usize, x: D::Vector) -> SceneError {
        let (body, other) = (&self.spec.bodies[b], &self.spec.bodies[a]);
        let remedy = match (&body.name, &other.name) {
            (Some(mine), Some(theirs)) => format!(
                "move one of them, or say which keeps the overlap: `wins_over: [\"{theirs}\"]` \
                 on bodies[{b}], or `wins_over: [\"{mine}\"]` on bodies[{a}]"
            ),
            _ => "move one of them, or name both bodies and give the one that keeps the overlap \
                  `wins_over: [\"<the other's name>\"]`"
                .to_string(),
        };
        self.spec.source.error(
            &format!("bodies[{b}].shape"),
            format!(
                "{} overlaps {}: the particle at {} lies in both shapes, and the overlap would \
                 be seeded twice (double mass); {remedy}",
                describe(b, body),
                describe(a, other),
                coordinates::<D>(x)
            ),
        )
    }
}

impl<D: Dim> Checks<'_, D> {
    /// Checks body `b`'s `wins_over`: names of other bodies, listed once, not naming a body that
    /// also wins over this one.
    pub(super) fn winners(&self, b: usize) -> Result<(), SceneError> {
        let body = &self.spec.bodies[b];
        for (k, name) in body.wins_over.iter().enumerate() {
            let field = format!("bodies[{b}].wins_over[{k}]");
            if body.wins_over[..k].contains(name) {
                return Err(self
                    .spec
                    .source
                    .error(&field, format!("\"{name}\" is listed twice")));
            }
            if body.name.as_ref() == Some(name) {
                return Err(self
                    .spec
                    .source
                    .error(&field, "a body cannot win over itself; name another body"));
            }
            let Some(a) = self
                .spec
                .bodies
                .iter()
                .position(|other| other.name.as_ref() == Some(name))
            else {
                let known: Vec<String> = self
                    .spec
                    .bodies
                    .iter()
                    .filter_map(|other| other.name.as_ref())
                    .filter(|other| body.name.as_ref() != Some(*other))
                    .map(|other| format!("\"{other}\""))
                    .collect();
                return Err(self.spec.source.error(
                    &field,
                    format!(
                        "no body is named \"{name}\"; the other bodies' names: {}",
                        if known.is_empty() {
                            "none (give the body a `name`)".to_string()
                        } else {
                            known.join(", ")
                        }
                    ),
                ));
            };
            if wins_over(&self.spec.bodies[a], body) {
                return Err(self.spec.source.error(
                    &field,
                    format!(
                        "{} and {} each win over the other; only one can keep the overlap",
                        describe(b, body),
                        describe(a, &self.spec.bodies[a])
                    ),
                ));
            }
        }
        Ok(())
    }
}
