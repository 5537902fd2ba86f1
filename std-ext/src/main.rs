//! The `rotorid` command line (see the README and `rotorid --help`).

fn main() {
    std::process::exit(rotorid::cli::main_from_env());
}
