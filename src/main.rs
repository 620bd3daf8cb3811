fn main() -> std::process::ExitCode {
    ember::tools::cli::main()
}
