//! Contact stage: interactions between the velocity fields of a node.

pub mod frictional;
pub mod frictional_law;
pub mod penalty;
pub mod penalty_faces;
pub mod penalty_law;
pub mod penalty_pairs;

use fractum_engine::prelude::*;
use frictional_law::PairFriction;

/// Every pair names groups some body belongs to, once, with μ >= 0.
pub fn check_pairs(
    installer: &mut Installer,
    params: &Params,
    pairs: &[PairFriction],
) -> Result<(), SceneError> {
    let mut groups: Vec<u8> = installer
        .world()
        .iter_entities()
        .filter_map(|e| e.get::<ContactGroup>().map(|g| g.0))
        .collect();
    groups.sort_unstable();
    groups.dedup();
    let listed = groups
        .iter()
        .map(|g| g.to_string())
        .collect::<Vec<_>>()
        .join(", ");
    for (k, pair) in pairs.iter().enumerate() {
        for group in [pair.groups.0, pair.groups.1] {
            if groups.binary_search(&group).is_err() {
                return Err(params.error(
                    &format!("pairs[{k}].groups"),
                    format!(
                        "unknown contact group {group}: the bodies' contact groups are {listed}"
                    ),
                ));
            }
        }
        params.require_non_negative(
            &format!("pairs[{k}].friction"),
            pair.friction,
            "expected a friction coefficient μ >= 0",
        )?;
        let (a, b) = pair.groups;
        if pairs[..k]
            .iter()
            .any(|p| p.groups == (a, b) || p.groups == (b, a))
        {
            return Err(params.error(
                &format!("pairs[{k}].groups"),
                format!("groups ({a}, {b}) are listed twice"),
            ));
        }
    }
    Ok(())
}
