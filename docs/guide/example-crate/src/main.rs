//! A `fractum` binary with `damage/overstress` registered beside the stock systems: every
//! command of the stock binary (`run`, `check`, `systems`, `verify`, ...) knows it.

fn main() {
    let mut registry = fractum_systems::stock_registry();
    if let Err(e) = registry.register(overstress::OVERSTRESS) {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
    std::process::exit(fractum_cli::main_with(std::env::args_os(), &registry));
}
