//! # fractum-systems
//!
//! Fractum's stock algorithms. One file per algorithm, grouped by stage; each file starts with
//! what it does, its stage, its registration name and the paper equations it implements, and
//! exposes one `REGISTRATION`. [`register_all`] adds them all to a registry; a user's crate can
//! then add its own next to them.

use fractum_engine::prelude::{Params, Registration, Registry, SceneError};

pub mod advection;
pub mod basis;
pub mod contact;
pub mod corrector;
pub mod damage;
pub mod neighbour;
pub mod partition;
pub mod predictor;
pub mod row_map_transfer;
pub mod spatial;
pub mod stress;
pub mod transfer;

/// Every stock registration.
pub const ALL: &[Registration] = &[
    neighbour::kdtree::REGISTRATION,
    neighbour::node_linked::REGISTRATION,
    basis::bspline::REGISTRATION,
    basis::gimp::REGISTRATION,
    basis::linear::REGISTRATION,
    basis::lme::REGISTRATION,
    basis::mls::REGISTRATION,
    predictor::usl::REGISTRATION,
    predictor::newmark::REGISTRATION,
    predictor::mls::REGISTRATION,
    stress::linear_elastic::REGISTRATION,
    stress::neo_hookean::REGISTRATION,
    stress::shock_viscosity::REGISTRATION,
    damage::eigenerosion::REGISTRATION,
    damage::eigensoftening::REGISTRATION,
    damage::rankine::REGISTRATION,
    damage::nonlocal_rankine::REGISTRATION,
    damage::time_to_failure::REGISTRATION,
    partition::bodies::REGISTRATION,
    partition::dfg::REGISTRATION,
    contact::frictional::REGISTRATION,
    contact::penalty::REGISTRATION,
    corrector::newmark::REGISTRATION,
    advection::usl::REGISTRATION,
    advection::newmark::REGISTRATION,
    advection::mls::REGISTRATION,
];

/// Adds every stock system to `registry`.
///
/// # Panics
/// If a stock name is already taken (a user's registration should use its own names).
pub fn register_all(registry: &mut Registry) {
    for registration in ALL {
        if let Err(e) = registry.register(*registration) {
            panic!("stock system cannot be registered: {e}");
        }
    }
}

/// A registry holding every stock system.
pub fn stock_registry() -> Registry {
    let mut registry = Registry::new();
    register_all(&mut registry);
    registry
}

/// Empty parameter set: rejects any field given in `params: (...)`.
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct NoParams {}

/// Parses `params` for a system that takes none, so a stray field is an error, not ignored.
pub(crate) fn no_params(params: &Params) -> Result<(), SceneError> {
    params.parse::<NoParams>().map(|_| ())
}

#[cfg(test)]
mod tests {
    use fractum_engine::prelude::Registration;
    use fractum_engine::testing::{assert_defaults, serde_fields};

    #[test]
    fn the_helpers_see_the_fields_and_catch_a_wrong_default() {
        use crate::predictor::newmark::{NewmarkParams, REGISTRATION};
        use fractum_engine::prelude::ParamDoc;
        let fields = serde_fields::<crate::contact::frictional::FrictionalParams>();
        assert!(
            fields.contains(&"friction") && fields.contains(&"pairs"),
            "{fields:?}"
        );
        const WRONG: &[ParamDoc] = &[ParamDoc {
            name: "gamma",
            ty: "f64",
            default: Some("0.6"),
            doc: "",
        }];
        let wrong = Registration {
            params: WRONG,
            ..REGISTRATION
        };
        let caught = std::panic::catch_unwind(|| assert_defaults::<NewmarkParams>(&wrong));
        assert!(caught.is_err());
    }
}
