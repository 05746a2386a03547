//! [`Params`]: a pipeline entry's raw `params`, parsed by its installer, placed in the scene
//! file for errors, and checked against the registration's declared parameters.

use super::Registration;
use crate::text::{Location, SceneError, parse_fragment};
use serde::de::DeserializeOwned;

/// The raw `params` of one pipeline entry, with where it sits in the scene file.
#[derive(Clone, Debug)]
pub struct Params<'a> {
    raw: Option<&'a str>,
    file: &'a str,
    origin: Location,
    field: String,
}

impl<'a> Params<'a> {
    /// Params text `raw` (None when the entry has no `params`) found at `origin` in `file`,
    /// whose field path is `field` (e.g. `pipeline[2].params`).
    pub fn new(raw: Option<&'a str>, file: &'a str, origin: Location, field: String) -> Self {
        Self {
            raw,
            file,
            origin,
            field,
        }
    }

    /// No params, as for a test or a programmatic pipeline.
    pub fn none() -> Params<'static> {
        Params {
            raw: None,
            file: "<no params>",
            origin: Location { line: 1, col: 1 },
            field: "params".to_string(),
        }
    }

    /// Params from a string, as for a test or a programmatic pipeline.
    pub fn inline(raw: &'a str) -> Self {
        Self {
            raw: Some(raw),
            file: "<params>",
            origin: Location { line: 1, col: 1 },
            field: "params".to_string(),
        }
    }

    /// Parses the params into `T`. An entry without `params` parses as `()`, so `T` must give
    /// every field a default for that to succeed; otherwise the error names the missing field.
    pub fn parse<T: DeserializeOwned>(&self) -> Result<T, SceneError> {
        parse_fragment(
            self.file,
            self.raw.unwrap_or("()"),
            self.origin,
            &self.field,
        )
    }

    /// Refuses `field` with `message` (placed at its value) unless `holds`: the one shape of
    /// every range check, e.g.
    /// `params.require("separability", (0.0..1.0).contains(&d) && d > 0.0, "expected D̄_min in (0, 1)")?`.
    pub fn require(&self, field: &str, holds: bool, message: &str) -> Result<(), SceneError> {
        if holds {
            Ok(())
        } else {
            Err(self.error(field, message))
        }
    }

    /// Refuses `value` of `field` with `message` unless it is finite and positive.
    pub fn require_positive(
        &self,
        field: &str,
        value: f64,
        message: &str,
    ) -> Result<(), SceneError> {
        self.require(field, value.is_finite() && value > 0.0, message)
    }

    /// Refuses `value` of `field` with `message` unless it is finite and not negative.
    pub fn require_non_negative(
        &self,
        field: &str,
        value: f64,
        message: &str,
    ) -> Result<(), SceneError> {
        self.require(field, value.is_finite() && value >= 0.0, message)
    }

    /// An error about these params (e.g. a value out of range), placed at the params.
    pub fn error(&self, relative: &str, message: impl Into<String>) -> SceneError {
        let field = if relative.is_empty() {
            self.field.clone()
        } else {
            format!("{}.{relative}", self.field)
        };
        let location = self
            .raw
            .and_then(|raw| {
                let at = crate::text::locate::locate(raw, relative)?;
                Some(self.origin.offset_by(Location::of_offset(raw, at)))
            })
            .unwrap_or(self.origin);
        SceneError::at(self.file, location, &field, message)
    }
}

/// The top-level field names of a pipeline entry's `params: (...)`, whatever their values.
struct ParamNames(Vec<String>);

impl<'de> serde::Deserialize<'de> for ParamNames {
    fn deserialize<De: serde::Deserializer<'de>>(deserializer: De) -> Result<Self, De::Error> {
        struct Names;
        impl<'de> serde::de::Visitor<'de> for Names {
            type Value = ParamNames;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("parameters written as `(name: value, …)`")
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(
                self,
                mut map: A,
            ) -> Result<ParamNames, A::Error> {
                let mut names = Vec::new();
                while let Some(name) = map.next_key::<String>()? {
                    map.next_value::<serde::de::IgnoredAny>()?;
                    names.push(name);
                }
                Ok(ParamNames(names))
            }
            fn visit_unit<E: serde::de::Error>(self) -> Result<ParamNames, E> {
                Ok(ParamNames(Vec::new()))
            }
        }
        deserializer.deserialize_struct("params", &[], Names)
    }
}

impl Params<'_> {
    /// Refuses a parameter that `registration` does not declare in its
    /// [`Registration::params`]: the declared list is a system's interface, so a misspelt or
    /// foreign field is an error for every system, whether or not its installer parses its
    /// params with `deny_unknown_fields`.
    pub fn check_declared(&self, registration: &Registration) -> Result<(), SceneError> {
        if self.raw.is_none() {
            return Ok(());
        }
        let ParamNames(names) = self.parse()?;
        let declared: Vec<&str> = registration.params.iter().map(|p| p.name).collect();
        match names.iter().find(|n| !declared.contains(&n.as_str())) {
            None => Ok(()),
            Some(unknown) if declared.is_empty() => Err(self.error(
                unknown,
                format!(
                    "unknown field `{unknown}`; {} takes no parameters",
                    registration.name
                ),
            )),
            Some(unknown) => {
                let quoted: Vec<String> = declared.iter().map(|d| format!("`{d}`")).collect();
                let expected = match quoted.as_slice() {
                    [one] => format!("expected {one}"),
                    _ => format!("expected one of {}", quoted.join(", ")),
                };
                Err(self.error_at_name(unknown, format!("unknown field `{unknown}`; {expected}")))
            }
        }
    }

    /// [`Params::error`] placed at the field's name rather than its value.
    fn error_at_name(&self, field: &str, message: String) -> SceneError {
        let mut error = self.error(field, message);
        let name_at = self.raw.and_then(|raw| {
            let value = crate::text::locate::locate(raw, field)?;
            raw[..value].rfind(field)
        });
        if let (Some(raw), Some(at)) = (self.raw, name_at) {
            error.location = Some(self.origin.offset_by(Location::of_offset(raw, at)));
        }
        error
    }
}
