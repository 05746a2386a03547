//! `fractum verify` end to end: the quick tier passes (as CI requires), an unchanged case is not
//! run again, a case outside its tolerance fails by a stated amount, and a missing or invalid
//! scene is an error of its case while the other cases still run.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("fractum-verify-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn verify(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_fractum"))
        .arg("verify")
        .args(args)
        .current_dir(root())
        .output()
        .unwrap()
}

fn text(output: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    )
}

#[test]
fn the_quick_tier_passes_and_keeps_its_results() {
    let dir = scratch("quick");
    let (work, docs) = (dir.join("runs"), dir.join("docs"));
    let (work, docs) = (work.to_str().unwrap(), docs.to_str().unwrap());
    let first = verify(&[
        "--tier", "quick", "--jobs", "2", "--work", work, "--docs", docs,
    ]);
    let report = text(&first);
    assert_eq!(first.status.code(), Some(0), "{report}");
    let summary = std::fs::read_to_string(dir.join("docs/VERIFICATION.md")).unwrap();
    for case in [
        "bar_vibration",
        "tension_rankine",
        "edge_cracked_panel_lme",
        "griffith_h025",
    ] {
        assert!(report.contains(&format!("{case} ")), "{report}");
        assert!(
            summary.contains(&format!("[{case}](verification/{case}.md)")),
            "{summary}"
        );
        assert!(dir.join(format!("docs/verification/{case}.md")).exists());
    }
    // The panel's page shows its damage snapshot.
    let png = std::fs::read(dir.join("docs/verification/edge_cracked_panel_lme-2.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    // Unchanged: measured again from the kept runs, not run again.
    let second = verify(&["--tier", "quick", "--work", work, "--docs", docs]);
    let report = text(&second);
    assert_eq!(second.status.code(), Some(0), "{report}");
    assert!(!report.contains("starting"), "{report}");
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn an_unknown_case_lists_the_known_ones() {
    let dir = scratch("unknown");
    let out = verify(&["--case", "kalthof", "--docs", dir.to_str().unwrap()]);
    let report = text(&out);
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(out.status.code(), Some(2), "{report}");
    assert!(
        report.contains("no case \"kalthof\"") && report.contains("kalthoff_winkler_dfg"),
        "{report}"
    );
}

#[test]
fn bad_cases_are_reported_while_the_others_run() {
    let dir = scratch("bad");
    let scene = root().join("scenes/tension_rankine.ron");
    let invalid = root().join("tests/bad_scenes/unknown_material.ron");
    let case = |name: &str, scene: &Path, reference: f64| {
        format!(
            r#"(name: "{name}", title: "{name}", about: "", tier: Quick, scene: "{}", cost: 1.0,
               checks: [(quantity: "dissipated energy", unit: "mJ", measure: Dissipated, scale: 1000.0,
                         reference: {reference}, source: Analytic("A G_f"), tolerance: Relative(0.05))])"#,
            scene.display()
        )
    };
    let catalogue = format!(
        "(cases: [{}, {}, {}, {}])",
        case("good", &scene, 2.525),
        case("off", &scene, 2.0),
        case("missing", &dir.join("nowhere.ron"), 2.525),
        case("invalid", &invalid, 2.525),
    );
    std::fs::write(dir.join("catalogue.ron"), catalogue).unwrap();
    let path = |p: &str| dir.join(p).to_str().unwrap().to_string();
    let out = verify(&[
        "--catalogue",
        &path("catalogue.ron"),
        "--jobs",
        "2",
        "--work",
        &path("runs"),
        "--docs",
        &path("docs"),
    ]);
    let report = text(&out);
    assert_eq!(out.status.code(), Some(6), "{report}");
    let line = |case: &str| {
        report
            .lines()
            .find(|l| {
                l.starts_with(case)
                    && !l.contains("starting")
                    && !l.contains("measured")
                    && !l.contains("ERROR the")
            })
            .unwrap_or("")
            .to_string()
    };
    assert!(line("good").contains("pass"), "{report}");
    assert!(
        line("off").contains("FAIL") && line("off").contains("beyond the tolerance"),
        "{report}"
    );
    assert!(
        line("missing").contains("cannot read the scene"),
        "{report}"
    );
    assert!(line("invalid").contains("unknown material"), "{report}");
    std::fs::remove_dir_all(dir).unwrap();
}
