//! Greyscale pages from image files: a PNG, a TIFF (every page of a multi-page one), or
//! numbered slices (`ct/rock_###.png`: a run of `#` stands for the slice's zero-padded number).
//! Decoding is the `png` and `tiff` crates'; this module checks that the pages are greyscale
//! and alike, and hands them on one at a time so that a stack is never held decoded.

use super::super::file_error::{FileError, fail};
use std::io::BufReader;
use std::path::{Path, PathBuf};

/// One decoded greyscale page: its raw sample values, rows from the top.
#[derive(Clone, Debug, PartialEq)]
pub struct GreyPage {
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// `width × height` grey values, row by row from the top row.
    pub samples: Vec<f64>,
    /// What the samples are, for messages: `8-bit`, `16-bit`, `32-bit float`, …
    pub kind: String,
}

/// Hands each page of the image at `path` to `page` with its slice number from 0, and says
/// whether the image is a stack (3D: more than one TIFF page, or numbered slices).
pub fn read_slices(
    path: &Path,
    page: &mut dyn FnMut(usize, GreyPage) -> Result<(), FileError>,
) -> Result<bool, FileError> {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned());
    if name.as_deref().is_some_and(|n| n.contains('#')) {
        let slices = numbered_slices(path)?;
        let mut first: Option<(usize, usize, String)> = None;
        for (k, slice) in slices.iter().enumerate() {
            let place = slice
                .file_name()
                .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
            let mut pages = 0;
            read_file(slice, &mut |_, p| {
                pages += 1;
                if pages > 1 {
                    return Err(fail(
                        "",
                        "a numbered slice holds more than one page; expected one picture per \
                         slice",
                    ));
                }
                check_alike(&mut first, "", &p)?;
                page(k, p)
            })
            .map_err(|e| match e.place.is_empty() {
                true => fail(&place, e.message),
                false => fail(format!("{place}, {}", e.place), e.message),
            })?;
        }
        return Ok(true);
    }
    let mut first = None;
    let mut count = 0;
    read_file(path, &mut |k, p| {
        count = k + 1;
        check_alike(&mut first, &format!("page {}", k + 1), &p)?;
        page(k, p)
    })?;
    Ok(count > 1)
}

/// Every page must be the size and kind of the first.
fn check_alike(
    first: &mut Option<(usize, usize, String)>,
    place: &str,
    page: &GreyPage,
) -> Result<(), FileError> {
    match first {
        None => *first = Some((page.width, page.height, page.kind.clone())),
        Some((w, h, kind)) if (*w, *h, kind.as_str()) != (page.width, page.height, &page.kind) => {
            return Err(fail(
                place,
                format!(
                    "this page is {}×{} {}; the first is {w}×{h} {kind}, and every page of a \
                     stack must match it",
                    page.width, page.height, page.kind
                ),
            ));
        }
        Some(_) => {}
    }
    Ok(())
}

/// The files of the numbered slices `path` names (a run of `#` for the number), in order:
/// from the lowest number present, with no gap.
fn numbered_slices(path: &Path) -> Result<Vec<PathBuf>, FileError> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let start = name.find('#').unwrap_or(0);
    let digits = name[start..].chars().take_while(|&c| c == '#').count();
    let (prefix, suffix) = (&name[..start], &name[start + digits..]);
    if suffix.contains('#') {
        return Err(fail(
            "",
            "the file name has two runs of `#`; expected one, standing for the slice number",
        ));
    }
    let folder = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let entries = std::fs::read_dir(&folder)
        .map_err(|e| fail("", format!("cannot list `{}`: {e}", folder.display())))?;
    let mut numbers: Vec<u64> = entries
        .filter_map(|entry| {
            let file = entry.ok()?.file_name().to_string_lossy().into_owned();
            let number = file.strip_prefix(prefix)?.strip_suffix(suffix)?;
            (number.len() == digits && number.bytes().all(|b| b.is_ascii_digit()))
                .then(|| number.parse().ok())?
        })
        .collect();
    numbers.sort_unstable();
    let file_of = |n: u64| folder.join(format!("{prefix}{n:0digits$}{suffix}"));
    let Some(&lowest) = numbers.first() else {
        let (zero, one) = (file_of(0), file_of(1));
        return Err(fail(
            "",
            format!(
                "no file matches it in `{}`; expected slices `{}`, `{}`, …",
                folder.display(),
                zero.file_name().unwrap_or_default().to_string_lossy(),
                one.file_name().unwrap_or_default().to_string_lossy(),
            ),
        ));
    };
    if let Some(k) = (0..numbers.len()).find(|&k| numbers[k] != lowest + k as u64) {
        let missing = file_of(lowest + k as u64);
        return Err(fail(
            "",
            format!(
                "slice `{}` is missing: the slices run from {lowest} with no gap",
                missing.display()
            ),
        ));
    }
    Ok(numbers.into_iter().map(file_of).collect())
}

/// Decodes every page of one PNG or TIFF file, by its extension.
fn read_file(
    path: &Path,
    page: &mut dyn FnMut(usize, GreyPage) -> Result<(), FileError>,
) -> Result<(), FileError> {
    let extension = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    let file = std::fs::File::open(path)
        .map_err(|e| fail("", format!("cannot read `{}`: {e}", path.display())))?;
    let bytes = file.metadata().map_or(0, |m| m.len());
    let reader = BufReader::new(file);
    match extension.as_deref() {
        Some("png") => page(0, read_png(reader, bytes)?),
        Some("tif" | "tiff") => read_tiff(reader, bytes, page),
        _ => Err(fail(
            "",
            "expected a .png, .tif or .tiff file, by its extension",
        )),
    }
}

fn read_png(reader: impl std::io::Read, bytes: u64) -> Result<GreyPage, FileError> {
    let png_error =
        |e: png::DecodingError| fail("", format!("not a readable PNG of {bytes} bytes: {e}"));
    let mut decoder = png::Decoder::new(reader);
    decoder.set_transformations(png::Transformations::IDENTITY);
    let mut reader = decoder.read_info().map_err(png_error)?;
    let info = reader.info();
    let (width, height) = (info.width as usize, info.height as usize);
    let bits = info.bit_depth as u8;
    if info.color_type != png::ColorType::Grayscale {
        return Err(fail(
            "",
            format!(
                "the PNG is {:?}; expected a greyscale picture (save it as greyscale, 8 or 16 bits)",
                info.color_type
            ),
        ));
    }
    let mut bytes = vec![0; reader.output_buffer_size()];
    reader.next_frame(&mut bytes).map_err(png_error)?;
    Ok(GreyPage {
        width,
        height,
        samples: unpack(&bytes, width, height, bits, true),
        kind: format!("{bits}-bit"),
    })
}

/// Grey values from rows of `bits`-bit samples, each row starting on a byte; multi-byte
/// samples are big-endian when `big_endian` (PNG's order).
fn unpack(bytes: &[u8], width: usize, height: usize, bits: u8, big_endian: bool) -> Vec<f64> {
    let stride = (width * bits as usize).div_ceil(8);
    let mut samples = Vec::with_capacity(width * height);
    for row in bytes.chunks(stride).take(height) {
        match bits {
            16 => samples.extend(row.chunks_exact(2).map(|b| {
                f64::from(if big_endian {
                    u16::from_be_bytes([b[0], b[1]])
                } else {
                    u16::from_le_bytes([b[0], b[1]])
                })
            })),
            8 => samples.extend(row.iter().map(|&b| f64::from(b))),
            _ => {
                let mask = (1u16 << bits) - 1;
                samples.extend((0..width).map(|i| {
                    let bit = i * bits as usize;
                    let shift = 8 - bits as usize - bit % 8;
                    f64::from((u16::from(row[bit / 8]) >> shift) & mask)
                }))
            }
        }
    }
    samples
}

/// A decoded TIFF page's samples as numbers, with the kind of sample they were (`8-bit`,
/// `32-bit float`, …), from a picture with `bits` bits per grey sample; why not, when its
/// samples are of a kind the reader does not take.
fn tiff_samples(
    data: &tiff::decoder::DecodingResult,
    (width, height, bits): (usize, usize, u8),
) -> Result<(Vec<f64>, String), String> {
    use tiff::decoder::DecodingResult;
    Ok(match data {
        DecodingResult::U8(v) if bits < 8 => {
            (unpack(v, width, height, bits, true), format!("{bits}-bit"))
        }
        DecodingResult::U8(v) => (v.iter().map(|&g| f64::from(g)).collect(), "8-bit".into()),
        DecodingResult::U16(v) => (v.iter().map(|&g| f64::from(g)).collect(), "16-bit".into()),
        DecodingResult::U32(v) => (v.iter().map(|&g| f64::from(g)).collect(), "32-bit".into()),
        DecodingResult::I8(v) => (
            v.iter().map(|&g| f64::from(g)).collect(),
            "signed 8-bit".into(),
        ),
        DecodingResult::I16(v) => (
            v.iter().map(|&g| f64::from(g)).collect(),
            "signed 16-bit".into(),
        ),
        DecodingResult::I32(v) => (
            v.iter().map(|&g| f64::from(g)).collect(),
            "signed 32-bit".into(),
        ),
        DecodingResult::F32(v) => (
            v.iter().map(|&g| f64::from(g)).collect(),
            "32-bit float".into(),
        ),
        DecodingResult::F64(v) => (v.clone(), "64-bit float".into()),
        other => {
            return Err(format!(
                "the page's samples are {}; expected 1 to 32-bit integers or 32 or \
                     64-bit floats",
                match other {
                    DecodingResult::U64(_) | DecodingResult::I64(_) => "64-bit integers",
                    _ => "16-bit floats",
                }
            ));
        }
    })
}

fn read_tiff(
    reader: BufReader<std::fs::File>,
    bytes: u64,
    page: &mut dyn FnMut(usize, GreyPage) -> Result<(), FileError>,
) -> Result<(), FileError> {
    use tiff::decoder::{Decoder, DecodingResult};
    let at = |k: usize| format!("page {}", k + 1);
    let tiff_error = |k: usize| {
        move |e: tiff::TiffError| fail(at(k), format!("not a readable TIFF of {bytes} bytes: {e}"))
    };
    let mut decoder = Decoder::new(reader).map_err(tiff_error(0))?;
    let mut data = DecodingResult::U8(Vec::new());
    for k in 0.. {
        let colour = decoder.colortype().map_err(tiff_error(k))?;
        let (width, height) = decoder.dimensions().map_err(tiff_error(k))?;
        let (width, height) = (width as usize, height as usize);
        let tiff::ColorType::Gray(bits) = colour else {
            return Err(fail(
                at(k),
                format!(
                    "the page is {colour:?}; expected a greyscale picture (save it as greyscale)"
                ),
            ));
        };
        decoder
            .read_image_to_buffer(&mut data)
            .map_err(tiff_error(k))?;
        let (samples, kind) =
            tiff_samples(&data, (width, height, bits)).map_err(|e| fail(at(k), e))?;
        if samples.len() < width * height {
            return Err(fail(
                at(k),
                format!(
                    "the page holds {} samples; a {width}×{height} greyscale page has {}",
                    samples.len(),
                    width * height
                ),
            ));
        }
        page(
            k,
            GreyPage {
                width,
                height,
                samples,
                kind,
            },
        )?;
        if !decoder.more_images() {
            return Ok(());
        }
        decoder.next_image().map_err(tiff_error(k + 1))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packed_rows_unpack_most_significant_bit_first() {
        // Two rows of three 1-bit samples, each row padded to a byte.
        let rows = [0b1010_0000, 0b0110_0000];
        assert_eq!(
            unpack(&rows, 3, 2, 1, true),
            vec![1.0, 0.0, 1.0, 0.0, 1.0, 1.0]
        );
        // 4-bit samples.
        assert_eq!(unpack(&[0xF3, 0x50], 3, 1, 4, true), vec![15.0, 3.0, 5.0]);
        // 16-bit, big-endian.
        assert_eq!(unpack(&[1, 2], 1, 1, 16, true), vec![258.0]);
    }
}
