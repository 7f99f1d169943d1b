//! Records the cargo profile this crate is built with (`release`, `dist`, `ci`, …) as
//! `LASH_PROFILE`, so that `lash bench` can say which build its figures come from. Cargo gives
//! build scripts only "debug" or "release" in `PROFILE`; the profile's own name is the folder
//! `OUT_DIR` sits under (`<target>/[<triple>/]<profile>/build/<crate>-<hash>/out`).

fn main() {
    let out_dir = std::env::var("OUT_DIR").unwrap_or_default();
    let profile = std::path::Path::new(&out_dir)
        .ancestors()
        .nth(3)
        .and_then(|p| p.file_name())
        .and_then(|n| n.to_str())
        .unwrap_or("unknown")
        .to_string();
    println!("cargo:rustc-env=LASH_PROFILE={profile}");
    println!("cargo:rerun-if-changed=build.rs");
}
