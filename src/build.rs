//! The build script of every package that links Open Image Denoise (feature `denoise`): the core,
//! the command line and the Python module share this file. The `oidn` crate finds the library in
//! `$OIDN_DIR/lib` but leaves the runtime path to whoever links, so each package's binaries, tests
//! and modules get that folder as their run path: they run without `LD_LIBRARY_PATH`.

fn main() {
    println!("cargo:rerun-if-env-changed=OIDN_DIR");
    if std::env::var_os("CARGO_FEATURE_DENOISE").is_none() {
        return;
    }
    let Some(dir) = std::env::var_os("OIDN_DIR") else {
        // The oidn crate's own build then looks for the library with pkg-config.
        println!(
            "cargo:warning=feature `denoise` without OIDN_DIR: set it to the Open Image Denoise 2.x folder \
             (`pip install pyoidn`: <site-packages>/pyoidn/oidn), or have pkg-config find the library"
        );
        return;
    };
    let lib = std::path::Path::new(&dir).join("lib");
    let lib = lib.canonicalize().unwrap_or(lib);
    println!("cargo:rustc-link-arg=-Wl,-rpath,{}", lib.display());
}
