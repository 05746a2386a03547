//! VTK's own reader (the `vtk` package of Python, the library ParaView is built on) reads every
//! kind of frame Fractum writes, zlib-compressed and not, and finds in it exactly the values
//! Fractum's own reader finds.
//!
//! The test needs Python with `vtk`, so it is built only with the `vtk-reader` feature and plain
//! `cargo test` leaves it out; `.ci/run` installs the package into a virtual environment and
//! runs it with `FRACTUM_VTK_PYTHON` naming that interpreter:
//!
//! ```text
//! python3 -m venv target/vtk-venv && target/vtk-venv/bin/pip install vtk
//! FRACTUM_VTK_PYTHON=target/vtk-venv/bin/python cargo test --features vtk-reader --test vtk_reader
//! ```

use fractum_engine::simulation::End;
use fractum_io::output::{
    FrameCompression, OutputPlan, ParticleFrame, read_particle_frame, write_particle_frame,
};
use fractum_io::run::run;
use fractum_suite::{load, repo_root, temp_dir};
use std::path::{Path, PathBuf};

/// Runs `scene` for two steps with a particle (and grid) frame every step into `out`.
fn frames_of(scene: &str, out: &Path, compression: FrameCompression, fields: Option<&[&str]>) {
    let path = repo_root().join("scenes").join(scene);
    let mut built = load(&path).unwrap_or_else(|e| panic!("{e}"));
    built.simulation.set_end(End::Steps(2));
    let plan = OutputPlan {
        vtu_every: 1,
        grid_every: 1,
        compression,
        frame_fields: fields.map(|f| f.iter().map(|s| s.to_string()).collect()),
        ..built.output.clone()
    };
    run(&mut built.simulation, &plan, out, |_| {}).unwrap_or_else(|e| panic!("{scene}: {e}"));
}

/// The frames under `dir`, sorted.
fn vtu_files(dir: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir.join("frames"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "vtu"))
        .collect();
    files.sort();
    files
}

/// Every array of `frame` that it carries, flattened as VTK holds it.
fn columns(frame: &ParticleFrame) -> Vec<(String, Vec<f64>)> {
    let flat3 = |v: &[[f64; 3]]| v.iter().flatten().copied().collect::<Vec<f64>>();
    let mut all = vec![
        ("points".to_string(), flat3(&frame.position)),
        (
            "id".into(),
            frame.id.iter().map(|&v| f64::from(v)).collect(),
        ),
        (
            "body".into(),
            frame.body.iter().map(|&v| f64::from(v)).collect(),
        ),
        (
            "material".into(),
            frame.material.iter().map(|&v| f64::from(v)).collect(),
        ),
        ("velocity".into(), flat3(&frame.velocity)),
        ("mass".into(), frame.mass.clone()),
        ("volume".into(), frame.volume.clone()),
        (
            "stress".into(),
            frame.stress.iter().flatten().copied().collect(),
        ),
        ("damage".into(), frame.damage.clone()),
        (
            "strain_energy_density".into(),
            frame.strain_energy_density.clone(),
        ),
    ];
    all.extend(frame.scalars.iter().cloned());
    all.extend(frame.vectors.iter().map(|(n, v)| (n.clone(), flat3(v))));
    let n = frame.position.len();
    all.retain(|(name, values)| name == "points" || !values.is_empty() || n == 0);
    all
}

fn read_f64s(path: &Path) -> Vec<f64> {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    bytes
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
        .collect()
}

/// The arrays VTK dumped for one frame, by name, sorted.
fn dumped(dir: &Path) -> Vec<(String, Vec<f64>)> {
    let mut arrays: Vec<(String, Vec<f64>)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "f64"))
        .map(|p| {
            let name = p.file_stem().unwrap().to_string_lossy().into_owned();
            (name, read_f64s(&p))
        })
        .collect();
    arrays.sort_by(|a, b| a.0.cmp(&b.0));
    arrays
}

/// Bitwise equality, NaN included (the velocity field of a particle with no node is NaN).
fn same_bits(a: &[f64], b: &[f64]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
}

#[test]
fn vtk_reads_every_frame_fractum_writes() {
    let root = temp_dir("vtk-reader");
    let cases: [(&str, &str, FrameCompression, Option<&[&str]>); 5] = [
        (
            "dfg_zlib",
            "kalthoff_winkler_dfg.ron",
            FrameCompression::Zlib,
            None,
        ),
        (
            "dfg_plain",
            "kalthoff_winkler_dfg.ron",
            FrameCompression::None,
            None,
        ),
        (
            "fields",
            "kalthoff_winkler_dfg.ron",
            FrameCompression::Zlib,
            Some(&["damage", "surface"]),
        ),
        (
            "zlib_3d",
            "tension_softening_3d.ron",
            FrameCompression::Zlib,
            None,
        ),
        (
            "plain_3d",
            "tension_softening_3d.ron",
            FrameCompression::None,
            None,
        ),
    ];
    let mut frames = Vec::new();
    for (name, scene, compression, fields) in cases {
        let out = root.join(name);
        frames_of(scene, &out, compression, fields);
        frames.extend(vtu_files(&out));
    }
    // A frame with no particle left (every body removed from the grid).
    std::fs::create_dir_all(root.join("empty/frames")).unwrap();
    let empty = root.join("empty/frames/particles_empty.vtu");
    write_particle_frame(&empty, &ParticleFrame::default(), FrameCompression::Zlib).unwrap();
    frames.push(empty);

    let python = std::env::var("FRACTUM_VTK_PYTHON").unwrap_or_else(|_| "python3".into());
    let script = repo_root().join("tests/support/vtk_dump.py");
    let dumps = root.join("dumps");
    let mut checked = 0;
    for (case, group) in frames.chunk_by(|a, b| a.parent() == b.parent()).enumerate() {
        let into = dumps.join(case.to_string());
        let status = std::process::Command::new(&python)
            .arg(&script)
            .arg(&into)
            .args(group)
            .status()
            .unwrap_or_else(|e| panic!("cannot start {python}: {e}"));
        assert!(status.success(), "VTK failed on {group:?}");
        for frame in group {
            let stem = frame.file_stem().unwrap().to_string_lossy().into_owned();
            let vtk = into.join(&stem);
            let cells = std::fs::read_to_string(vtk.join("cells.txt")).unwrap();
            let counts: Vec<&str> = cells.split_whitespace().collect();
            assert_eq!(counts[0], counts[1], "{stem}: one vertex cell per point");
            assert!(
                counts[2..].iter().all(|&t| t == "1"),
                "{stem}: cells {cells}"
            );
            if stem.starts_with("grid") {
                continue;
            }
            let ours = read_particle_frame(frame).unwrap();
            let mut expected = columns(&ours);
            expected.sort_by(|a, b| a.0.cmp(&b.0));
            let theirs = dumped(&vtk);
            let names =
                |c: &[(String, Vec<f64>)]| c.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>();
            assert_eq!(names(&theirs), names(&expected), "{}", frame.display());
            for ((name, a), (_, b)) in theirs.iter().zip(&expected) {
                assert!(same_bits(a, b), "{}: array {name} differs", frame.display());
            }
            checked += 1;
        }
    }
    // Compressed and plain frames of the same steps hold the same values under VTK (grid
    // frames included, which Fractum does not read back itself).
    for (zlib, plain) in [(0, 1), (3, 4)] {
        let (zlib, plain) = (dumps.join(zlib.to_string()), dumps.join(plain.to_string()));
        for entry in std::fs::read_dir(&zlib).unwrap() {
            let stem = entry.unwrap().file_name();
            let (a, b) = (dumped(&zlib.join(&stem)), dumped(&plain.join(&stem)));
            assert_eq!(a.len(), b.len(), "{stem:?}");
            for ((name, x), (other, y)) in a.iter().zip(&b) {
                assert!(name == other && same_bits(x, y), "{stem:?}: {name} differs");
            }
        }
    }
    assert!(checked >= 12, "only {checked} particle frames checked");
    std::fs::remove_dir_all(&root).unwrap();
}
