//! ARCHITECTURE.md's floors of crates, held against the crates' manifests: every workspace
//! member stands on exactly one floor, and each of its Fractum dependencies (normal and build,
//! not dev) stands on a floor below it. The map in the document cannot drift from the crate
//! graph the compiler enforces. The same for the floors of the core's modules, held against
//! the `crate::` paths of its source (tests aside).

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

/// The floor of each module of the core, from ARCHITECTURE.md's numbered list under "Its
/// modules form floors": the backticked names of each item, leaving out what its parentheses
/// say.
fn documented_core_floors() -> BTreeMap<String, usize> {
    let text = std::fs::read_to_string(repo_root().join("ARCHITECTURE.md")).unwrap();
    let block = text
        .split("Its modules form floors")
        .nth(1)
        .and_then(|rest| rest.split("- **engine/geometry**").next())
        .expect("ARCHITECTURE.md lists the core's floors");
    let mut floors = BTreeMap::new();
    let mut floor = None;
    // Parentheses may run over a line's end.
    let mut depth = 0usize;
    for line in block.lines().map(str::trim) {
        if let Some((number, _)) = line.split_once(". ")
            && let Ok(number) = number.parse::<usize>()
        {
            floor = Some(number);
        }
        let Some(floor) = floor else { continue };
        let outside: String = line
            .chars()
            .filter(|&c| {
                match c {
                    '(' => depth += 1,
                    ')' => depth = depth.saturating_sub(1),
                    _ => return depth == 0,
                }
                false
            })
            .collect();
        for name in outside.split('`').skip(1).step_by(2) {
            let earlier = floors.insert(name.to_string(), floor);
            assert!(earlier.is_none(), "{name} stands on two floors of the core");
        }
    }
    floors
}

/// Every `.rs` file under `dir`.
fn rust_files(dir: &std::path::Path) -> Vec<std::path::PathBuf> {
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            files.extend(rust_files(&path));
        } else if path.extension().is_some_and(|e| e == "rs") {
            files.push(path);
        }
    }
    files
}

#[test]
fn every_module_of_the_core_imports_only_from_floors_below_it() {
    let floors = documented_core_floors();
    assert!(floors.len() > 20, "the scanner read {floors:?}");
    let src = repo_root().join("engine/core/src");
    // A set: a line that names a module twice says so once.
    let mut wrong = std::collections::BTreeSet::new();
    let mut modules = std::collections::BTreeSet::new();
    for file in rust_files(&src) {
        let relative = file.strip_prefix(&src).unwrap();
        let first = relative.iter().next().unwrap().to_string_lossy();
        let module = first.trim_end_matches(".rs").to_string();
        if module == "lib" {
            continue;
        }
        let Some(&floor) = floors.get(&module) else {
            wrong.insert(format!("{module} is on no floor of ARCHITECTURE.md"));
            continue;
        };
        modules.insert(module.clone());
        let text = std::fs::read_to_string(&file).unwrap();
        let code = text.split("\n#[cfg(test)]").next().unwrap();
        let lines = code.lines().filter(|l| !l.trim_start().starts_with("//"));
        for line in lines {
            for (at, _) in line.match_indices("crate::") {
                let name: String = line[at + "crate::".len()..]
                    .chars()
                    .take_while(|c| c.is_alphanumeric() || *c == '_')
                    .collect();
                if let Some(&other) = floors.get(&name)
                    && name != module
                    && other >= floor
                {
                    wrong.insert(format!(
                        "{} (floor {floor}) imports {name} (floor {other})",
                        relative.display()
                    ));
                }
            }
        }
    }
    for listed in floors.keys() {
        if !modules.contains(listed) {
            wrong.insert(format!(
                "ARCHITECTURE.md lists {listed}, which is no module of the core"
            ));
        }
    }
    assert!(wrong.is_empty(), "{wrong:#?}");
}
