//! Checks that tie a registration's documented parameters ([`ParamDoc`](crate::registry::ParamDoc))
//! to the serde type its installer parses: the same fields, and every documented default that
//! is a RON value equal to the type's own default. A system's unit test calls
//! [`assert_defaults`] with its registration, so `fractum systems` and the guide never show a
//! parameter or a default that the code does not have:
//!
//! ```
//! use fractum_engine::prelude::*;
//! use fractum_engine::testing::assert_defaults;
//!
//! #[derive(serde::Deserialize, Debug, PartialEq)]
//! #[serde(default, deny_unknown_fields)]
//! struct KickParams {
//!     speed: f64,
//! }
//!
//! impl Default for KickParams {
//!     fn default() -> Self {
//!         Self { speed: 1.0 }
//!     }
//! }
//!
//! const PARAMS: &[ParamDoc] = &[ParamDoc {
//!     name: "speed",
//!     ty: "f64",
//!     default: Some("1.0"),
//!     doc: "How fast (m/s).",
//! }];
//!
//! fn install(_: &mut Installer, params: &Params) -> Result<(), SceneError> {
//!     params.parse::<KickParams>().map(|_| ())
//! }
//!
//! const REGISTRATION: Registration = Registration {
//!     name: "advection/kick",
//!     summary: "An example.",
//!     params: PARAMS,
//!     requires: &[],
//!     install,
//! };
//!
//! assert_defaults::<KickParams>(&REGISTRATION);
//! ```

use crate::registry::{Params, Registration};
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
