//! The `sparsemor` command: reduce big FE models from disk (see `sparsemor --help`).

mod cli;

fn main() {
    if let Err(e) = cli::run() {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}
