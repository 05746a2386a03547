//! ARCHITECTURE.md's floors of crates, held against the crates' manifests: every workspace
//! member stands on exactly one floor, and each of its Fractum dependencies (normal and build,
//! not dev) stands on a floor below it. The map in the document cannot drift from the crate
//! graph the compiler enforces.

use fractum_suite::repo_root;
use std::collections::BTreeMap;

/// Floor number of each crate, from the ```floors block of ARCHITECTURE.md (`N: a, b`).
fn documented_floors() -> BTreeMap<String, usize> {
    let text = std::fs::read_to_string(repo_root().join("ARCHITECTURE.md")).unwrap();
    let block = text
        .split("```floors\n")
        .nth(1)
        .and_then(|rest| rest.split("```").next())
        .expect("ARCHITECTURE.md has a ```floors block");
    let mut floors = BTreeMap::new();
    for line in block.lines().filter(|l| !l.trim().is_empty()) {
        let (floor, crates) = line
            .split_once(':')
            .unwrap_or_else(|| panic!("floor line `{line}`: expected `N: crate, crate`"));
        let floor: usize = floor.trim().parse().unwrap();
        for name in crates.split(',').map(str::trim) {
            let earlier = floors.insert(name.to_string(), floor);
            assert!(earlier.is_none(), "{name} stands on two floors");
        }
    }
    floors
}

/// The workspace's members (paths relative to the root), from the root manifest.
fn members() -> Vec<String> {
    let text = std::fs::read_to_string(repo_root().join("Cargo.toml")).unwrap();
    let list = text
        .split("members = [")
        .nth(1)
        .and_then(|rest| rest.split(']').next())
        .unwrap();
    let mut members: Vec<String> = list
        .split(',')
        .map(|m| m.trim().trim_matches('"').to_string())
        .filter(|m| !m.is_empty())
        .collect();
    members.push(".".to_string());
    members
}

/// A manifest's package name and the `fractum-*` crates it depends on outside
/// `[dev-dependencies]` (dependencies of every target, build dependencies).
fn package_and_dependencies(member: &str) -> (String, Vec<String>) {
    let text = std::fs::read_to_string(repo_root().join(member).join("Cargo.toml")).unwrap();
    let mut name = None;
    let mut section = String::new();
    let mut dependencies = Vec::new();
    for line in text.lines().map(str::trim) {
        if line.starts_with('[') {
            section = line.to_string();
            continue;
        }
        if section == "[package]"
            && let Some(value) = line.strip_prefix("name = ")
        {
            name = Some(value.trim_matches('"').to_string());
        }
        let counts = section.ends_with("dependencies]") && !section.contains("dev-dependencies");
        if counts && line.starts_with("fractum-") {
            let crate_name = line.split(['=', '.', ' ']).next().unwrap();
            dependencies.push(crate_name.to_string());
        }
    }
    (name.unwrap(), dependencies)
}

#[test]
fn every_crate_depends_only_on_crates_below_it() {
    let floors = documented_floors();
    let mut seen = Vec::new();
    for member in members() {
        let (name, dependencies) = package_and_dependencies(&member);
        let floor = *floors
            .get(&name)
            .unwrap_or_else(|| panic!("{name} ({member}) is on no floor of ARCHITECTURE.md"));
        for dependency in dependencies {
            let below = floors[&dependency];
            assert!(
                below < floor,
                "{name} (floor {floor}) depends on {dependency} (floor {below}): every arrow \
                 points down"
            );
        }
        seen.push(name);
    }
    for name in floors.keys() {
        assert!(
            seen.contains(name),
            "ARCHITECTURE.md lists {name}, which is no workspace member"
        );
    }
}

#[test]
fn the_systems_and_the_geometry_stand_on_the_core_alone() {
    let (_, systems) = package_and_dependencies("systems");
    assert_eq!(
        systems,
        ["fractum-engine"],
        "systems depends on the core only"
    );
    let (_, geometry) = package_and_dependencies("engine/geometry");
    assert!(geometry.is_empty(), "geometry depends on no Fractum crate");
    let text = std::fs::read_to_string(repo_root().join("engine/geometry/Cargo.toml")).unwrap();
    assert!(!text.contains("bevy_ecs"), "geometry knows no ECS");
}
