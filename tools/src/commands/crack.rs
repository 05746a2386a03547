//! `fractum crack`: a crack's tip, angle and speed from a run's frames.

use crate::{CrackArgs, EXIT_IO, crack, load};
use fractum_engine::registry::Registry;
use fractum_engine::resources::Materials;
use fractum_engine::text::readable as num;
use fractum_io::output::write_atomically;
use std::path::Path;

/// A point of 2 or 3 coordinates as three.
fn point3(values: &[f64], what: &str) -> Result<[f64; 3], String> {
    match values {
        [x, y] => Ok([*x, *y, 0.0]),
        [x, y, z] => Ok([*x, *y, *z]),
        _ => Err(format!("--{what} takes 2 or 3 comma-separated numbers")),
    }
}

/// The Rayleigh speed of `material` (or the first) of the scene at `path`, with its name.
fn scene_rayleigh_speed(
    path: &Path,
    material: Option<&str>,
    registry: &Registry,
) -> Result<(String, f64), String> {
    let (_, built) = load(path, registry).map_err(|e| e.to_string())?;
    let materials = &built.simulation.world.resource::<Materials>().0;
    let m = match material {
        Some(name) => materials.iter().find(|m| m.name == name).ok_or_else(|| {
            let names: Vec<&str> = materials.iter().map(|m| m.name.as_str()).collect();
            format!(
                "no material {name:?} in {}; it has {names:?}",
                path.display()
            )
        })?,
        None => materials
            .first()
            .ok_or_else(|| format!("{} has no materials", path.display()))?,
    };
    let speed = crack::rayleigh_speed(m.youngs_modulus, m.poisson_ratio, m.density);
    Ok((m.name.clone(), speed))
}

pub(crate) fn crack_command(request: &CrackArgs, registry: &Registry) -> i32 {
    match crack_report(request, registry) {
        Ok(report) => {
            outln!("{report}");
            0
        }
        Err(e) => {
            eprintln!("error: {e}");
            EXIT_IO
        }
    }
}

/// The crack's history written to `crack.csv`, and the report of its length, angle and speed.
fn crack_report(request: &CrackArgs, registry: &Registry) -> Result<String, String> {
    let dir = request.out.as_path();
    let notch_tip = point3(&request.notch, "notch")?;
    let notch_direction = point3(&request.direction, "direction")?;
    let link = match request.link {
        Some(l) => l,
        None => crack::default_link(dir, request.thickness)?,
    };
    let options = crack::CrackOptions {
        notch_tip,
        notch_direction,
        damage_above: request.damage_above,
        link,
        angle_length: request
            .angle_length
            .unwrap_or(crack::DEFAULT_ANGLE_LINKS * link),
    };
    let history = crack::crack_history(dir, &options)?;
    let mut table = String::from("time,tip_x,tip_y,tip_z,length\n");
    for t in &history {
        let [x, y, z] = t.tip;
        table.push_str(&format!("{:e},{x:e},{y:e},{z:e},{:e}\n", t.time, t.length));
    }
    let path = dir.join("crack.csv");
    write_atomically(&path, table.as_bytes())
        .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    let length = history.last().map_or(0.0, |t| t.length);
    let mut report = format!(
        "crack length {} m (link {} m); wrote {}",
        num(length),
        num(link),
        path.display()
    );
    match crack::initial_angle(&history, &options) {
        Some(a) => report.push_str(&format!(
            "\ninitial angle {a:.1}° from the notch direction (at {} m of crack)",
            num(options.angle_length)
        )),
        None => report.push_str(&format!(
            "\nno initial angle: the crack never reached {} m",
            num(options.angle_length)
        )),
    }
    let rayleigh = request
        .scene
        .as_deref()
        .map(|s| scene_rayleigh_speed(s, request.material.as_deref(), registry))
        .transpose()?;
    report.push_str(&speed_report(&history, rayleigh));
    if let Some(window) = &request.window {
        report.push_str(&window_report(&history, window)?);
    }
    Ok(report)
}

/// The crack's speed over the window `[from, to]` of `--window`.
fn window_report(history: &[crack::TipAt], window: &[f64]) -> Result<String, String> {
    let &[from, to] = window else {
        return Err("--window takes two comma-separated times, FROM,TO".into());
    };
    if to <= from || to.is_nan() || from.is_nan() {
        return Err(format!("--window {from},{to}: TO must come after FROM"));
    }
    Ok(match crack::crack_speed_between(history, from, to) {
        Some(speed) => format!(
            "\ncrack speed {} m/s from {from:e} to {to:e} s (least squares over the frames \
             in the window)",
            num(speed)
        ),
        None => format!("\nno crack speed from {from:e} to {to:e} s: fewer than two frames there"),
    })
}

/// The crack speed lines of the report, against the Rayleigh speed when known.
fn speed_report(history: &[crack::TipAt], rayleigh: Option<(String, f64)>) -> String {
    match crack::crack_speed(history) {
        Some((mean, largest)) => {
            let mut report = format!(
                "\ncrack speed {} m/s (least squares over the growth), largest between \
                 frames {} m/s",
                num(mean),
                num(largest)
            );
            if let Some((name, c_r)) = rayleigh {
                report.push_str(&format!(
                    "\nRayleigh speed of {name}: {} m/s (crack speed {:.2} of it, \
                     largest {:.2})",
                    num(c_r),
                    mean / c_r,
                    largest / c_r
                ));
            }
            report
        }
        None => "\nno crack speed: the crack did not grow between frames".to_string(),
    }
}
