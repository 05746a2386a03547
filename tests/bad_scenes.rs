//! The bad-scene corpus: every file in `tests/bad_scenes/` holds one mistake and declares, on its
//! first line, where the error must point and what it must say:
//! `// expect at LINE:COL: message fragment`.

use fractum_suite::{load, ron_files};

fn expectation(text: &str) -> (String, String) {
    let first = text.lines().next().unwrap_or_default();
    let rest = first
        .strip_prefix("// expect at ")
        .unwrap_or_else(|| panic!("first line must be `// expect at L:C: message`, got {first:?}"));
    let (location, message) = rest.split_once(": ").expect("`L:C: message`");
    (location.to_string(), message.to_string())
}

#[test]
fn every_bad_scene_fails_at_its_declared_place_with_its_declared_message() {
    let files = ron_files("tests/bad_scenes");
    let mut failures = Vec::new();
    for path in &files {
        let text = std::fs::read_to_string(path).unwrap();
        let (location, message) = expectation(&text);
        match load(path) {
            Ok(_) => failures.push(format!("{}: loaded without error", path.display())),
            Err(e) => {
                let shown = e.to_string();
                let prefix = format!("{}:{location}: ", path.display());
                if !shown.starts_with(&prefix) || !shown.contains(&message) {
                    failures.push(format!(
                        "{}\n  expected `{prefix}…{message}…`\n  got      `{shown}`",
                        path.display()
                    ));
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn corpus_covers_the_mistakes_users_make() {
    let names: Vec<String> = ron_files("tests/bad_scenes")
        .iter()
        .map(|p| p.file_stem().unwrap().to_string_lossy().into_owned())
        .collect();
    for required in [
        "unknown_system",
        "misspelt_field",
        "wrong_type",
        "missing_stage",
        "unknown_material",
        "body_outside_grid",
        "unstable_dt",
        "mixed_coordinates",
        "grid_corners_disagree",
        "shape_3d_in_2d_scene",
        "shape_2d_in_3d_scene",
        "z_axis_in_2d_scene",
        "thickness_in_3d_scene",
        "overlapping_bodies",
        "mesh_truncated",
        "mesh_truncated_binary",
        "mesh_wrong_count",
        "mesh_nan_coordinate",
        "mesh_unknown_element_type",
        "mesh_inverted_element",
        "mesh_unknown_physical",
        "mesh_unknown_boundary_group",
        "points_missing_volume",
        "points_nan_coordinate",
        "points_duplicate_position",
        "points_vtu_appended",
        "points_vtu_missing_volume",
        "image_no_voxel_in_any_phase",
        "image_truncated",
        "image_colour",
        "image_pages_differ",
        "image_missing_slice",
        "image_overlapping_windows",
    ] {
        assert!(
            names.iter().any(|n| n == required),
            "missing bad scene {required}"
        );
    }
}
