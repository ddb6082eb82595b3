//! Build script: finds Embree (4, then 3), generates its bindings with bindgen and compiles
//! the small C shim in `ffi/` that hides the Embree 3/4 API differences.
//!
//! Search order:
//! 1. `PIR_NO_EMBREE=1`: skip the search (build the pure-Rust backends only; for testing the
//!    fallback on a machine that has Embree).
//! 2. `EMBREE_DIR`: `$EMBREE_DIR/include/embree{4,3}/rtcore.h` and the library in
//!    `$EMBREE_DIR/lib` (or `lib64`); an rpath to that directory is added.
//! 3. System headers: `embree4/rtcore.h`, then `embree3/rtcore.h` in `/usr/include` and
//!    `/usr/local/include`, the library in the usual library directories.
//!
//! The version comes from `rtcore_config.h` (`RTC_VERSION_MAJOR`/`MINOR`/`PATCH`); Debian ships
//! no pkg-config file. Bindings are generated from the installed headers, never checked in:
//! a header/library mismatch silently corrupts the ray/hit structs.
//!
//! When found: `cargo:rustc-cfg=pir_embree`, `PIR_EMBREE_VERSION=<x.y.z>`. With
//! `PIR_NO_EMBREE=1`: `cargo:rustc-cfg=pir_no_embree` (without Embree on purpose; the tests
//! that need Embree then skip even on CI). When not found:
//! one `cargo:warning=` with the install hint, and the crate builds without Embree — unless
//! `PIR_REQUIRE_EMBREE=1`, which turns a missing Embree into a build error.
//! Either way `PIR_EMBREE_STATUS` describes the outcome for `pir::accel::embree_status()`.

use std::env;
use std::fs;
use std::path::{Path, PathBuf};

const INSTALL_HINT: &str = "install it with `apt-get install libembree-dev libclang-dev` (or set EMBREE_DIR to \
     an Embree 3/4 install prefix) and rebuild";

/// An Embree installation: headers, library and version.
struct Found {
    major: u32,
    version: String,
    include_dir: PathBuf,
    /// A directory to add to the link search path (and rpath), when not a system directory.
    lib_dir: Option<PathBuf>,
    config_header: PathBuf,
}

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    for f in ["ffi/wrapper.h", "ffi/pir_embree.h", "ffi/pir_embree.c"] {
        println!("cargo:rerun-if-changed={f}");
    }
    for v in ["EMBREE_DIR", "PIR_REQUIRE_EMBREE", "PIR_NO_EMBREE"] {
        println!("cargo:rerun-if-env-changed={v}");
    }
    println!("cargo:rustc-check-cfg=cfg(pir_embree)");
    println!("cargo:rustc-check-cfg=cfg(pir_no_embree)");

    let require = flag("PIR_REQUIRE_EMBREE");
    let result = if flag("PIR_NO_EMBREE") {
        println!("cargo:rustc-cfg=pir_no_embree");
        Err("disabled by PIR_NO_EMBREE=1".to_string())
    } else {
        find_embree().and_then(|found| build_embree(&found).map(|()| found))
    };

    match result {
        Ok(found) => {
            println!("cargo:rustc-cfg=pir_embree");
            println!("cargo:rustc-env=PIR_EMBREE_VERSION={}", found.version);
            println!(
                "cargo:rustc-env=PIR_EMBREE_STATUS=embree {} ({})",
                found.version,
                found.include_dir.display()
            );
        }
        Err(why) => {
            if require {
                panic!("PIR_REQUIRE_EMBREE=1 but Embree cannot be used: {why}; {INSTALL_HINT}");
            }
            println!("cargo:warning=Embree not found ({why}): building pir without it; {INSTALL_HINT}");
            println!("cargo:rustc-env=PIR_EMBREE_VERSION=");
            println!("cargo:rustc-env=PIR_EMBREE_STATUS=not built in ({why}); {INSTALL_HINT}");
        }
    }
}

/// True when the environment variable is set to something other than empty, `0` or `false`.
fn flag(name: &str) -> bool {
    env::var(name).map(|v| !matches!(v.trim(), "" | "0" | "false" | "no")).unwrap_or(false)
}

fn find_embree() -> Result<Found, String> {
    if let Some(dir) = env::var_os("EMBREE_DIR").filter(|d| !d.is_empty()) {
        let dir = PathBuf::from(dir);
        let include = dir.join("include");
        let (major, include_dir) = find_header(std::slice::from_ref(&include))
            .ok_or_else(|| format!("no embree4/rtcore.h or embree3/rtcore.h under {}", include.display()))?;
        let libname = format!("embree{major}");
        let lib_dir = [dir.join("lib"), dir.join("lib64"), dir.join("lib").join(multiarch_triple())]
            .into_iter()
            .find(|d| has_library(d, &libname))
            .ok_or_else(|| {
                format!("no lib{libname} under {}/lib, lib64 or lib/<multiarch>", dir.display())
            })?;
        return finish(major, include_dir, Some(lib_dir));
    }

    let includes: Vec<PathBuf> = ["/usr/include", "/usr/local/include"].iter().map(PathBuf::from).collect();
    let (major, include_dir) = find_header(&includes)
        .ok_or("no embree4/rtcore.h or embree3/rtcore.h in /usr/include or /usr/local/include")?;
    let libname = format!("embree{major}");
    let multiarch = format!("/usr/lib/{}", multiarch_triple());
    let lib_dirs = [multiarch.as_str(), "/usr/lib", "/usr/lib64", "/usr/local/lib", "/usr/local/lib64"];
    let lib_dir = lib_dirs
        .iter()
        .map(PathBuf::from)
        .find(|d| has_library(d, &libname))
        .ok_or_else(|| format!("headers in {} but no lib{libname} to link", include_dir.display()))?;
    // System directories are on the linker's default path; /usr/local may not be.
    let lib_dir = lib_dir.starts_with("/usr/local").then_some(lib_dir);
    finish(major, include_dir, lib_dir)
}

/// Debian's multiarch library directory name for the target, e.g. `x86_64-linux-gnu`.
fn multiarch_triple() -> String {
    let arch = env::var("CARGO_CFG_TARGET_ARCH").unwrap_or_default();
    let os = env::var("CARGO_CFG_TARGET_OS").unwrap_or_default();
    format!("{arch}-{os}-gnu")
}

/// The first `embree4/rtcore.h` or `embree3/rtcore.h` (4 preferred) in `dirs`: (major, dir).
fn find_header(dirs: &[PathBuf]) -> Option<(u32, PathBuf)> {
    [4, 3].into_iter().find_map(|major| {
        dirs.iter().find(|d| d.join(format!("embree{major}/rtcore.h")).is_file()).map(|d| (major, d.clone()))
    })
}

fn has_library(dir: &Path, name: &str) -> bool {
    [format!("lib{name}.so"), format!("lib{name}.dylib"), format!("lib{name}.a"), format!("{name}.lib")]
        .iter()
        .any(|f| dir.join(f).exists())
}

fn finish(major: u32, include_dir: PathBuf, lib_dir: Option<PathBuf>) -> Result<Found, String> {
    let config_header = include_dir.join(format!("embree{major}/rtcore_config.h"));
    let text = fs::read_to_string(&config_header)
        .map_err(|e| format!("cannot read {}: {e}", config_header.display()))?;
    let define = |name: &str| -> Option<String> {
        text.lines().find_map(|l| {
            let mut it = l.split_whitespace();
            (it.next() == Some("#define") && it.next() == Some(name))
                .then(|| it.next().map(str::to_string))?
        })
    };
    let version =
        match (define("RTC_VERSION_MAJOR"), define("RTC_VERSION_MINOR"), define("RTC_VERSION_PATCH")) {
            (Some(a), Some(b), Some(c)) => format!("{a}.{b}.{c}"),
            _ => define("RTC_VERSION_STRING")
                .map(|s| s.trim_matches('"').to_string())
                .ok_or_else(|| format!("no RTC_VERSION_* in {}", config_header.display()))?,
        };
    let header_major: u32 = version.split('.').next().and_then(|m| m.parse().ok()).unwrap_or(0);
    if header_major != major {
        return Err(format!("embree{major}/ headers report version {version}"));
    }
    Ok(Found { major, version, include_dir, lib_dir, config_header })
}

/// Generates the bindings, compiles the shim and emits the link directives.
fn build_embree(found: &Found) -> Result<(), String> {
    println!("cargo:rerun-if-changed={}", found.config_header.display());
    let out = PathBuf::from(env::var("OUT_DIR").expect("OUT_DIR is set by cargo"));
    let manifest = PathBuf::from(env::var("CARGO_MANIFEST_DIR").expect("set by cargo"));
    let ffi = manifest.join("ffi");
    let major_define = format!("PIR_EMBREE_MAJOR={}", found.major);

    // bindgen panics when libclang cannot be loaded; turn that into a "not found" reason.
    let include_arg = format!("-I{}", found.include_dir.display());
    let ffi_arg = format!("-I{}", ffi.display());
    let wrapper = ffi.join("wrapper.h");
    let generated = std::panic::catch_unwind(|| {
        bindgen::Builder::default()
            .header(wrapper.to_string_lossy())
            .clang_arg(&include_arg)
            .clang_arg(&ffi_arg)
            .clang_arg(format!("-D{major_define}"))
            .allowlist_function("rtc.*|pir_.*")
            .allowlist_type("RTC.*")
            .allowlist_var("RTC.*")
            // Enums pir only passes *into* Embree are Rust enums; enums Embree hands back
            // (RTCError in the error callback, …) stay newtypes, because a value missing from
            // a Rust enum (a newer Embree's error code) would be undefined behaviour.
            .default_enum_style(bindgen::EnumVariation::NewType { is_bitfield: false, is_global: false })
            .rustified_enum("RTCBuildQuality|RTCFormat|RTCBufferType|RTCGeometryType|RTCDeviceProperty")
            .bitfield_enum("RTCSceneFlags|RTCBuildFlags")
            .derive_default(true)
            .layout_tests(true)
            .generate()
    });
    let bindings = match generated {
        Ok(Ok(b)) => b,
        Ok(Err(e)) => return Err(format!("bindgen failed on the Embree headers: {e}")),
        Err(_) => return Err("bindgen could not run (is libclang installed?)".into()),
    };
    bindings
        .write_to_file(out.join("embree_bindings.rs"))
        .map_err(|e| format!("cannot write bindings: {e}"))?;

    cc::Build::new()
        .file(ffi.join("pir_embree.c"))
        .include(&found.include_dir)
        .include(&ffi)
        .define("PIR_EMBREE_MAJOR", found.major.to_string().as_str())
        .warnings(true)
        .try_compile("pir_embree_shim")
        .map_err(|e| format!("cannot compile ffi/pir_embree.c: {e}"))?;

    if let Some(dir) = &found.lib_dir {
        println!("cargo:rustc-link-search=native={}", dir.display());
        if env::var("CARGO_CFG_TARGET_OS").as_deref() != Ok("windows") {
            println!("cargo:rustc-link-arg=-Wl,-rpath,{}", dir.display());
        }
    }
    println!("cargo:rustc-link-lib=dylib=embree{}", found.major);
    Ok(())
}
