//! Convergence studies of the verification catalogue: one quantity measured by several cases
//! that differ only in their cell size, and the order of convergence the measurements show.
//!
//! - Against the reference (an analytic solution, a paper, an experiment): the error
//!   `e_i = m_i − r` of each run, and between successive runs the observed order
//!   `p = ln(|e_{i−1}| / |e_i|) / ln(h_{i−1} / h_i)`. It means something only where the
//!   reference is the limit the scheme converges to.
//! - Without a reference (Richardson): from the last three runs, at a constant refinement
//!   ratio `q = h₁/h₂ = h₂/h₃`, `p = ln((m₁ − m₂) / (m₂ − m₃)) / ln q` and the extrapolated
//!   limit `m₃ + (m₃ − m₂) / (q^p − 1)`: the order the runs show whatever they converge to,
//!   and where. Differences that change sign (the runs oscillate) have no order; differences
//!   that grow (a negative order) show no convergence, and no limit is given.

use super::catalogue::{Catalogue, Source, Study};
use super::record::{self, Results};
use std::fmt::Write as _;

/// Richardson's estimate from three runs at a constant refinement ratio.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Richardson {
    /// The observed order.
    pub order: f64,
    /// The extrapolated limit.
    pub limit: f64,
}

/// The observed order between successive runs from their errors against the reference:
/// `None` for the first run, and where an error is zero or not finite.
pub fn orders_against_reference(spacings: &[f64], errors: &[f64]) -> Vec<Option<f64>> {
    let mut orders = vec![None];
    for i in 1..errors.len().min(spacings.len()) {
        let (e0, e1) = (errors[i - 1].abs(), errors[i].abs());
        let order = (e0 / e1).ln() / (spacings[i - 1] / spacings[i]).ln();
        orders.push((e0 > 0.0 && e1 > 0.0 && order.is_finite()).then_some(order));
    }
    orders
}

/// Richardson's order and limit from the last three runs, when their spacings share one
/// ratio (to 1e-6) and their differences have one sign.
pub fn richardson(spacings: &[f64], values: &[f64]) -> Option<Richardson> {
    let n = values.len().min(spacings.len());
    if n < 3 {
        return None;
    }
    let (h, m) = (&spacings[n - 3..n], &values[n - 3..n]);
    let ratio = h[0] / h[1];
    if ((h[1] / h[2]) / ratio - 1.0).abs() > 1e-6 || ratio <= 1.0 {
        return None;
    }
    let quotient = (m[0] - m[1]) / (m[1] - m[2]);
    if !(quotient.is_finite() && quotient > 0.0) {
        return None;
    }
    let order = quotient.ln() / ratio.ln();
    let limit = m[2] + (m[2] - m[1]) / (ratio.powf(order) - 1.0);
    (order.is_finite() && limit.is_finite()).then_some(Richardson { order, limit })
}

/// The summary's section on the studies: a table per study and Richardson's line.
pub fn section(catalogue: &Catalogue, results: &Results) -> String {
    if catalogue.studies.is_empty() {
        return String::new();
    }
    let mut text = String::from(
        "\n## Convergence\n\nEach study holds one quantity over runs that refine the cell. \
         `error` is the measurement less the reference; `order` is the observed order between a \
         run and the one before, `ln(|e₁| / |e₂|) / ln(h₁ / h₂)`, meaningful where the reference \
         is the limit the runs converge to. Richardson's order and limit come from the last \
         three runs' differences alone, `p = ln((m₁ − m₂) / (m₂ − m₃)) / ln(h₁ / h₂)`.\n",
    );
    for study in &catalogue.studies {
        text.push_str(&study_table(catalogue, results, study));
    }
    text
}

fn study_table(catalogue: &Catalogue, results: &Results, study: &Study) -> String {
    let mut rows = Vec::new();
    let mut unit = "";
    let mut reference = None;
    for name in &study.cases {
        let Some(case) = catalogue.case(name) else {
            continue;
        };
        let Some(check) = case.checks.iter().find(|c| c.quantity == study.quantity) else {
            continue;
        };
        unit = &check.unit;
        if reference.is_none() && !matches!(check.source, Source::Case(_)) {
            reference = Some(check.reference);
        }
        rows.push(record::evaluate(catalogue, results, case, check).measured);
    }
    let mut text = format!(
        "\n### {}\n\n| case | h | measured | error | order |\n| --- | --- | --- | --- | --- |\n",
        study.title
    );
    let complete: Option<Vec<f64>> = rows.iter().copied().collect();
    let errors: Option<Vec<f64>> = match (&complete, reference) {
        (Some(values), Some(r)) => Some(values.iter().map(|m| m - r).collect()),
        _ => None,
    };
    let orders = errors
        .as_ref()
        .map(|e| orders_against_reference(&study.spacings, e))
        .unwrap_or_default();
    for (i, (name, measured)) in study.cases.iter().zip(&rows).enumerate() {
        let error = match (measured, reference) {
            (Some(m), Some(r)) => format!(
                "{} ({:+.2}%)",
                record::with_unit(Some(m - r), unit),
                100.0 * (m - r) / r
            ),
            _ => "—".into(),
        };
        let order = orders
            .get(i)
            .copied()
            .flatten()
            .map_or("—".into(), |p| format!("{p:.2}"));
        let _ = writeln!(
            text,
            "| [{name}](verification/{name}.md) | {} {} | {} | {error} | {order} |",
            record::sig(study.spacings[i]),
            study.spacing_unit,
            record::with_unit(*measured, unit),
        );
    }
    let line = match complete.as_deref().map(|v| richardson(&study.spacings, v)) {
        None => "Richardson: not every run measured.".to_string(),
        Some(None) => "Richardson: the last three runs' differences change sign (or the \
                       refinement ratio is not constant): no order."
            .to_string(),
        Some(Some(r)) if r.order <= 0.0 => format!(
            "Richardson over the last three runs: the differences grow (order {:.2}): no limit.",
            r.order
        ),
        Some(Some(r)) => {
            let against = reference.map_or(String::new(), |reference| {
                format!(
                    " ({:+.2}% from the reference)",
                    100.0 * (r.limit - reference) / reference
                )
            });
            format!(
                "Richardson over the last three runs: order {:.2}, limit {}{against}.",
                r.order,
                record::with_unit(Some(r.limit), unit)
            )
        }
    };
    let _ = writeln!(text, "\n{line}");
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Runs with error `C h²` show order 2 against the reference, and Richardson finds the
    /// order and the limit from the values alone.
    #[test]
    fn second_order_runs_show_order_two_both_ways() {
        let spacings = [0.4, 0.2, 0.1];
        let values: Vec<f64> = spacings.iter().map(|h| 3.0 + 5.0 * h * h).collect();
        let errors: Vec<f64> = values.iter().map(|v| v - 3.0).collect();
        let orders = orders_against_reference(&spacings, &errors);
        assert_eq!(orders[0], None);
        for p in &orders[1..] {
            assert!((p.unwrap() - 2.0).abs() < 1e-12, "{orders:?}");
        }
        let r = richardson(&spacings, &values).unwrap();
        assert!(
            (r.order - 2.0).abs() < 1e-9 && (r.limit - 3.0).abs() < 1e-12,
            "{r:?}"
        );
    }

    /// Oscillating runs, or a ratio that changes, give Richardson no order.
    #[test]
    fn oscillating_runs_or_an_uneven_refinement_have_no_richardson_order() {
        assert_eq!(richardson(&[0.4, 0.2, 0.1], &[1.0, 1.2, 1.1]), None);
        assert_eq!(richardson(&[0.4, 0.2, 0.05], &[1.0, 1.2, 1.3]), None);
        assert!(richardson(&[0.4, 0.2, 0.1], &[1.0, 1.2, 1.3]).is_some());
    }
}
