//! The `fractum` binary with the stock systems.

fn main() {
    let registry = fractum_systems::stock_registry();
    std::process::exit(fractum_cli::main_with(std::env::args_os(), &registry));
}
