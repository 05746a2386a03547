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
pub mod spatial;
pub mod stress;
pub mod transfer;

/// Every stock registration.
pub const ALL: &[Registration] = &[
    neighbour::kdtree::REGISTRATION,
    neighbour::node_linked::REGISTRATION,
    basis::gimp::REGISTRATION,
    basis::linear::REGISTRATION,
    basis::lme::REGISTRATION,
    predictor::usl::REGISTRATION,
    predictor::newmark::REGISTRATION,
    stress::linear_elastic::REGISTRATION,
    stress::neo_hookean::REGISTRATION,
    damage::eigenerosion::REGISTRATION,
    damage::eigensoftening::REGISTRATION,
    damage::rankine::REGISTRATION,
    damage::time_to_failure::REGISTRATION,
    partition::bodies::REGISTRATION,
    partition::dfg::REGISTRATION,
    contact::frictional::REGISTRATION,
    contact::penalty::REGISTRATION,
    corrector::newmark::REGISTRATION,
    advection::usl::REGISTRATION,
    advection::newmark::REGISTRATION,
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

/// Test helpers that tie a registration's documented parameters to its serde type.
#[cfg(test)]
pub(crate) mod param_docs {
    use fractum_engine::prelude::{Params, Registration};
    use serde::de::{self, DeserializeOwned, Visitor};

    /// A deserializer that records the field names a derived `Deserialize` asks for.
    struct Capture(std::cell::Cell<&'static [&'static str]>);

    impl<'de> de::Deserializer<'de> for &Capture {
        type Error = de::value::Error;

        fn deserialize_any<V: Visitor<'de>>(self, _: V) -> Result<V::Value, Self::Error> {
            Err(de::Error::custom("not a struct"))
        }

        fn deserialize_struct<V: Visitor<'de>>(
            self,
            _: &'static str,
            fields: &'static [&'static str],
            _: V,
        ) -> Result<V::Value, Self::Error> {
            self.0.set(fields);
            Err(de::Error::custom("captured"))
        }

        serde::forward_to_deserialize_any! {
            bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string bytes byte_buf
            option unit unit_struct newtype_struct seq tuple tuple_struct map enum identifier
            ignored_any
        }
    }

    /// The field names of `T`'s derived `Deserialize`.
    pub fn serde_fields<T: DeserializeOwned>() -> Vec<&'static str> {
        let capture = Capture(std::cell::Cell::new(&[]));
        let _ = T::deserialize(&capture);
        capture.0.get().to_vec()
    }

    /// The registration documents exactly the fields its params type reads.
    pub fn assert_documented<T: DeserializeOwned>(registration: &Registration) {
        let mut documented: Vec<&str> = registration.params.iter().map(|p| p.name).collect();
        let mut fields = serde_fields::<T>();
        documented.sort_unstable();
        fields.sort_unstable();
        assert_eq!(
            documented, fields,
            "{}: documented vs read",
            registration.name
        );
    }

    /// Every documented default that is a RON value parses to the params type's own default
    /// (defaults described in words, such as "cell diagonal", are left to the docs).
    pub fn assert_defaults<T: DeserializeOwned + Default + PartialEq + std::fmt::Debug>(
        registration: &Registration,
    ) {
        assert_documented::<T>(registration);
        for doc in registration.params {
            let Some(default) = doc.default else { continue };
            let text = format!("({}: {default})", doc.name);
            if let Ok(parsed) = Params::inline(&text).parse::<T>() {
                assert_eq!(parsed, T::default(), "{}: {}", registration.name, doc.name);
            } else {
                // Not a RON value: it must not look like one either.
                assert!(
                    default.parse::<f64>().is_err(),
                    "{}: default {default} of {} does not parse",
                    registration.name,
                    doc.name
                );
            }
        }
    }

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
