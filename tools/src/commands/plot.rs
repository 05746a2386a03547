//! `fractum plot`: PNG plots of series columns against time.

use crate::{EXIT_BAD_SCENE, plot};
use std::path::{Path, PathBuf};

pub(crate) fn plot_command(
    csvs: &[PathBuf],
    x: &str,
    columns: &[String],
    bar: Option<&str>,
    output: Option<PathBuf>,
) -> i32 {
    let result = (|| {
        let runs = csvs
            .iter()
            .map(|csv| {
                let run = csv
                    .parent()
                    .and_then(Path::file_name)
                    .map_or_else(|| csv.display().to_string(), |n| n.to_string_lossy().into());
                Ok((run, plot::Series::read(csv)?))
            })
            .collect::<Result<Vec<_>, String>>()?;
        let bar = bar.map(plot::BarReference::parse).transpose()?;
        let output =
            output.unwrap_or_else(|| csvs[0].with_file_name(format!("{}.png", columns.join("+"))));
        plot::plot_runs(&runs, x, columns, bar, &output)
    })();
    match result {
        Ok(path) => {
            outln!("wrote {}", path.display());
            0
        }
        Err(e) => {
            eprintln!("error: {e}");
            EXIT_BAD_SCENE
        }
    }
}
