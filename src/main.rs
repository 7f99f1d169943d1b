//! The `lash` command-line binary: a thin shell around [`lash_cli`].

fn main() -> std::process::ExitCode {
    lash_cli::main()
}
