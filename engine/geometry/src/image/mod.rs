//! Bodies from images: `Image(file: "ct/rock_###.tif", voxel_size: 0.1e-3, phases: [..])`,
//! a 2D greyscale picture (PNG or TIFF) or a 3D stack (a multi-page TIFF, or numbered slices),
//! thresholded into phases by grey windows, as micro-CT specimens are seeded.
//!
//! The image lies on a voxel lattice from `origin` (the outer corner of the first column of
//! the bottom row of the first slice): columns run along x, rows along y with the top row of
//! the picture at the largest y (so the body looks as the picture does), slices along z.
//! Each voxel whose grey value falls in a phase's window `[grey_min, grey_max]` (both ends
//! included; the file's raw sample values, 0 to 255 for 8-bit pictures) is inside the shape and
//! carries that phase. Only the phase of each voxel is kept, one byte per voxel, so a 512³
//! stack takes 134 MB whatever its bit depth.
//!
//! A body of an image is seeded voxel by voxel: `particles_per_cell` points along each
//! direction of every voxel (one per voxel with 1), placed by the body's `placement` as the
//! grid's cells are, each with its share of the voxel's volume; a phase that names a material
//! gives it to its particles.

mod decode;

pub use decode::{GreyPage, read_slices};

use super::file_error::{FileError, fail};
use glam::DVec3;
use std::path::Path;

/// A grey window and what the voxels in it become.
#[derive(Clone, Debug, PartialEq)]
pub struct Phase {
    /// The lowest grey value of the window.
    pub grey_min: f64,
    /// The highest grey value of the window (included).
    pub grey_max: f64,
    /// The material of the phase's particles; the body's when `None`.
    pub material: Option<String>,
}

/// Where the image's voxels lie.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VoxelFrame {
    /// The outer corner of the first voxel (bottom row, first column, first slice).
    pub origin: DVec3,
    /// Voxel widths along x, y and z (z only counts for stacks).
    pub spacing: DVec3,
}

/// An image thresholded into phases: for each voxel, its phase or none.
#[derive(Clone, Debug)]
pub struct VoxelImage {
    /// The file, as the scene names it.
    pub file: String,
    /// Columns, rows and slices (1 slice for a 2D picture).
    size: [usize; 3],
    three_d: bool,
    frame: VoxelFrame,
    /// Per slice, 0 for a voxel in no phase, else 1 + its phase; column fastest, rows from the
    /// bottom. Slice by slice, so that a stack never needs one allocation of its full size
    /// (nor the copies of growing one).
    labels: Vec<Box<[u8]>>,
    phases: Vec<Phase>,
    /// Voxels per phase.
    counts: Vec<usize>,
    /// The faces of the box of all the voxels in a phase.
    lo: DVec3,
    hi: DVec3,
}

impl PartialEq for VoxelImage {
    fn eq(&self, other: &Self) -> bool {
        self.file == other.file
            && self.size == other.size
            && self.frame == other.frame
            && self.phases == other.phases
            && self.labels == other.labels
    }
}

/// `None` when the phases are usable, else the phase at fault and what was expected: finite
/// windows with `grey_min <= grey_max`, no grey value in two windows, 1 to 255 phases.
pub fn phase_problem(phases: &[Phase]) -> Option<(usize, String)> {
    if phases.is_empty() {
        return Some((
            0,
            "expected at least one phase: `[(grey_min: .., grey_max: ..)]`".into(),
        ));
    }
    if phases.len() > 255 {
        return Some((255, "expected at most 255 phases".into()));
    }
    for (k, p) in phases.iter().enumerate() {
        if !(p.grey_min.is_finite() && p.grey_max.is_finite()) || p.grey_min > p.grey_max {
            return Some((
                k,
                format!(
                    "the window is {} to {}; expected finite grey values with `grey_min` at \
                     most `grey_max`",
                    p.grey_min, p.grey_max
                ),
            ));
        }
        if let Some(j) = phases[..k]
            .iter()
            .position(|q| p.grey_min <= q.grey_max && q.grey_min <= p.grey_max)
        {
            return Some((
                k,
                format!(
                    "the window {} to {} overlaps that of phases[{j}], {} to {}; a grey value \
                     belongs to one phase at most",
                    p.grey_min, p.grey_max, phases[j].grey_min, phases[j].grey_max
                ),
            ));
        }
    }
    None
}

/// The phase of grey value `g`: 1 + its index, or 0 when no window holds it.
fn label_of(phases: &[Phase], g: f64) -> u8 {
    phases
        .iter()
        .position(|p| g >= p.grey_min && g <= p.grey_max)
        .map_or(0, |k| k as u8 + 1)
}

/// Reads the image at `path` (`file` is how the scene names it; a run of `#` in it numbers
/// slices) and thresholds it into `phases` (checked by [`phase_problem`] first).
pub fn read_image(
    path: &Path,
    file: &str,
    frame: VoxelFrame,
    phases: &[Phase],
) -> Result<VoxelImage, FileError> {
    let mut image = VoxelImage {
        file: file.to_string(),
        size: [0; 3],
        three_d: false,
        frame,
        labels: Vec::new(),
        phases: phases.to_vec(),
        counts: vec![0; phases.len()],
        lo: DVec3::ZERO,
        hi: DVec3::ZERO,
    };
    let (mut first, mut last) = ([usize::MAX; 3], [0usize; 3]);
    let mut grey = (f64::INFINITY, f64::NEG_INFINITY);
    let three_d = read_slices(path, &mut |slice, page: GreyPage| {
        let [w, h] = [page.width, page.height];
        image.size = [w, h, slice + 1];
        let mut labels = Vec::with_capacity(w * h);
        for j in 0..h {
            // Rows are stored from the top; y grows upwards.
            let row = &page.samples[(h - 1 - j) * w..(h - j) * w];
            for (i, &g) in row.iter().enumerate() {
                grey = (grey.0.min(g), grey.1.max(g));
                let label = label_of(phases, g);
                labels.push(label);
                if label > 0 {
                    image.counts[label as usize - 1] += 1;
                    for (a, n) in [i, j, slice].into_iter().enumerate() {
                        first[a] = first[a].min(n);
                        last[a] = last[a].max(n);
                    }
                }
            }
        }
        image.labels.push(labels.into_boxed_slice());
        Ok(())
    })?;
    image.three_d = three_d;
    if image.counts.iter().all(|&n| n == 0) {
        let [w, h, d] = image.size;
        return Err(fail(
            "",
            format!(
                "no voxel falls in any phase: the {w}×{h}{} image's grey values run from {} to \
                 {}, the phases' windows are {}",
                if three_d {
                    format!("×{d}")
                } else {
                    String::new()
                },
                grey.0,
                grey.1,
                phases
                    .iter()
                    .map(|p| format!("{} to {}", p.grey_min, p.grey_max))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        ));
    }
    let corner = |n: [usize; 3]| {
        let n = DVec3::new(n[0] as f64, n[1] as f64, n[2] as f64);
        image.frame.origin + n * image.frame.spacing
    };
    image.lo = corner(first);
    image.hi = corner(last.map(|n| n + 1));
    if !three_d {
        image.lo.z = 0.0;
        image.hi.z = 0.0;
    }
    Ok(image)
}

impl VoxelImage {
    /// 3 for a stack, 2 for a single picture.
    pub fn dimension(&self) -> usize {
        if self.three_d { 3 } else { 2 }
    }

    /// Columns, rows and slices.
    pub fn size(&self) -> [usize; 3] {
        self.size
    }

    /// The phases, as the scene gives them.
    pub fn phases(&self) -> &[Phase] {
        &self.phases
    }

    /// How many voxels each phase holds.
    pub fn voxel_counts(&self) -> &[usize] {
        &self.counts
    }

    /// The box of the voxels in a phase (z = 0 for a picture).
    pub fn bounds(&self) -> (DVec3, DVec3) {
        (self.lo, self.hi)
    }

    /// The volume of one voxel (an area for a picture).
    pub fn voxel_volume(&self) -> f64 {
        let s = self.frame.spacing;
        if self.three_d {
            s.x * s.y * s.z
        } else {
            s.x * s.y
        }
    }

    /// The phase of the voxel holding `x` (z ignored for a picture), if it is in one.
    pub fn phase_at(&self, x: DVec3) -> Option<usize> {
        let mut n = [0; 3];
        for a in 0..self.dimension() {
            let k = ((x[a] - self.frame.origin[a]) / self.frame.spacing[a]).floor();
            if !(k >= 0.0 && k < self.size[a] as f64) {
                return None;
            }
            n[a] = k as usize;
        }
        match self.labels[n[2]][n[0] + self.size[0] * n[1]] {
            0 => None,
            label => Some(label as usize - 1),
        }
    }

    /// Whether `x` lies in a voxel of some phase.
    pub fn contains(&self, x: DVec3) -> bool {
        self.phase_at(x).is_some()
    }

    /// The particles of every voxel in a phase, voxels in index order (columns fastest, then
    /// rows from the bottom, then slices): the tensor-product rule `points` (reference
    /// coordinates in [−1, 1] and weights summing to 2, as `seed::cell_points` gives them)
    /// scaled to the voxel, each point with its share of the voxel's volume (area in 2D).
    pub fn particles(&self, points: &[(f64, f64)]) -> Vec<(DVec3, f64)> {
        let axes = self.dimension();
        let (origin, s) = (self.frame.origin, self.frame.spacing);
        let voxels = self.counts.iter().sum::<usize>();
        let per_voxel = points.len().pow(axes as u32);
        let mut out = Vec::with_capacity(voxels * per_voxel);
        let share = self.voxel_volume() / (1usize << axes) as f64;
        let w = self.size[0];
        let voxels = self.labels.iter().enumerate().flat_map(|(slice, labels)| {
            let filled = labels.iter().enumerate().filter(|(_, l)| **l > 0);
            filled.map(move |(index, _)| [index % w, index / w, slice])
        });
        for n in voxels {
            let corner = DVec3::new(n[0] as f64, n[1] as f64, n[2] as f64);
            let centre = origin + (corner + DVec3::splat(0.5)) * s;
            for k in 0..per_voxel {
                let sub = [k % points.len(), k / points.len() % points.len(), {
                    k / (points.len() * points.len())
                }];
                let reference = DVec3::new(points[sub[0]].0, points[sub[1]].0, points[sub[2]].0);
                let mut x = centre + reference * (0.5 * s);
                if axes == 2 {
                    x.z = 0.0;
                }
                let volume = (0..axes).fold(share, |v, a| v * points[sub[a]].1);
                out.push((x, volume));
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn phases(windows: &[(f64, f64)]) -> Vec<Phase> {
        windows
            .iter()
            .map(|&(grey_min, grey_max)| Phase {
                grey_min,
                grey_max,
                material: None,
            })
            .collect()
    }

    #[test]
    fn windows_must_be_ordered_finite_and_apart() {
        assert!(phase_problem(&phases(&[(0.0, 10.0), (11.0, 20.0)])).is_none());
        assert_eq!(phase_problem(&phases(&[(5.0, 1.0)])).unwrap().0, 0);
        assert_eq!(phase_problem(&phases(&[(0.0, f64::NAN)])).unwrap().0, 0);
        let (k, message) = phase_problem(&phases(&[(0.0, 10.0), (10.0, 20.0)])).unwrap();
        assert_eq!(k, 1);
        assert!(message.contains("overlaps that of phases[0]"), "{message}");
        assert!(phase_problem(&[]).is_some());
    }

    #[test]
    fn grey_values_take_the_phase_of_their_window() {
        let p = phases(&[(0.0, 10.0), (100.0, 200.0)]);
        assert_eq!(label_of(&p, 0.0), 1);
        assert_eq!(label_of(&p, 10.0), 1);
        assert_eq!(label_of(&p, 10.5), 0);
        assert_eq!(label_of(&p, 200.0), 2);
        assert_eq!(label_of(&p, f64::NAN), 0);
    }
}
