//! `fractum curve`: the peak of a load curve and the linearity of its rise.

use crate::{EXIT_BAD_SCENE, plot};
use std::path::Path;

pub(crate) fn curve_command(csv: &Path, x: &str, y: &str, from: f64) -> i32 {
    let result = (|| {
        let series = plot::Series::read(csv)?;
        let (xs, ys) = (series.column(x)?, series.column(y)?);
        plot::curve_summary(&xs, &ys, from)
            .ok_or_else(|| "too few points before the peak".to_string())
    })();
    match result {
        Ok(s) => {
            outln!(
                "peak {y} = {:.6e} at {x} = {:.6e}\npre-peak slope {:.6e}, RMS deviation from the line {:.6e} ({:.2}% of the peak)",
                s.peak,
                s.x_at_peak,
                s.slope,
                s.rms_deviation,
                100.0 * s.rms_deviation / s.peak.abs()
            );
            let percent = 100.0 * plot::FALLEN_FRACTION;
            match s.fall {
                Some(fall) => {
                    outln!("falls below {percent}% of the peak {fall:.6e} in {x} after it")
                }
                None => outln!("does not fall below {percent}% of the peak"),
            }
            0
        }
        Err(e) => {
            eprintln!("error: {e}");
            EXIT_BAD_SCENE
        }
    }
}
