//! `fractum fragments`: the fragments of runs' frames and their size distributions.

use crate::cli::FragmentsArgs;
use crate::{EXIT_IO, fragments};

/// `fractum fragments` with `args`; the exit code.
pub(crate) fn fragments_command(args: &FragmentsArgs) -> i32 {
    let options = &fragments::FragmentOptions {
        damage_below: args.damage_below,
        link: args.link,
        thickness: args.thickness,
        bodies: args.body.clone(),
    };
    let (dirs, time, output) = (&args.out, args.time, args.output.clone());
    let result = (|| {
        let mut runs = Vec::new();
        for dir in dirs {
            let run = fragments::run_fragments(dir, time, options)?;
            fragments::write_fragment_tables(&run)?;
            let largest = run.fragments.first().map_or(0.0, |f| f.diameter);
            outln!(
                "{}: t = {:e} s, {} fragments (largest {largest:e} m across), mass-weighted mean \
                 speed {:e} m/s, link {:e} m; wrote fragments.csv and fragment_sizes.csv",
                dir.display(),
                run.time,
                run.fragments.len(),
                fragments::mean_speed(&run.fragments),
                run.link
            );
            runs.push(run);
        }
        let output = output.unwrap_or_else(|| dirs[0].join("fragment_sizes.png"));
        fragments::plot_size_distributions(&runs, &output)
    })();
    match result {
        Ok(path) => {
            outln!("wrote {}", path.display());
            0
        }
        Err(e) => {
            eprintln!("error: {e}");
            EXIT_IO
        }
    }
}
