//! A block of particles on the wire between ranks ([`super::send`], [`super::receive`]): their
//! ids and their carried components' encoded parts, framed as plain little-endian lengths.
//!
//! The parts are already bytes (each component's column as a checkpoint encodes it), so the
//! frame only says where each one ends: the id count and the ids (`u32` each), the part count,
//! and each part's length before its bytes (`u64` each). Encoding the block with serde instead
//! went through the parts one byte at a time, which cost more than the rest of the exchange
//! (BENCHMARKS.md, "Where a distributed step's time goes").

use super::Block;

/// The bytes of `(ids, parts)` on the wire.
pub(super) fn encode(ids: &[u32], parts: &[Vec<u8>]) -> Vec<u8> {
    let payload: usize = parts.iter().map(Vec::len).sum();
    let mut bytes = Vec::with_capacity(16 + 4 * ids.len() + 8 * parts.len() + payload);
    bytes.extend_from_slice(&(ids.len() as u64).to_le_bytes());
    for id in ids {
        bytes.extend_from_slice(&id.to_le_bytes());
    }
    bytes.extend_from_slice(&(parts.len() as u64).to_le_bytes());
    for part in parts {
        bytes.extend_from_slice(&(part.len() as u64).to_le_bytes());
        bytes.extend_from_slice(part);
    }
    bytes
}

/// The block [`encode`] wrote, or what is wrong with `bytes` (cut short, or longer than the
/// block it frames).
pub(super) fn decode(bytes: &[u8]) -> Result<Block, String> {
    let mut reader = Reader { bytes, at: 0 };
    let id_count = reader.length("the id count")?;
    let ids = (reader.take(id_count.saturating_mul(4), "the ids")?)
        .chunks_exact(4)
        .map(|id| u32::from_le_bytes([id[0], id[1], id[2], id[3]]))
        .collect();
    let part_count = reader.length("the part count")?;
    let parts = (0..part_count)
        .map(|k| {
            let len = reader.length(&format!("the length of part {k}"))?;
            Ok(reader.take(len, &format!("part {k}"))?.to_vec())
        })
        .collect::<Result<Vec<_>, String>>()?;
    if reader.at != bytes.len() {
        return Err(format!(
            "{} bytes after the block's {}",
            bytes.len() - reader.at,
            reader.at
        ));
    }
    Ok((ids, parts))
}

/// The unread rest of a frame.
struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    /// The next `len` bytes, `what` naming them in the error when fewer are left.
    fn take(&mut self, len: usize, what: &str) -> Result<&'a [u8], String> {
        let end = self
            .at
            .checked_add(len)
            .filter(|&end| end <= self.bytes.len());
        let Some(end) = end else {
            return Err(format!(
                "the block ends at byte {} inside {what} ({len} bytes from byte {})",
                self.bytes.len(),
                self.at
            ));
        };
        let taken = &self.bytes[self.at..end];
        self.at = end;
        Ok(taken)
    }

    /// The next little-endian `u64`, as a length.
    fn length(&mut self, what: &str) -> Result<usize, String> {
        let raw = self.take(8, what)?;
        let value = u64::from_le_bytes(raw.try_into().map_err(|_| what.to_string())?);
        usize::try_from(value).map_err(|_| format!("{what} {value} is not a length here"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_block_comes_back_as_it_went() {
        let ids = vec![3, 7, u32::MAX];
        let parts = vec![vec![1, 2, 3], Vec::new(), vec![255; 1000]];
        let bytes = encode(&ids, &parts);
        assert_eq!(bytes.len(), 8 + 12 + 8 + 3 * 8 + 1003);
        assert_eq!(decode(&bytes).unwrap(), (ids, parts));
        let empty = encode(&[], &[]);
        assert_eq!(decode(&empty).unwrap(), (Vec::new(), Vec::new()));
    }

    /// Every cut of a block, and a byte too many, is refused with what was being read.
    #[test]
    fn a_cut_or_padded_block_is_refused() {
        let bytes = encode(&[1, 2], &[vec![9; 5], vec![8; 2]]);
        for end in 0..bytes.len() {
            let error = decode(&bytes[..end]).unwrap_err();
            assert!(
                error.contains(&format!("ends at byte {end} inside")),
                "{error}"
            );
        }
        assert!(decode(&bytes[..3]).unwrap_err().contains("the id count"));
        assert!(
            decode(&bytes[..bytes.len() - 1])
                .unwrap_err()
                .contains("part 1")
        );
        let mut padded = bytes.clone();
        padded.push(0);
        let error = decode(&padded).unwrap_err();
        assert!(error.contains("1 bytes after the block's"), "{error}");
        // A length past the end of the buffer is refused, not allocated.
        let mut huge = bytes;
        huge[..8].copy_from_slice(&u64::MAX.to_le_bytes());
        assert!(decode(&huge).unwrap_err().contains("inside the ids"));
    }
}
