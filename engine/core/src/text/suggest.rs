//! "Did you mean …?": the known name nearest a misspelt one.

/// The candidate nearest `name` by edit distance (insertions, deletions, substitutions and
/// swaps of neighbours, ignoring case), if one is near enough to be a likely misspelling: at
/// most a third of the name's length, and at least one edit.
pub fn nearest<'a>(name: &str, candidates: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    let limit = (name.chars().count() / 3).max(1);
    candidates
        .into_iter()
        .map(|c| (edit_distance(&name.to_lowercase(), &c.to_lowercase()), c))
        .filter(|(d, _)| *d <= limit)
        .min_by_key(|(d, _)| *d)
        .map(|(_, c)| c)
}

/// ` (did you mean "x"?)` for the candidate nearest `name`, or nothing.
pub fn did_you_mean<'a>(name: &str, candidates: impl IntoIterator<Item = &'a str>) -> String {
    nearest(name, candidates)
        .map(|c| format!(" (did you mean \"{c}\"?)"))
        .unwrap_or_default()
}

/// Optimal-string-alignment distance between `a` and `b`, by characters.
fn edit_distance(a: &str, b: &str) -> usize {
    let (a, b): (Vec<char>, Vec<char>) = (a.chars().collect(), b.chars().collect());
    let mut rows = vec![vec![0usize; b.len() + 1]; a.len() + 1];
    for (i, row) in rows.iter_mut().enumerate() {
        row[0] = i;
    }
    for (j, cell) in rows[0].iter_mut().enumerate() {
        *cell = j;
    }
    for i in 1..=a.len() {
        for j in 1..=b.len() {
            let cost = usize::from(a[i - 1] != b[j - 1]);
            let mut best = (rows[i - 1][j] + 1)
                .min(rows[i][j - 1] + 1)
                .min(rows[i - 1][j - 1] + cost);
            if i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] {
                best = best.min(rows[i - 2][j - 2] + 1);
            }
            rows[i][j] = best;
        }
    }
    rows[a.len()][b.len()]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn suggests_the_nearest_name_within_a_third_of_its_length() {
        let systems = [
            "damage/rankine",
            "damage/eigenerosion",
            "stress/neo_hookean",
        ];
        assert_eq!(nearest("damage/rankin", systems), Some("damage/rankine"));
        assert_eq!(
            nearest("stress/neohookean", systems),
            Some("stress/neo_hookean")
        );
        assert_eq!(nearest("damage/rnakine", systems), Some("damage/rankine"));
        assert_eq!(nearest("contact/frictional", systems), None);
        assert_eq!(
            did_you_mean("stele", ["steel"]),
            " (did you mean \"steel\"?)"
        );
        assert_eq!(did_you_mean("glass", ["steel"]), "");
    }
}
