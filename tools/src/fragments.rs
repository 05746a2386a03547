//! `fractum fragments`: the fragments of a run at one time, as connected components of intact
//! material (dfg-partitioning-mpm.md §3.4, "a connected components algorithm to identify
//! fragments of undamaged material"), with the size and speed of each and the cumulative size
//! distribution (the paper's Fig. 18).
//!
//! - Intact: a particle whose damage is below `damage_below` (default 0.5: a particle more than
//!   half failed belongs to a crack, not to a fragment), of the chosen bodies (all by default;
//!   e.g. the specimen without the platens that load it).
//! - Connected: two intact particles closer than the link length, by default 1.5 particle
//!   spacings (the spacing from the median particle volume: `V^{1/3}` in 3D, `√(V / t)` in 2D
//!   with the scene's thickness `t`), which joins the diagonal neighbours of a lattice with two
//!   particles per cell and nothing further. Components by union-find over a kd-tree's pairs.
//! - A frame is 2D when it records the scene's thickness (`fractum run` writes it into every 2D
//!   frame's field data), or, for a frame that does not, when every particle has z = 0 exactly.
//!   The recorded thickness is used unless the options give one.
//! - Per fragment: particle count, mass, volume, equivalent diameter (of the disk of the same
//!   area in 2D, of the sphere of the same volume in 3D), centroid, velocity (its momentum over
//!   its mass) and speed.

use fractum_engine::prelude::{DVec3, Three};
use fractum_io::output::ParticleFrame;
use fractum_systems::spatial::Spatial;

/// What counts as a fragment.
#[derive(Clone, Debug, PartialEq)]
pub struct FragmentOptions {
    /// Particles with damage below this are intact material.
    pub damage_below: f64,
    /// Link length (m); `None`: 1.5 median particle spacings.
    pub link: Option<f64>,
    /// The scene's thickness (m) for 2D frames, whose volumes are per that thickness; `None`:
    /// the thickness the frame records.
    pub thickness: Option<f64>,
    /// Only the particles of these bodies (indices in the scene's order); all when empty.
    pub bodies: Vec<u16>,
}

impl Default for FragmentOptions {
    fn default() -> Self {
        Self {
            damage_below: 0.5,
            link: None,
            thickness: None,
            bodies: Vec::new(),
        }
    }
}

/// One fragment.
#[derive(Clone, Debug, PartialEq)]
pub struct Fragment {
    /// Number of particles.
    pub particles: usize,
    /// Mass (kg; per scene thickness in 2D).
    pub mass: f64,
    /// Volume (m³; per scene thickness in 2D).
    pub volume: f64,
    /// Equivalent diameter (m).
    pub diameter: f64,
    /// Mass-weighted centroid.
    pub centroid: [f64; 3],
    /// Momentum over mass.
    pub velocity: [f64; 3],
}

impl Fragment {
    /// Magnitude of the fragment's velocity.
    pub fn speed(&self) -> f64 {
        self.velocity.iter().map(|v| v * v).sum::<f64>().sqrt()
    }
}

/// Whether `frame` is 2D, and the thickness its volumes are per (`thickness` if given, else the
/// one the frame records; 1 in 3D). A 2D frame that records none needs `thickness`.
pub fn frame_thickness(
    frame: &ParticleFrame,
    thickness: Option<f64>,
) -> Result<(bool, f64), String> {
    let planar = frame.thickness.is_some() || frame.position.iter().all(|p| p[2] == 0.0);
    if !planar {
        return Ok((false, 1.0));
    }
    match thickness.or(frame.thickness) {
        Some(t) if t > 0.0 && t.is_finite() => Ok((true, t)),
        Some(t) => Err(format!("a thickness of {t} m: expected a positive length")),
        None => Err(
            "a 2D frame that does not record its scene's thickness (written by an \
                     older fractum): give the scene's thickness with --thickness"
                .into(),
        ),
    }
}

/// The fragments of `frame`, largest mass first, and the link length used; an error when the
/// frame's thickness is unknown (see [`frame_thickness`]).
pub fn find_fragments(
    frame: &ParticleFrame,
    options: &FragmentOptions,
) -> Result<(Vec<Fragment>, f64), String> {
    frame.require(&["damage", "mass", "velocity", "volume"])?;
    if !options.bodies.is_empty() {
        frame.require(&["body"])?;
    }
    let (planar, thickness) = frame_thickness(frame, options.thickness)?;
    let chosen = |p: usize| {
        options.bodies.is_empty()
            || frame
                .body
                .get(p)
                .is_some_and(|b| options.bodies.contains(b))
    };
    let intact: Vec<usize> = (0..frame.position.len())
        .filter(|&p| frame.damage[p] < options.damage_below && chosen(p))
        .collect();
    let link = options
        .link
        .unwrap_or_else(|| 1.5 * median_spacing(frame, planar, thickness));
    let labels = components(&intact, &frame.position, link);
    let mut fragments: Vec<Option<Fragment>> = vec![None; intact.len()];
    for (k, &p) in intact.iter().enumerate() {
        let (m, v) = (frame.mass[p], frame.velocity[p]);
        let f = fragments[labels[k]].get_or_insert(Fragment {
            particles: 0,
            mass: 0.0,
            volume: 0.0,
            diameter: 0.0,
            centroid: [0.0; 3],
            velocity: [0.0; 3],
        });
        f.particles += 1;
        f.mass += m;
        f.volume += frame.volume[p];
        let x = frame.position[p];
        for ((c, u), (xa, va)) in f
            .centroid
            .iter_mut()
            .zip(&mut f.velocity)
            .zip(x.iter().zip(v))
        {
            *c += m * xa;
            *u += m * va;
        }
    }
    let mut fragments: Vec<Fragment> = fragments
        .into_iter()
        .flatten()
        .map(|mut f| {
            for a in 0..3 {
                f.centroid[a] /= f.mass;
                f.velocity[a] /= f.mass;
            }
            f.diameter = equivalent_diameter(f.volume, planar, thickness);
            f
        })
        .collect();
    fragments.sort_by(|a, b| b.mass.total_cmp(&a.mass));
    Ok((fragments, link))
}

/// The diameter of the disk (2D, area `volume / thickness`) or sphere of the same size.
pub fn equivalent_diameter(volume: f64, planar: bool, thickness: f64) -> f64 {
    if planar {
        2.0 * (volume / thickness / std::f64::consts::PI).sqrt()
    } else {
        (6.0 * volume / std::f64::consts::PI).cbrt()
    }
}

/// The median particle spacing from the particle volumes (`planar`: a 2D frame of scene
/// thickness `thickness`).
pub fn median_spacing(frame: &ParticleFrame, planar: bool, thickness: f64) -> f64 {
    let mut volumes = frame.volume.clone();
    if volumes.is_empty() {
        return 0.0;
    }
    volumes.sort_by(f64::total_cmp);
    particle_size(volumes[volumes.len() / 2], planar, thickness)
}

/// The side of a particle of `volume`: of its area (volume over `thickness`) in a planar frame,
/// of its volume in 3D.
pub fn particle_size(volume: f64, planar: bool, thickness: f64) -> f64 {
    if planar {
        (volume / thickness).sqrt()
    } else {
        volume.cbrt()
    }
}

/// Component label (0, 1, …, in order of first appearance) of each of the `members`
/// (indices into `positions`), joining members closer than `link`.
pub fn components(members: &[usize], positions: &[[f64; 3]], link: f64) -> Vec<usize> {
    let points: Vec<DVec3> = members
        .iter()
        .map(|&p| DVec3::from_array(positions[p]))
        .collect();
    let tree = Three::tree(&points);
    let mut parent: Vec<usize> = (0..members.len()).collect();
    let mut found = Vec::new();
    for (k, &x) in points.iter().enumerate() {
        found.clear();
        Three::within(&tree, x, link, &mut found);
        for &j in &found {
            union(&mut parent, k, j as usize);
        }
    }
    let mut next = 0;
    let mut label_of_root = vec![usize::MAX; members.len()];
    (0..members.len())
        .map(|k| {
            let root = find(&mut parent, k);
            if label_of_root[root] == usize::MAX {
                label_of_root[root] = next;
                next += 1;
            }
            label_of_root[root]
        })
        .collect()
}

fn find(parent: &mut [usize], mut k: usize) -> usize {
    while parent[k] != k {
        parent[k] = parent[parent[k]];
        k = parent[k];
    }
    k
}

fn union(parent: &mut [usize], a: usize, b: usize) {
    let (ra, rb) = (find(parent, a), find(parent, b));
    if ra != rb {
        // The smaller root wins, so labels do not depend on the pair order.
        let (lo, hi) = (ra.min(rb), ra.max(rb));
        parent[hi] = lo;
    }
}

/// The cumulative size distribution: for each fragment diameter (ascending), the fraction of
/// the fragments' mass in fragments of that diameter or smaller.
pub fn cumulative_by_mass(fragments: &[Fragment]) -> Vec<(f64, f64)> {
    let mut sizes: Vec<(f64, f64)> = fragments.iter().map(|f| (f.diameter, f.mass)).collect();
    sizes.sort_by(|a, b| a.0.total_cmp(&b.0));
    let total: f64 = sizes.iter().map(|s| s.1).sum();
    let mut running = 0.0;
    sizes
        .into_iter()
        .map(|(d, m)| {
            running += m;
            (d, running / total)
        })
        .collect()
}

/// The fragments of one run: the frame analysed and what was found.
#[derive(Clone, Debug)]
pub struct RunFragments {
    /// The run's output folder.
    pub dir: std::path::PathBuf,
    /// Time of the frame analysed.
    pub time: f64,
    /// The fragments, largest mass first.
    pub fragments: Vec<Fragment>,
    /// Link length used.
    pub link: f64,
}

/// The time and file of the particle frame of the run in `dir` nearest `time` (the last when
/// `None`).
pub fn frame_file_near(
    dir: &std::path::Path,
    time: Option<f64>,
) -> Result<(f64, std::path::PathBuf), String> {
    let frames = fractum_io::output::read_pvd(&dir.join("particles.pvd"))?;
    let chosen = match time {
        Some(t) => frames
            .iter()
            .min_by(|a, b| (a.0 - t).abs().total_cmp(&(b.0 - t).abs())),
        None => frames.last(),
    }
    .ok_or_else(|| format!("{}: the run wrote no particle frames", dir.display()))?;
    Ok((chosen.0, dir.join(&chosen.1)))
}

/// Reads the frame of the run in `dir` nearest to `time` (the last one when `None`) and finds
/// its fragments.
pub fn run_fragments(
    dir: &std::path::Path,
    time: Option<f64>,
    options: &FragmentOptions,
) -> Result<RunFragments, String> {
    let (time, path) = frame_file_near(dir, time)?;
    let frame = fractum_io::output::read_particle_frame(&path)?;
    let (fragments, link) =
        find_fragments(&frame, options).map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(RunFragments {
        dir: dir.to_path_buf(),
        time,
        fragments,
        link,
    })
}

/// `fragments.csv` (one row per fragment) and `fragment_sizes.csv` (the cumulative mass
/// fraction against diameter) in the run's folder, written atomically.
pub fn write_fragment_tables(run: &RunFragments) -> Result<(), String> {
    let mut table = String::from(
        "fragment,particles,mass,volume,equivalent_diameter,speed,velocity_x,velocity_y,\
         velocity_z,centroid_x,centroid_y,centroid_z\n",
    );
    for (k, f) in run.fragments.iter().enumerate() {
        let [vx, vy, vz] = f.velocity;
        let [cx, cy, cz] = f.centroid;
        table.push_str(&format!(
            "{k},{},{:e},{:e},{:e},{:e},{vx:e},{vy:e},{vz:e},{cx:e},{cy:e},{cz:e}\n",
            f.particles,
            f.mass,
            f.volume,
            f.diameter,
            f.speed()
        ));
    }
    let mut sizes = String::from("equivalent_diameter,cumulative_mass_fraction\n");
    for (d, fraction) in cumulative_by_mass(&run.fragments) {
        sizes.push_str(&format!("{d:e},{fraction:e}\n"));
    }
    for (name, text) in [("fragments.csv", table), ("fragment_sizes.csv", sizes)] {
        let path = run.dir.join(name);
        fractum_io::output::write_atomically(&path, text.as_bytes())
            .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    }
    Ok(())
}

/// The mass-weighted mean speed of the fragments (the paper's Fig. 18 insets).
pub fn mean_speed(fragments: &[Fragment]) -> f64 {
    let mass: f64 = fragments.iter().map(|f| f.mass).sum();
    fragments.iter().map(|f| f.mass * f.speed()).sum::<f64>() / mass
}

/// The cumulative size distributions of `runs` on one plot (log₁₀ of the diameter across),
/// into the PNG `output`.
pub fn plot_size_distributions(
    runs: &[RunFragments],
    output: &std::path::Path,
) -> Result<std::path::PathBuf, String> {
    let curves: Vec<(String, Vec<(f64, f64)>)> = runs
        .iter()
        .map(|run| {
            let name = run.dir.file_name().map_or_else(
                || run.dir.display().to_string(),
                |n| n.to_string_lossy().into(),
            );
            // A staircase: the fraction rises at each fragment's diameter.
            let mut points = Vec::new();
            let mut below = 0.0;
            for (d, fraction) in cumulative_by_mass(&run.fragments) {
                points.push((d.log10(), below));
                points.push((d.log10(), fraction));
                below = fraction;
            }
            (format!("{name} (t = {:.3e} s)", run.time), points)
        })
        .collect();
    crate::plot::draw_curves(
        &curves,
        (
            "log10 of the equivalent diameter (m)",
            "cumulative mass fraction",
        ),
        output,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An `n × n` lattice of spacing 1 (2D, unit thickness), intact except where `failed`.
    fn lattice(n: usize, failed: impl Fn(usize, usize) -> bool) -> ParticleFrame {
        let mut f = ParticleFrame::default();
        for i in 0..n {
            for j in 0..n {
                f.id.push((i * n + j) as u32);
                f.position.push([i as f64 + 0.5, j as f64 + 0.5, 0.0]);
                // The left half moves left, the right half right.
                let vx = if i < n / 2 { -1.0 } else { 1.0 };
                f.velocity.push([vx, 0.0, 0.0]);
                f.mass.push(2.0);
                f.volume.push(1.0);
                f.damage.push(if failed(i, j) { 1.0 } else { 0.0 });
            }
        }
        f.thickness = Some(1.0);
        f
    }

    #[test]
    fn the_frame_s_thickness_sets_the_spacing_unless_one_is_given() {
        // Volumes of 2 per unit spacing of a 2-thick scene: the spacing is still 1.
        let mut frame = lattice(4, |_, _| false);
        frame.volume.iter_mut().for_each(|v| *v = 2.0);
        frame.thickness = Some(2.0);
        let (fragments, link) = find_fragments(&frame, &FragmentOptions::default()).unwrap();
        assert_eq!(link, 1.5);
        let area = 16.0;
        assert!((fragments[0].diameter - 2.0 * (area / std::f64::consts::PI).sqrt()).abs() < 1e-12);
        // A thickness given overrides the recorded one.
        let options = FragmentOptions {
            thickness: Some(0.5),
            ..FragmentOptions::default()
        };
        assert_eq!(find_fragments(&frame, &options).unwrap().1, 3.0);
        // A 2D frame of an older fractum, without its thickness: asked for, not guessed.
        frame.thickness = None;
        let error = find_fragments(&frame, &FragmentOptions::default()).unwrap_err();
        assert!(error.contains("--thickness"), "{error}");
    }

    #[test]
    fn a_failed_column_splits_the_lattice_in_two() {
        let frame = lattice(10, |i, _| i == 5);
        let (fragments, link) = find_fragments(&frame, &FragmentOptions::default()).unwrap();
        assert_eq!(link, 1.5);
        assert_eq!(fragments.len(), 2);
        // Columns 0-4 (50 particles) and 6-9 (40): the larger first.
        assert_eq!((fragments[0].particles, fragments[1].particles), (50, 40));
        assert_eq!(fragments[0].mass, 100.0);
        assert!((fragments[0].diameter - 2.0 * (50.0 / std::f64::consts::PI).sqrt()).abs() < 1e-12);
        assert_eq!(fragments[0].velocity, [-1.0, 0.0, 0.0]);
        assert_eq!(fragments[1].speed(), 1.0);
        assert!((fragments[0].centroid[0] - 2.5).abs() < 1e-12);
    }

    #[test]
    fn only_the_chosen_bodies_are_counted() {
        let mut frame = lattice(10, |i, _| i == 5);
        // The right half is another body.
        frame.body = (0..100).map(|k| u16::from(k / 10 > 5)).collect();
        let options = FragmentOptions {
            bodies: vec![0],
            ..FragmentOptions::default()
        };
        let (fragments, _) = find_fragments(&frame, &options).unwrap();
        assert_eq!(fragments.len(), 1);
        assert_eq!(fragments[0].particles, 50);
    }

    #[test]
    fn a_failed_cross_gives_four_and_isolated_particles_count_alone() {
        // A cross through the middle, and a particle cut off in a corner by a failed L.
        let frame = lattice(11, |i, j| {
            i == 5 || j == 5 || (i, j) == (1, 0) || (i, j) == (0, 1) || (i, j) == (1, 1)
        });
        let (fragments, _) = find_fragments(&frame, &FragmentOptions::default()).unwrap();
        let mut counts: Vec<usize> = fragments.iter().map(|f| f.particles).collect();
        counts.sort_unstable();
        assert_eq!(counts, vec![1, 21, 25, 25, 25]);
        let cumulative = cumulative_by_mass(&fragments);
        assert_eq!(cumulative.len(), 5);
        assert!((cumulative[0].1 - 1.0 / 97.0).abs() < 1e-12);
        assert_eq!(cumulative[4].1, 1.0);
    }

    #[test]
    fn a_diagonal_crack_one_particle_wide_does_not_separate() {
        // Damage on the diagonal alone: diagonal neighbours across it are 1.41 apart, within
        // the link, so the two sides stay one fragment, as a lattice of two particles per cell
        // needs a crack two particles wide to open along a diagonal. Damage on i + j ∈ {9, 10}
        // separates.
        let thin = lattice(10, |i, j| i + j == 9);
        assert_eq!(
            find_fragments(&thin, &FragmentOptions::default())
                .unwrap()
                .0
                .len(),
            1
        );
        let thick = lattice(10, |i, j| i + j == 9 || i + j == 10);
        assert_eq!(
            find_fragments(&thick, &FragmentOptions::default())
                .unwrap()
                .0
                .len(),
            2
        );
    }
}
