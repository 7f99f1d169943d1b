//! Compiles the C shim that expands the FMI 2.0 logger's printf-style messages.

fn main() {
    println!("cargo:rerun-if-changed=c/fmi2_logger.c");
    cc::Build::new().file("c/fmi2_logger.c").warnings(true).compile("lash_fmi2_logger");
}
