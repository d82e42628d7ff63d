fn main() -> std::process::ExitCode {
    raytracer::cli::main()
}
