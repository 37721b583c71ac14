//! `pathtracer`: the command line (see the `cli` module). Flags follow the CS184 PathTracer.

mod cli;

fn main() -> std::process::ExitCode {
    cli::main()
}
