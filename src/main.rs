//! The `hsph` command; see `hsph --help`.
fn main() {
    std::process::exit(hsph::cli::main());
}
