//! `series.csv`: one row per output step. Rows are kept in memory and the whole file is
//! replaced atomically at most about once a second and at the end, so the file on disk is always
//! complete and a reader never sees a partial row.

use super::atomic::write_atomically;
use std::fmt::Write;
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// Accumulates rows and keeps `path` up to date.
#[derive(Debug)]
pub struct SeriesWriter {
    /// `None` for a rank of a distributed run other than rank 0, which keeps the same rows but
    /// leaves the file to rank 0.
    path: Option<PathBuf>,
    columns: usize,
    text: String,
    last_flush: Option<Instant>,
}

impl SeriesWriter {
    /// A writer for `path` with these column names.
    pub fn new(path: PathBuf, columns: &[String]) -> Self {
        Self {
            path: Some(path),
            columns: columns.len(),
            text: columns.join(",") + "\n",
            last_flush: None,
        }
    }

    /// A writer that continues `text`, the series of an earlier run up to its checkpoint.
    pub fn continuing(path: PathBuf, text: String) -> Self {
        let columns = text.lines().next().map_or(0, |h| h.split(',').count());
        Self {
            path: Some(path),
            columns,
            text,
            last_flush: None,
        }
    }

    /// This writer keeping its rows in memory only: a rank other than rank 0 of a distributed
    /// run, whose rows are rank 0's.
    pub fn in_memory(mut self) -> Self {
        self.path = None;
        self
    }

    /// Appends a row (step, then the other values) and flushes if a second has passed.
    pub fn push(&mut self, step: u64, values: &[f64]) -> std::io::Result<()> {
        debug_assert_eq!(values.len() + 1, self.columns);
        let _ = write!(self.text, "{step}");
        for v in values {
            // Shortest representation that reads back to the same f64.
            let _ = write!(self.text, ",{v:?}");
        }
        self.text.push('\n');
        if self
            .last_flush
            .is_none_or(|t| t.elapsed() > Duration::from_secs(1))
        {
            self.flush()?;
        }
        Ok(())
    }

    /// Writes everything so far.
    pub fn flush(&mut self) -> std::io::Result<()> {
        self.last_flush = Some(Instant::now());
        match &self.path {
            Some(path) => write_atomically(path, self.text.as_bytes()),
            None => Ok(()),
        }
    }

    /// The CSV text so far.
    pub fn text(&self) -> &str {
        &self.text
    }
}
