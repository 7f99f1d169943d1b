//! lash's Python package, end to end: a virtual environment in target/py-venv with numpy, pandas,
//! pytest and maturin from PyPI, a `pip install` of crates/lash-py (built by maturin with the
//! test profile), then its pytest suite (crates/lash-py/pytests), which checks the package
//! against the `lash` binary of this build and runs the example in examples/python/.

use std::path::Path;
use std::process::Command;

#[test]
fn the_python_package_installs_with_pip_and_passes_its_pytest_suite() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let venv = root.join("target").join("py-venv");
    let bin = venv.join("bin");
    let python = bin.join("python");
    if !python.exists() {
        let ok = Command::new("python3").args(["-m", "venv"]).arg(&venv).status().expect("python3 is needed").success();
        assert!(ok, "creating {}", venv.display());
    }
    let ok = Command::new(&python)
        .args(["-m", "pip", "install", "--quiet", "maturin>=1.9,<2", "numpy", "pandas", "pytest"])
        .status()
        .expect("pip")
        .success();
    assert!(ok, "installing maturin, numpy, pandas and pytest from PyPI into {}", venv.display());
    // maturin on PATH for pip's build backend; the test profile (release without fat LTO).
    let path = format!("{}:{}", bin.display(), std::env::var("PATH").unwrap_or_default());
    let install = Command::new(&python)
        .args(["-m", "pip", "install", "--quiet", "--no-build-isolation", "--force-reinstall", "--no-deps"])
        .arg(root.join("crates").join("lash-py"))
        .env("PATH", &path)
        .env("MATURIN_PEP517_ARGS", "--profile ci")
        .output()
        .expect("pip install");
    assert!(
        install.status.success(),
        "pip install crates/lash-py:\n{}\n{}",
        String::from_utf8_lossy(&install.stdout),
        String::from_utf8_lossy(&install.stderr)
    );
    let tests = Command::new(&python)
        .args(["-m", "pytest", "-q", "-p", "no:cacheprovider"])
        .arg(root.join("crates").join("lash-py").join("pytests"))
        .env("LASH_BIN", env!("CARGO_BIN_EXE_lash"))
        .env("LASH_ROOT", root)
        .current_dir(std::env::temp_dir())
        .output()
        .expect("pytest");
    let out = String::from_utf8_lossy(&tests.stdout);
    eprintln!("{out}{}", String::from_utf8_lossy(&tests.stderr));
    assert!(tests.status.success(), "the pytest suite of the Python package failed:\n{out}");
    assert!(out.contains(" passed"), "pytest ran no tests:\n{out}");
}
