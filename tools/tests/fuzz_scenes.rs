//! A fuzz target that stays: shipped scenes mutated as a user's typos and extremes would
//! (numbers swapped for extremes or scaled by a wrong factor, characters and lines dropped or
//! doubled, names swapped, files cut short), each checked and, when accepted, run for five
//! steps by the real binary. Half the mutations change only a number, so most of those scenes
//! still read and the run itself is tried.
//!
//! - `fractum check` never panics or aborts: it exits 0, or 1 with `file:line:col`;
//! - a run of an accepted scene exits 0 with only finite numbers in `series.csv`, or 3 with a
//!   message naming the step, the stage and a particle or node.
//!
//! `PROPTEST_CASES` sets the number of mutated scenes (256 by default here).

use crate::support::{root, text};
use proptest::prelude::*;
use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// Small shipped scenes of every kind of pipeline (2D and 3D, USL and Newmark, LME, damage,
/// contact, partitioning) and of shape (a boolean difference in `plate_with_hole`, an STL
/// surface in `spinning_sphere`, Gmsh meshes and boundary groups in `two_disks_mesh` and
/// `plate_with_hole_mesh`, a particle file in `two_disks_points`).
const SEEDS: [&str; 15] = [
    "two_disks.ron",
    "two_disks_contact.ron",
    "tension_softening.ron",
    "tension_rankine.ron",
    "time_to_failure_strip.ron",
    "sliding_block.ron",
    "bar_vibration.ron",
    "bar_vibration_graded.ron",
    "bar_vibration_3d.ron",
    "block_compression.ron",
    "plate_with_hole.ron",
    "spinning_sphere.ron",
    "two_disks_mesh.ron",
    "plate_with_hole_mesh.ron",
    "two_disks_points.ron",
];

/// Mesh files of each format a `Mesh` shape reads (Gmsh ASCII and binary, GiD), each filling
/// part of the unit square, particle files (CSV, meshio's VTU) and images (PNG, TIFF), mutated
/// under [`MESH_SCENE`].
const MESH_SEEDS: [&str; 7] = [
    "scenes/geometry/two_disks.msh",
    "tests/fixtures/meshes/disk_binary.msh",
    "tests/fixtures/meshes/nl-partsol/MPM_Mesh.msh",
    "scenes/geometry/two_disks_particles.csv",
    "tests/fixtures/points/two_disks_meshio.vtu",
    "tests/fixtures/images/disk.png",
    "tests/fixtures/images/disk_16bit.tif",
];

/// A small 2D scene whose one body is the mutated file: `SHAPE` is `Mesh(file: "fuzzed.msh",
/// seeding: ..)`, `Points("fuzzed.csv")` (or `.vtu`) or `Image(file: "fuzzed.png", ..)` (or
/// `.tif`).
const MESH_SCENE: &str = r#"(
    time: (step: Fixed(1.0e-3), end: Steps(5)),
    grid: (min: (0.0, 0.0), max: (1.0, 1.0), spacing: 0.05),
    materials: {"elastic": (density: 1000.0, youngs_modulus: 1000.0, poisson_ratio: 0.3)},
    bodies: [(shape: SHAPE, material: "elastic", particles_per_cell: 1)],
    pipeline: [
        (system: "basis/linear"),
        (system: "predictor/usl"),
        (system: "stress/linear_elastic"),
        (system: "advection/usl"),
    ],
)"#;

/// Values a number is swapped for: zero, signs, the edges of f64, huge counts.
const EXTREMES: [&str; 14] = [
    "0.0",
    "-1.0",
    "1e-320",
    "1e300",
    "-1e300",
    "NaN",
    "inf",
    "1e-300",
    "16",
    "4294967296",
    "0.5",
    "1e8",
    "2",
    "-0.0",
];

/// Characters a typo inserts.
const TYPOS: [char; 12] = [',', '(', ')', '"', ':', '[', ']', 'x', '.', '-', '{', '0'];

/// Memory a mutated scene may ask for in this test (so no case can take the machine's).
const MEMORY_LIMIT: &str = "2e9";

/// Byte ranges of the numeric literals in `text`.
fn numbers(text: &str) -> Vec<(usize, usize)> {
    let bytes = text.as_bytes();
    let mut found = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        let starts = bytes[i].is_ascii_digit()
            && (i == 0 || !(bytes[i - 1].is_ascii_alphanumeric() || bytes[i - 1] == b'_'));
        if starts {
            let start = if i > 0 && bytes[i - 1] == b'-' {
                i - 1
            } else {
                i
            };
            let mut end = i;
            while end < bytes.len()
                && (bytes[end].is_ascii_digit()
                    || matches!(bytes[end], b'.' | b'e' | b'E')
                    || (matches!(bytes[end], b'-' | b'+') && matches!(bytes[end - 1], b'e' | b'E')))
            {
                end += 1;
            }
            found.push((start, end));
            i = end;
        } else {
            i += 1;
        }
    }
    found
}

/// Byte ranges of the words (names, identifiers) in `text`.
fn words(text: &str) -> Vec<(usize, usize)> {
    let bytes = text.as_bytes();
    let mut found = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        let inside_number = i > 0 && (bytes[i - 1].is_ascii_digit() || bytes[i - 1] == b'.');
        if bytes[i].is_ascii_alphabetic() && !inside_number {
            let start = i;
            while i < bytes.len() && (bytes[i].is_ascii_alphanumeric() || bytes[i] == b'_') {
                i += 1;
            }
            found.push((start, i));
        } else {
            i += 1;
        }
    }
    found
}

fn floor_boundary(text: &str, mut at: usize) -> usize {
    at = at.min(text.len());
    while !text.is_char_boundary(at) {
        at -= 1;
    }
    at
}

/// Factors a number is scaled by: a digit too many or too few, a wrong prefix, a sign.
const SCALES: [f64; 8] = [10.0, 0.1, 1e3, 1e-3, 1e6, 1e-6, -1.0, 1e12];

/// `value` scaled by `factor`, written as RON reads it (an integer stays one while it fits).
fn scaled(value: &str, factor: f64) -> String {
    let Ok(x) = value.parse::<f64>() else {
        return value.to_string();
    };
    let y = x * factor;
    let integer = !value.contains(['.', 'e', 'E']);
    if integer && y.fract() == 0.0 && y.abs() < 1e15 {
        format!("{}", y as i64)
    } else {
        format!("{y:?}")
    }
}

/// One mutation of `text`: `kind` picks what, `at` where, `pick` with what. Half the kinds
/// change a number (an extreme, or the number scaled) and leave the scene readable, so that
/// the run, not only the reader, is tried; the rest are typos and cuts.
fn mutate(text: &str, kind: u8, at: usize, pick: usize) -> String {
    let mut out = text.to_string();
    let spans = numbers(text);
    let number = || spans.get(at % spans.len().max(1)).copied();
    match kind % 12 {
        0..=2 => {
            if let Some((a, b)) = number() {
                out.replace_range(a..b, EXTREMES[pick % EXTREMES.len()]);
            }
        }
        3..=5 => {
            if let Some((a, b)) = number() {
                out.replace_range(a..b, &scaled(&text[a..b], SCALES[pick % SCALES.len()]));
            }
        }
        6 => {
            let a = floor_boundary(text, at % text.len().max(1));
            let b = floor_boundary(text, a + 1 + pick % 3);
            out.replace_range(a..b.max(a), "");
        }
        7 => {
            let a = floor_boundary(text, at % text.len().max(1));
            out.insert(a, TYPOS[pick % TYPOS.len()]);
        }
        8 | 9 => {
            let lines: Vec<&str> = text.lines().collect();
            let k = at % lines.len().max(1);
            let mut edited: Vec<&str> = lines.clone();
            if kind % 12 == 8 {
                edited.insert(k, lines[k]);
            } else {
                edited.remove(k);
            }
            out = edited.join("\n");
        }
        10 => {
            let spans = words(text);
            if !spans.is_empty() {
                let (a, b) = spans[at % spans.len()];
                let (c, d) = spans[pick % spans.len()];
                out.replace_range(a..b, &text[c..d]);
            }
        }
        _ => out.truncate(floor_boundary(text, at % text.len().max(1))),
    }
    out
}

/// Runs the binary with a deadline; a run that outlives it is a hang.
fn fractum(args: &[&str], dir: &Path) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_fractum"))
        .args(args)
        .current_dir(dir)
        .env("FRACTUM_MEMORY_LIMIT", MEMORY_LIMIT)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the fractum binary runs");
    let started = Instant::now();
    while child.try_wait().expect("wait").is_none() {
        if started.elapsed() > Duration::from_secs(300) {
            let _ = child.kill();
            panic!("fractum {args:?} hung");
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    child.wait_with_output().expect("output")
}

/// Whether `message` points at `file:line:col`.
fn placed(message: &str, file: &str) -> bool {
    let Some(rest) = message.strip_prefix(&format!("error: {file}:")) else {
        return false;
    };
    let mut parts = rest.splitn(3, ':');
    let line = parts.next().is_some_and(|l| l.parse::<u32>().is_ok());
    let col = parts.next().is_some_and(|c| c.parse::<u32>().is_ok());
    line && col
}

/// How a mutated scene fared, when it fared well.
#[derive(Debug)]
enum Outcome {
    /// `check` refused it with a place; the message.
    Refused(String),
    /// It ran five steps with finite results.
    Ran,
    /// The run stopped with a named particle or node.
    Stopped,
}

impl Outcome {
    /// One line for the log: the outcome, and for a refusal the message.
    fn describe(&self) -> String {
        match self {
            Outcome::Refused(message) => format!("Refused {}", message.replace('\n', " ")),
            Outcome::Ran => "Ran".into(),
            Outcome::Stopped => "Stopped".into(),
        }
    }
}

/// Appends the outcome to the file `FRACTUM_FUZZ_LOG` names, if any (for counting them).
fn log(seed: &str, outcome: &Result<Outcome, String>) {
    if let Ok(path) = std::env::var("FRACTUM_FUZZ_LOG") {
        use std::io::Write;
        if let Ok(mut file) = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(path)
        {
            let line = match outcome {
                Ok(o) => o.describe(),
                Err(e) => format!("Failed {}", e.replace('\n', " ")),
            };
            let _ = writeln!(file, "{seed} {line}");
        }
    }
}

/// Checks and (when accepted) runs one mutated scene; returns what went wrong, if anything.
fn try_scene(dir: &Path, scene: &str) -> Result<Outcome, String> {
    std::fs::write(dir.join("fuzz.ron"), scene).unwrap();
    let check = fractum(&["check", "fuzz.ron"], dir);
    // The estimate from counts takes the same input through the same checks up to spawning:
    // it refuses with a place or reports, never panics, and passes what `check` passes.
    let estimate = fractum(&["check", "--estimate", "fuzz.ron"], dir);
    match (estimate.status.code(), check.status.code()) {
        (Some(0), _) | (Some(1), Some(1)) => {}
        (code, checked) => {
            return Err(format!(
                "check --estimate exited {code:?} where check exited {checked:?}: {}",
                text(&estimate.stderr)
            ));
        }
    }
    if estimate.status.code() == Some(1)
        && !text(&estimate.stdout).contains("does not fit")
        && !placed(&text(&estimate.stderr), "fuzz.ron")
    {
        return Err(format!(
            "check --estimate's error has no file:line:col: {}",
            text(&estimate.stderr)
        ));
    }
    match check.status.code() {
        Some(0) => {}
        Some(1) => {
            let message = text(&check.stderr);
            return if placed(&message, "fuzz.ron") {
                Ok(Outcome::Refused(message.trim().to_string()))
            } else {
                Err(format!("check's error has no file:line:col: {message}"))
            };
        }
        code => return Err(format!("check exited {code:?}: {}", text(&check.stderr))),
    }
    let run = fractum(
        &[
            "run",
            "fuzz.ron",
            "--steps",
            "5",
            "--out",
            "out",
            "--force",
            "--quiet",
            "--threads",
            "1",
        ],
        dir,
    );
    match run.status.code() {
        Some(0) => {
            let series = std::fs::read_to_string(dir.join("out/series.csv"))
                .map_err(|e| format!("no series.csv: {e}"))?;
            // A `Track` probe reads NaN by design once its particle has left the grid.
            let header: Vec<&str> = series
                .lines()
                .next()
                .unwrap_or_default()
                .split(',')
                .collect();
            for line in series.lines().skip(1) {
                let broken = line.split(',').zip(&header).any(|(v, name)| {
                    !name.starts_with("track_") && !v.parse::<f64>().is_ok_and(f64::is_finite)
                });
                if broken {
                    return Err(format!("a non-finite value in series.csv: {line}"));
                }
            }
            Ok(Outcome::Ran)
        }
        Some(3) => {
            let message = text(&run.stderr);
            let named = message.contains("step ")
                && message.contains("stage ")
                && (message.contains("particle") || message.contains("node"));
            if named {
                Ok(Outcome::Stopped)
            } else {
                Err(format!(
                    "exit 3 without step, stage and particle: {message}"
                ))
            }
        }
        code => Err(format!("run exited {code:?}: {}", text(&run.stderr))),
    }
}

fn seeds() -> Vec<String> {
    SEEDS
        .iter()
        .map(|s| std::fs::read_to_string(root().join("scenes").join(s)).unwrap())
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: std::env::var("PROPTEST_CASES").ok().and_then(|c| c.parse().ok()).unwrap_or(256),
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    #[test]
    fn mutated_scenes_are_refused_with_a_place_or_run_cleanly(
        seed in 0..SEEDS.len(),
        mutations in prop::collection::vec((any::<u8>(), any::<usize>(), any::<usize>()), 1..3),
    ) {
        let seeds = seeds();
        let mut scene = seeds[seed].clone();
        for (kind, at, pick) in mutations {
            scene = mutate(&scene, kind, at, pick);
        }
        let dir = std::env::temp_dir().join(format!("fractum-fuzz-{}", std::process::id()));
        // The geometry files the shipped scenes name, beside the mutated scene.
        let geometry = dir.join("geometry");
        std::fs::create_dir_all(&geometry).unwrap();
        for file in std::fs::read_dir(root().join("scenes/geometry")).unwrap() {
            let file = file.unwrap();
            std::fs::copy(file.path(), geometry.join(file.file_name())).unwrap();
        }
        let outcome = try_scene(&dir, &scene);
        log(SEEDS[seed], &outcome);
        // A failing case's folder stays for a look; the others leave nothing behind.
        if outcome.is_ok() {
            let _ = std::fs::remove_dir_all(&dir);
        }
        prop_assert!(outcome.is_ok(), "{}\n--- scene from {} ---\n{scene}", outcome.unwrap_err(), SEEDS[seed]);
    }
}

/// One mutation of a mesh file: a text file as a scene's text is mutated; a binary one cut
/// short, or with one byte or one 8-byte value overwritten (by an extreme double).
fn mutate_mesh(bytes: &[u8], kind: u8, at: usize, pick: usize) -> Vec<u8> {
    if let Ok(text) = std::str::from_utf8(bytes) {
        return mutate(text, kind, at, pick).into_bytes();
    }
    let mut out = bytes.to_vec();
    let at = at % bytes.len().max(1);
    match kind % 3 {
        0 => out.truncate(at),
        1 => out[at] = pick as u8,
        _ => {
            let extreme = [f64::NAN, f64::INFINITY, 1e308, -1.0, 0.0][pick % 5];
            let end = (at + 8).min(out.len());
            out[at..end].copy_from_slice(&extreme.to_le_bytes()[..end - at]);
        }
    }
    out
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: std::env::var("PROPTEST_CASES").ok().and_then(|c| c.parse().ok()).unwrap_or(256) / 4,
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    #[test]
    fn mutated_meshes_and_particle_files_are_refused_with_a_place_or_run_cleanly(
        seed in 0..MESH_SEEDS.len(),
        elements in any::<bool>(),
        mutations in prop::collection::vec((any::<u8>(), any::<usize>(), any::<usize>()), 1..3),
    ) {
        let mut mesh = std::fs::read(root().join(MESH_SEEDS[seed])).unwrap();
        for (kind, at, pick) in mutations {
            mesh = mutate_mesh(&mesh, kind, at, pick);
        }
        let dir = std::env::temp_dir().join(format!("fractum-fuzz-mesh-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let seeding = if elements { "Elements" } else { "Grid" };
        let extension = MESH_SEEDS[seed].rsplit('.').next().unwrap_or_default();
        let shape = if extension == "png" || extension == "tif" {
            std::fs::write(dir.join(format!("fuzzed.{extension}")), &mesh).unwrap();
            format!(
                "Image(file: \"fuzzed.{extension}\", voxel_size: 0.025, phases: [(grey_min: 100, \
                 grey_max: 70000)])"
            )
        } else if extension != "msh" {
            std::fs::write(dir.join(format!("fuzzed.{extension}")), &mesh).unwrap();
            format!("Points(\"fuzzed.{extension}\")")
        } else {
            std::fs::write(dir.join("fuzzed.msh"), &mesh).unwrap();
            format!("Mesh(file: \"fuzzed.msh\", seeding: {seeding})")
        };
        let outcome = try_scene(&dir, &MESH_SCENE.replace("SHAPE", &shape));
        log(MESH_SEEDS[seed], &outcome);
        if outcome.is_ok() {
            let _ = std::fs::remove_dir_all(&dir);
        }
        prop_assert!(outcome.is_ok(), "{}\n--- mesh from {} ({seeding}) kept in {} ---", outcome.unwrap_err(), MESH_SEEDS[seed], dir.display());
    }
}

/// The mutations themselves: each kind changes the text as described.
#[test]
fn mutations_find_numbers_and_words() {
    let text = "(a: 1.5e-3, b: -2, c_d: x3)";
    let spans: Vec<&str> = numbers(text).iter().map(|&(a, b)| &text[a..b]).collect();
    assert_eq!(spans, ["1.5e-3", "-2"]);
    let names: Vec<&str> = words(text).iter().map(|&(a, b)| &text[a..b]).collect();
    assert_eq!(names, ["a", "b", "c_d", "x3"]);
    assert_eq!(mutate(text, 0, 1, 3), "(a: 1.5e-3, b: 1e300, c_d: x3)");
    assert_eq!(mutate(text, 3, 1, 2), "(a: 1.5e-3, b: -2000, c_d: x3)");
    assert_eq!(mutate(text, 4, 0, 6), "(a: -0.0015, b: -2, c_d: x3)");
    assert_eq!(mutate(text, 11, 3, 0), "(a:");
}
