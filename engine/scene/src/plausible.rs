//! Magnitudes no solid has: a Young's modulus of 30 Pa (GPa meant), a density of 7.8 kg/m³
//! (g/cm³ meant), a tensile strength of 3 Pa (MPa meant). Such a scene is valid, so nothing
//! refuses it, but it runs a different problem than the one meant: a modulus a billion times
//! too small gives a wave speed of centimetres per second and a one-step run. `fractum check`
//! names each such value with the unit slip it likely is; the run itself is not refused, as
//! scaled and dimensionless test problems (a bar of E = 100 Pa, ρ = 1 kg/m³) are legitimate.
//!
//! The ranges are those of engineering solids, wide on purpose: wave speeds from 20 m/s (soft
//! rubber) to 25 km/s (beyond diamond's 18 km/s); densities from 10 kg/m³ (aerogels, foams) to
//! 25 000 kg/m³ (beyond osmium's 22 600); strengths from a millionth of the modulus to a fifth
//! of it.

use crate::SceneFile;
use fractum_engine::text::edit::value_at;
use fractum_engine::text::readable as num;

/// Bar wave speeds of solids (m/s).
const WAVE_SPEED: (f64, f64) = (20.0, 25_000.0);
/// Densities of solids (kg/m³).
const DENSITY: (f64, f64) = (10.0, 25_000.0);
/// Tensile strength over Young's modulus of solids.
const STRENGTH_OVER_MODULUS: (f64, f64) = (1.0e-6, 0.2);

/// One implausible value: the field it is at and what it likely is.
#[derive(Clone, Debug, PartialEq)]
pub struct Implausible {
    /// The field path (`materials.steel.youngs_modulus`).
    pub field: String,
    /// What is wrong and the likely slip.
    pub message: String,
}

impl std::fmt::Display for Implausible {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "`{}`: {}", self.field, self.message)
    }
}

/// Every magnitude of `file` far outside solids' ranges, with the unit slip it likely is.
pub fn implausible_magnitudes(file: &SceneFile) -> Vec<Implausible> {
    let mut found = Vec::new();
    for (name, m) in &file.scene.materials {
        let field = |f: &str| format!("materials.{name}.{f}");
        if let Some(message) = density_slip(m.density) {
            found.push(Implausible {
                field: field("density"),
                message,
            });
        }
        if let Some(message) = modulus_slip(m.youngs_modulus, plausible_density(m.density)) {
            found.push(Implausible {
                field: field("youngs_modulus"),
                message,
            });
        }
    }
    found.extend(strength_slips(file));
    found
}

/// The density a wave speed is judged with: the scene's where plausible, else what it likely
/// meant (g/cm³ read as kg/m³), so one slip is not reported twice.
fn plausible_density(density: f64) -> f64 {
    if within(density, DENSITY) {
        density
    } else if within(density * 1.0e3, DENSITY) {
        density * 1.0e3
    } else {
        density
    }
}

fn within(value: f64, (low, high): (f64, f64)) -> bool {
    value >= low && value <= high
}

fn density_slip(density: f64) -> Option<String> {
    if within(density, DENSITY) || density <= 0.0 {
        return None;
    }
    let hint = if within(density * 1.0e3, DENSITY) {
        format!(
            "; g/cm³ meant? {} g/cm³ is {} kg/m³",
            num(density),
            num(density * 1.0e3)
        )
    } else {
        String::new()
    };
    Some(format!(
        "{} kg/m³ is outside the densities of solids ({} to {} kg/m³){hint}",
        num(density),
        DENSITY.0,
        DENSITY.1
    ))
}

fn modulus_slip(modulus: f64, density: f64) -> Option<String> {
    if modulus <= 0.0 || density <= 0.0 {
        return None;
    }
    let speed = |e: f64| (e / density).sqrt();
    let c = speed(modulus);
    if within(c, WAVE_SPEED) {
        return None;
    }
    let hint = [
        (1.0e9, "GPa"),
        (1.0e6, "MPa"),
        (1.0e-6, "Pa where MPa was written"),
    ]
    .into_iter()
    .find(|(scale, _)| within(speed(modulus * scale), WAVE_SPEED))
    .map(|(scale, unit)| match unit {
        "GPa" | "MPa" => format!(
            "; {unit} meant? {} {unit} is {} Pa",
            num(modulus),
            num(modulus * scale)
        ),
        _ => format!(
            "; {unit}? {} Pa would be {} Pa",
            num(modulus),
            num(modulus * scale)
        ),
    })
    .unwrap_or_default();
    Some(format!(
        "{} Pa with a density of {} kg/m³ gives a wave speed of {} m/s, outside solids' {} to \
         {} m/s (the time step follows the wave speed: the run would take far too few or too \
         many steps){hint}",
        num(modulus),
        num(density),
        num(c),
        WAVE_SPEED.0,
        WAVE_SPEED.1
    ))
}

/// `tensile_strength` of each pipeline entry against the modulus of the materials it governs.
fn strength_slips(file: &SceneFile) -> Vec<Implausible> {
    let mut found = Vec::new();
    for (k, entry) in file.scene.pipeline.iter().enumerate() {
        let Some(params) = &entry.params else {
            continue;
        };
        let Some(strength) = value_at(params.get_ron(), "tensile_strength")
            .and_then(|v| v.trim().parse::<f64>().ok())
        else {
            continue;
        };
        let governed: Vec<_> = file
            .scene
            .materials
            .iter()
            .filter(|(name, _)| {
                entry
                    .materials
                    .as_ref()
                    .is_none_or(|names| names.contains(name))
            })
            .map(|(_, m)| m)
            .collect();
        // A strength is judged against a plausible modulus only: where the modulus is the
        // slip, that is what is reported.
        if governed
            .iter()
            .any(|m| modulus_slip(m.youngs_modulus, plausible_density(m.density)).is_some())
        {
            continue;
        }
        let Some(modulus) = governed.iter().map(|m| m.youngs_modulus).reduce(f64::min) else {
            continue;
        };
        if strength <= 0.0 || modulus <= 0.0 {
            continue;
        }
        let ratio = strength / modulus;
        if within(ratio, STRENGTH_OVER_MODULUS) {
            continue;
        }
        let hint = [
            (1.0e6, "MPa"),
            (1.0e9, "GPa"),
            (1.0e-6, "Pa where MPa was written"),
        ]
        .into_iter()
        .find(|(scale, _)| within(ratio * scale, STRENGTH_OVER_MODULUS))
        .map(|(scale, unit)| format!("; {unit}? that is {} Pa", num(strength * scale)))
        .unwrap_or_default();
        found.push(Implausible {
            field: format!("pipeline[{k}].params.tensile_strength"),
            message: format!(
                "{} Pa is {} times Young's modulus ({} Pa), outside solids' {} to {}{hint}",
                num(strength),
                num(ratio),
                num(modulus),
                num(STRENGTH_OVER_MODULUS.0),
                STRENGTH_OVER_MODULUS.1
            ),
        });
    }
    found
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene(materials: &str, params: &str) -> SceneFile {
        let text = format!(
            "(time: (step: Cfl(0.5), end: Steps(1)),
              grid: (min: (0.0, 0.0), max: (1.0, 1.0), spacing: 0.1),
              materials: {{ {materials} }},
              bodies: [],
              pipeline: [(system: \"damage/rankine\", params: ({params}))])"
        );
        SceneFile::parse("s.ron", text).unwrap()
    }

    fn found(materials: &str, params: &str) -> Vec<String> {
        implausible_magnitudes(&scene(materials, params))
            .iter()
            .map(ToString::to_string)
            .collect()
    }

    #[test]
    fn solids_pass() {
        let concrete = r#""c": (density: 2400.0, youngs_modulus: 30.0e9, poisson_ratio: 0.2)"#;
        assert!(found(concrete, "tensile_strength: 3.0e6").is_empty());
    }

    #[test]
    fn a_modulus_in_gpa_and_a_strength_in_mpa_are_named() {
        let slips = found(
            r#""c": (density: 2400.0, youngs_modulus: 30.0, poisson_ratio: 0.2)"#,
            "tensile_strength: 3.0e6",
        );
        assert_eq!(slips.len(), 1, "{slips:?}");
        assert!(
            slips[0].starts_with("`materials.c.youngs_modulus`: 30 Pa"),
            "{slips:?}"
        );
        // One slip: the strength, right for 30 GPa, is not blamed for the modulus's.
        assert!(
            slips[0].contains("GPa meant? 30 GPa is 3e10 Pa"),
            "{slips:?}"
        );
        let slips = found(
            r#""c": (density: 2400.0, youngs_modulus: 30.0e9, poisson_ratio: 0.2)"#,
            "tensile_strength: 3.0",
        );
        assert_eq!(slips.len(), 1, "{slips:?}");
        assert!(
            slips[0].contains("pipeline[0].params.tensile_strength"),
            "{slips:?}"
        );
        assert!(
            slips[0].contains("1e-10 times Young's modulus (3e10 Pa)"),
            "{slips:?}"
        );
        assert!(slips[0].contains("MPa? that is 3e6 Pa"), "{slips:?}");
    }

    #[test]
    fn a_density_in_g_per_cm3_is_named_once() {
        let slips = found(
            r#""s": (density: 7.8, youngs_modulus: 200.0e9, poisson_ratio: 0.3)"#,
            "tensile_strength: 1.0e9",
        );
        assert_eq!(slips.len(), 1, "{slips:?}");
        assert!(
            slips[0].contains("g/cm³ meant? 7.8 g/cm³ is 7800 kg/m³"),
            "{slips:?}"
        );
    }
}
