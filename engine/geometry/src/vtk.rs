//! The VTK XML codec that Fractum's readers share: a particle file's reader
//! ([`crate::points`]) and the frame reader of `fractum-io`. A file is scanned tag by tag for
//! the elements it needs (no XML crate for a format this regular): tag attributes, the
//! `DataArray` elements between two offsets, and inline binary arrays (base64 with `UInt32` or
//! `UInt64` headers, optionally VTK's zlib compression) decoded to bytes and to numbers.

use base64::Engine as _;
use base64::engine::general_purpose::STANDARD as BASE64;
use std::io::Read;

/// The value of `name="..."` in the text of a tag.
pub fn attribute<'a>(tag: &'a str, name: &str) -> Option<&'a str> {
    let start = tag.find(&format!(" {name}=\""))? + name.len() + 3;
    let end = tag[start..].find('"')? + start;
    Some(&tag[start..end])
}

/// How a file encodes its binary arrays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Encoding {
    /// Bytes of each header word: 4 (`UInt32`) or 8 (`UInt64`).
    pub header_bytes: usize,
    /// Whether arrays are compressed with VTK's zlib compressor.
    pub compressed: bool,
}

/// One `DataArray`: where it starts, its attributes' text and its content.
pub struct DataArray<'a> {
    /// Byte offset of its start tag in the text.
    pub at: usize,
    /// The text of its start tag, attributes included.
    pub tag: &'a str,
    /// Its content, trimmed (empty for a self-closing tag).
    pub body: &'a str,
}

/// Every `DataArray` between byte offsets `from` and `to` of `text`, in order; a malformed one
/// as its offset and what is wrong.
pub fn data_arrays(
    text: &str,
    from: usize,
    to: usize,
) -> Result<Vec<DataArray<'_>>, (usize, &'static str)> {
    let mut out = Vec::new();
    let mut at = from;
    while let Some(offset) = text[at..to].find("<DataArray") {
        let start = at + offset;
        let close = text[start..to]
            .find('>')
            .ok_or((start, "a DataArray tag that does not close"))?
            + start;
        let tag = &text[start..close];
        if tag.ends_with('/') {
            out.push(DataArray {
                at: start,
                tag,
                body: "",
            });
            at = close + 1;
            continue;
        }
        let end = text[close..to]
            .find("</DataArray>")
            .ok_or((start, "a DataArray without its end tag"))?
            + close;
        out.push(DataArray {
            at: start,
            tag,
            body: text[close + 1..end].trim(),
        });
        at = end;
    }
    Ok(out)
}

impl DataArray<'_> {
    /// Its `Name` attribute (empty when it has none).
    pub fn name(&self) -> &str {
        attribute(self.tag, "Name").unwrap_or("")
    }

    /// Its `NumberOfComponents` (1 when not given).
    pub fn components(&self) -> usize {
        attribute(self.tag, "NumberOfComponents")
            .and_then(|c| c.parse().ok())
            .unwrap_or(1)
    }
}

/// Little-endian values of VTK type `ty` as doubles; `None` for an unknown type.
pub fn numbers(bytes: &[u8], ty: &str) -> Option<Vec<f64>> {
    macro_rules! read {
        ($t:ty) => {
            bytes
                .chunks_exact(std::mem::size_of::<$t>())
                .map(|c| <$t>::from_le_bytes(c.try_into().expect("sized chunk")) as f64)
                .collect()
        };
    }
    Some(match ty {
        "Float64" => read!(f64),
        "Float32" => read!(f32),
        "Int8" => read!(i8),
        "UInt8" => read!(u8),
        "Int16" => read!(i16),
        "UInt16" => read!(u16),
        "Int32" => read!(i32),
        "UInt32" => read!(u32),
        "Int64" => read!(i64),
        "UInt64" => read!(u64),
        _ => return None,
    })
}

/// The header word `index` (4 or 8 bytes).
fn word(bytes: &[u8], index: usize, size: usize) -> Option<usize> {
    let chunk = bytes.get(size * index..size * (index + 1))?;
    Some(match size {
        4 => u32::from_le_bytes(chunk.try_into().ok()?) as usize,
        _ => u64::from_le_bytes(chunk.try_into().ok()?) as usize,
    })
}

/// The bytes of an inline binary array: a byte count and the data encoded together, or with
/// VTK's zlib compression, a header `[blocks, block size, last block size, compressed
/// sizes...]` encoded apart from the compressed blocks.
pub fn decode(body: &str, encoding: &Encoding) -> Result<Vec<u8>, String> {
    let base64 = |s: &str| BASE64.decode(s).map_err(|e| format!("not base64: {e}"));
    let size = encoding.header_bytes;
    let short = || "its header is cut short".to_string();
    if !encoding.compressed {
        let block = base64(body)?;
        let count = word(&block, 0, size).ok_or_else(short)?;
        let data = &block[size..];
        if count != data.len() {
            return Err(format!(
                "{} bytes where its header says {count}",
                data.len()
            ));
        }
        return Ok(data.to_vec());
    }
    let encoded = |bytes: usize| bytes.div_ceil(3) * 4;
    let first = base64(body.get(..encoded(size)).ok_or_else(short)?)?;
    let blocks = word(&first, 0, size).ok_or_else(short)?;
    if blocks > body.len() {
        return Err(format!(
            "{blocks} compressed blocks, more than it could hold"
        ));
    }
    let header_len = encoded(size * (3 + blocks));
    let header = base64(body.get(..header_len).ok_or_else(short)?)?;
    let at = |i: usize| word(&header, i, size).ok_or_else(short);
    let (block_size, last) = (at(1)?, at(2)?);
    let total = match (blocks, last) {
        (0, _) => 0,
        (b, 0) => b * block_size,
        (b, l) => (b - 1) * block_size + l,
    };
    let data = base64(body[header_len..].trim())?;
    let mut out = Vec::with_capacity(total.min(data.len().saturating_mul(1032)));
    let mut offset = 0;
    for i in 0..blocks {
        let size = at(3 + i)?;
        let block = data
            .get(offset..offset + size)
            .ok_or("fewer compressed bytes than its header says")?;
        flate2::read::ZlibDecoder::new(block)
            .take(total.saturating_sub(out.len()) as u64 + 1)
            .read_to_end(&mut out)
            .map_err(|e| format!("its data do not inflate: {e}"))?;
        offset += size;
    }
    if out.len() != total {
        return Err(format!("{} bytes where its header says {total}", out.len()));
    }
    Ok(out)
}
