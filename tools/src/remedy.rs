//! The usual cures of a failed run, named in the report where the engine knows the cause.

use fractum_engine::health::Cause;

/// A sentence naming the usual cures of a failure of `cause` in a run whose pipeline holds the
/// systems `pipeline`; `None` where the cause says nothing a user can act on in general.
pub fn remedy(cause: Cause, pipeline: &[&str]) -> Option<String> {
    let linear = pipeline.contains(&"basis/linear");
    let smaller_step = "a smaller time step (a lower `Cfl` factor such as `Cfl(0.3)`, or a \
                        smaller `Fixed` step)";
    let gimp = "`basis/gimp` in place of `basis/linear` (with the linear tents a stressed \
                particle that crosses into an empty cell takes a runaway velocity; GIMP has no \
                such instability)";
    let runaway = if linear {
        format!("{gimp}, or {smaller_step}")
    } else {
        smaller_step.to_string()
    };
    match cause {
        Cause::Inverted => Some(format!(
            "the particle's material inverted (J <= 0) under more deformation than one step \
             can take; the usual cures: {runaway}"
        )),
        Cause::Runaway => Some(format!("the usual cures of a runaway: {runaway}")),
        Cause::LeftGrid => Some(format!(
            "the usual cures: a grid that reaches further, or `safety: (on_leave_grid: \
             Remove)` to drop such particles and go on; a particle much faster than the \
             scene's bodies is a runaway, cured by {runaway}"
        )),
        Cause::Other => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gimp_is_named_only_where_the_linear_tents_run() {
        let linear = remedy(Cause::Runaway, &["basis/linear", "predictor/usl"]).unwrap();
        assert!(
            linear.contains("basis/gimp") && linear.contains("Cfl(0.3)"),
            "{linear}"
        );
        let lme = remedy(Cause::Inverted, &["basis/lme"]).unwrap();
        assert!(
            !lme.contains("basis/gimp") && lme.contains("J <= 0"),
            "{lme}"
        );
        assert!(
            remedy(Cause::LeftGrid, &[])
                .unwrap()
                .contains("on_leave_grid: Remove")
        );
        assert_eq!(remedy(Cause::Other, &["basis/linear"]), None);
    }
}
