//! The `sparsemor` command: reduce big FE models from disk (see `sparsemor --help`).

mod cli;

fn main() {
    match cli::run() {
        Ok(done) => std::process::exit(done.exit_code()),
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    }
}
