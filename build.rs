//! Build script: records the build's identity (see [`identity`]), and finds
//! Embree 3 and generates its Rust bindings with bindgen.
//!
//! With the `embree` feature (and not `embree4`) it finds Embree 3 and
//! generates bindings ([`embree3`]); with `embree4` the `embree4-sys` crate
//! supplies bindings and asks for `-lembree4`, and this script only says where
//! that library is ([`embree4`]); without either feature there is no Embree.
//!
//! Embree is looked for, in order, in
//! 1. `$EMBREE_DIR/include/embree3/rtcore.h` and `$EMBREE_DIR/lib` (an explicit
//!    `EMBREE_DIR` that does not hold Embree 3 is an error, never skipped);
//! 2. `pkg-config embree3` (Debian ships no .pc file, other systems may);
//! 3. the system headers `/usr/include/embree3/rtcore.h` (or `/usr/local/...`)
//!    with `libembree3` in the default linker paths.
//!
//! If only Embree 4 turns up, the build stops and says to use `--features
//! embree4`. The bindings are configured only through bindgen's options (never
//! by editing its output); enum variants lose their C prefixes through
//! [`StripPrefixes`] so that the names match those of `embree4-sys`
//! (`RTC_FORMAT_FLOAT3` -> `RTCFormat::FLOAT3`) and one safe wrapper compiles
//! against both.

use std::env;

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    identity::run();
    let embree = env::var_os("CARGO_FEATURE_EMBREE").is_some();
    let embree4 = env::var_os("CARGO_FEATURE_EMBREE4").is_some();
    // Without `embree` there is no Embree; with `embree4`, embree4-sys
    // supplies bindings and linking, so there is nothing to find or generate.
    if embree && !embree4 {
        // bindgen is a build-dependency only under the `embree` feature.
        #[cfg(feature = "embree")]
        embree3::run();
    }
    if embree4 {
        embree4::run();
    }
    if env::var_os("CARGO_FEATURE_DENOISE").is_some() {
        oidn_rpath();
    }
}

/// With the `denoise` feature the `oidn` crate links OpenImageDenoise from
/// `$OIDN_DIR/lib` (else pkg-config) but leaves finding it at run time to
/// the loader: put that directory in the binaries' RPATH, as for Embree 4.
/// Without `OIDN_DIR` the library is a system one the loader finds itself.
fn oidn_rpath() {
    println!("cargo:rerun-if-env-changed=OIDN_DIR");
    if let Some(dir) = env::var_os("OIDN_DIR").filter(|d| !d.is_empty()) {
        let lib = std::path::Path::new(&dir).join("lib");
        println!("cargo:rustc-link-arg=-Wl,-rpath,{}", lib.display());
    }
}

/// What the Embree 3 and Embree 4 steps share: stopping the build with a
/// message, pkg-config, and the places libraries live.
mod find {
    use std::path::{Path, PathBuf};

    /// Stop the build with `message`. Cargo prints each `cargo::error` line as
    /// `error: embertrace@...: <line>` and fails the build once the script
    /// ends (Rust >= 1.84; the crate needs 1.85), so exiting with status 0
    /// keeps cargo's output to the message alone instead of adding a dump of
    /// the script's stdout and stderr.
    pub fn fail(message: &str) -> ! {
        for line in message.lines() {
            println!("cargo::error={line}");
        }
        std::process::exit(0);
    }

    /// Whether `dir` holds `lib<name>` in any form (shared, versioned or static).
    pub fn has_lib(dir: &Path, name: &str) -> bool {
        let prefix = format!("lib{name}.");
        std::fs::read_dir(dir).is_ok_and(|entries| {
            entries
                .flatten()
                .any(|e| e.file_name().to_string_lossy().starts_with(&prefix))
        })
    }

    /// Run `pkg-config --cflags --libs <name>`; `None` when pkg-config is absent
    /// or does not know the package.
    pub fn pkg_config(name: &str) -> Option<String> {
        let out = std::process::Command::new("pkg-config")
            .args(["--cflags", "--libs", name])
            .output()
            .ok()?;
        if !out.status.success() {
            return None;
        }
        Some(String::from_utf8_lossy(&out.stdout).into_owned())
    }

    /// Library directories the linker searches by default on common systems.
    pub fn system_lib_dirs() -> Vec<PathBuf> {
        let mut dirs: Vec<PathBuf> = [
            "/usr/lib",
            "/usr/lib64",
            "/usr/local/lib",
            "/usr/local/lib64",
        ]
        .iter()
        .map(PathBuf::from)
        .collect();
        // Debian multiarch: /usr/lib/x86_64-linux-gnu and friends.
        if let Ok(entries) = std::fs::read_dir("/usr/lib") {
            dirs.extend(
                entries
                    .flatten()
                    .filter(|e| e.file_name().to_string_lossy().contains("-linux-"))
                    .map(|e| e.path()),
            );
        }
        dirs
    }
}

#[cfg(feature = "embree")]
mod embree3 {
    use crate::find::{fail, has_lib, pkg_config, system_lib_dirs};
    use bindgen::callbacks::{EnumVariantValue, ParseCallbacks};
    use std::env;
    use std::path::{Path, PathBuf};

    /// The one fix to print whenever Embree 3 or libclang is missing.
    const FIX: &str = "install them with: apt-get install libembree-dev libclang-dev   \
                       (or build without Embree: cargo build --no-default-features)";

    /// The message for a missing Embree 3 or libclang.
    fn missing(what: &str) -> ! {
        fail(&format!(
            "the `embree` feature needs the Embree 3 headers and library and libclang, \
             but {what}.\n{FIX}"
        ))
    }

    /// The message for a system that only has Embree 4.
    fn only_embree4(found: &str) -> ! {
        fail(&format!(
            "found Embree 4 ({found}) but not Embree 3, which the default `embree` feature \
             binds; build with `--features embree4` (the embree4-sys crate) instead, \
             or install Embree 3 (apt-get install libembree-dev)"
        ))
    }

    /// Where Embree 3 was found.
    #[derive(Debug, Default)]
    struct Embree3 {
        /// Path of `rtcore.h`.
        header: PathBuf,
        /// Extra clang arguments (`-I`, `-D` from pkg-config or `EMBREE_DIR`).
        clang_args: Vec<String>,
        /// Library search directories.
        link_search: Vec<PathBuf>,
        /// Libraries to link.
        link_libs: Vec<String>,
    }

    /// `<dir>/embree<major>/rtcore.h` when it exists.
    fn header_in(include_dir: &Path, major: u32) -> Option<PathBuf> {
        let h = include_dir.join(format!("embree{major}")).join("rtcore.h");
        h.is_file().then_some(h)
    }

    /// Step 1: `EMBREE_DIR`. `None` when unset; an error when set but wrong.
    fn from_embree_dir() -> Option<Embree3> {
        let dir = PathBuf::from(env::var_os("EMBREE_DIR")?);
        let include = dir.join("include");
        let Some(header) = header_in(&include, 3) else {
            if header_in(&include, 4).is_some() {
                only_embree4(&format!("EMBREE_DIR={}", dir.display()));
            }
            missing(&format!(
                "EMBREE_DIR={} has no include/embree3/rtcore.h",
                dir.display()
            ));
        };
        let Some(lib) = ["lib", "lib64"]
            .iter()
            .map(|l| dir.join(l))
            .find(|l| has_lib(l, "embree3"))
        else {
            missing(&format!(
                "EMBREE_DIR={} has no lib/libembree3.*",
                dir.display()
            ));
        };
        Some(Embree3 {
            header,
            clang_args: vec![format!("-I{}", include.display())],
            link_search: vec![lib],
            link_libs: vec!["embree3".to_string()],
        })
    }

    /// System include directories searched for `embree<major>/rtcore.h`.
    const SYSTEM_INCLUDES: [&str; 2] = ["/usr/include", "/usr/local/include"];

    /// Step 2: pkg-config's `embree3`.
    fn from_pkg_config() -> Option<Embree3> {
        let flags = pkg_config("embree3")?;
        let mut found = Embree3::default();
        let mut include_dirs = Vec::new();
        for token in flags.split_whitespace() {
            if let Some(dir) = token.strip_prefix("-I") {
                include_dirs.push(PathBuf::from(dir));
                found.clang_args.push(token.to_string());
            } else if let Some(dir) = token.strip_prefix("-L") {
                found.link_search.push(PathBuf::from(dir));
            } else if let Some(lib) = token.strip_prefix("-l") {
                found.link_libs.push(lib.to_string());
            } else if token.starts_with("-D") {
                found.clang_args.push(token.to_string());
            }
        }
        if found.link_libs.is_empty() {
            found.link_libs.push("embree3".to_string());
        }
        let candidates = include_dirs
            .iter()
            .map(PathBuf::as_path)
            .chain(SYSTEM_INCLUDES.iter().map(Path::new));
        found.header = candidates.into_iter().find_map(|d| header_in(d, 3))?;
        Some(found)
    }

    /// Step 3: system headers plus `libembree3` in a default linker path.
    fn from_system() -> Option<Embree3> {
        let header = SYSTEM_INCLUDES
            .iter()
            .find_map(|d| header_in(Path::new(d), 3))?;
        let Some(lib_dir) = system_lib_dirs()
            .into_iter()
            .find(|d| has_lib(d, "embree3"))
        else {
            missing(&format!(
                "{} exists but libembree3 is in no default library directory \
                 (set EMBREE_DIR to an Embree 3 install to override)",
                header.display()
            ));
        };
        let mut found = Embree3 {
            header,
            link_libs: vec!["embree3".to_string()],
            ..Embree3::default()
        };
        if lib_dir.starts_with("/usr/local") {
            found.link_search.push(lib_dir);
        }
        Some(found)
    }

    /// Where Embree 4 is, when it is (for the "use --features embree4" message).
    fn find_embree4() -> Option<String> {
        if pkg_config("embree4").is_some() {
            return Some("pkg-config embree4".to_string());
        }
        SYSTEM_INCLUDES
            .iter()
            .find_map(|d| header_in(Path::new(d), 4))
            .map(|h| h.display().to_string())
    }

    /// Embree 3, by `EMBREE_DIR`, pkg-config, then system paths; the build
    /// stops with one message when none has it.
    fn locate() -> Embree3 {
        println!("cargo:rerun-if-env-changed=EMBREE_DIR");
        println!("cargo:rerun-if-env-changed=PKG_CONFIG_PATH");
        if let Some(found) = from_embree_dir() {
            return found;
        }
        if let Some(found) = from_pkg_config().or_else(from_system) {
            return found;
        }
        if let Some(found) = find_embree4() {
            only_embree4(&found);
        }
        missing(
            "neither EMBREE_DIR, nor pkg-config embree3, nor /usr/include/embree3/rtcore.h \
             has them",
        )
    }

    /// The C prefixes stripped from enum variants: the same list `embree4-sys`
    /// removes from its output (so the generated names agree), plus Embree 3's
    /// `RTCIntersectContextFlags` prefix, the analogue of Embree 4's
    /// `RTC_RAY_QUERY_FLAG_`.
    const PREFIXES: [&str; 12] = [
        "RTC_FORMAT_",
        "RTC_BUILD_QUALITY_",
        "RTC_RAY_QUERY_FLAG_",
        "RTC_INTERSECT_CONTEXT_FLAG_",
        "RTC_DEVICE_PROPERTY_",
        "RTC_ERROR_",
        "RTC_BUFFER_TYPE_",
        "RTC_GEOMETRY_TYPE_",
        "RTC_SUBDIVISION_MODE_",
        "RTC_CURVE_FLAG_",
        "RTC_SCENE_FLAG_",
        "RTC_BUILD_FLAG_",
    ];

    /// Renames `RTC_FORMAT_FLOAT3` to `FLOAT3`, `RTC_SCENE_FLAG_ROBUST` to
    /// `ROBUST`, and so on.
    #[derive(Debug)]
    struct StripPrefixes;

    impl ParseCallbacks for StripPrefixes {
        fn enum_variant_name(
            &self,
            _enum_name: Option<&str>,
            original: &str,
            _value: EnumVariantValue,
        ) -> Option<String> {
            PREFIXES
                .iter()
                .find_map(|p| original.strip_prefix(p))
                .map(str::to_string)
        }
    }

    /// Locate Embree 3, emit the link directives, and write
    /// `$OUT_DIR/embree_bindings.rs`.
    pub fn run() {
        let found = locate();
        for dir in &found.link_search {
            println!("cargo:rustc-link-search=native={}", dir.display());
        }
        for lib in &found.link_libs {
            println!("cargo:rustc-link-lib={lib}");
        }

        let builder = bindgen::Builder::default()
            .header(found.header.display().to_string())
            .clang_args(&found.clang_args)
            .allowlist_function("rtc.*")
            .allowlist_type("RTC.*")
            .allowlist_var("RTC.*")
            .rustified_enum("RTCFormat")
            .rustified_enum("RTCBuildQuality")
            .rustified_enum("RTCError")
            .rustified_enum("RTCBufferType")
            .rustified_enum("RTCGeometryType")
            .rustified_enum("RTCDeviceProperty")
            .rustified_enum("RTCSubdivisionMode")
            .bitfield_enum("RTC.*Flags")
            .derive_default(true)
            .layout_tests(false)
            .parse_callbacks(Box::new(StripPrefixes))
            .parse_callbacks(Box::new(bindgen::CargoCallbacks::new()));

        // bindgen panics (rather than returning an error) when it cannot load
        // libclang; turn that into the same one message as a missing Embree.
        let previous_hook = std::panic::take_hook();
        std::panic::set_hook(Box::new(|_| {}));
        // AssertUnwindSafe: after a panic the builder is gone and the build stops.
        let generated =
            std::panic::catch_unwind(std::panic::AssertUnwindSafe(move || builder.generate()));
        std::panic::set_hook(previous_hook);
        let bindings = match generated {
            Ok(Ok(bindings)) => bindings,
            Ok(Err(e)) => missing(&format!(
                "bindgen could not parse {}: {e}",
                found.header.display()
            )),
            Err(panic) => {
                let why = panic
                    .downcast_ref::<String>()
                    .map(String::as_str)
                    .or_else(|| panic.downcast_ref::<&str>().copied())
                    .unwrap_or("bindgen panicked");
                missing(&format!("bindgen failed ({why})"))
            }
        };

        let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"))
            .join("embree_bindings.rs");
        if let Err(e) = bindings.write_to_file(&out) {
            fail(&format!("cannot write {}: {e}", out.display()));
        }
    }
}

/// Where `libembree4` is, for the `embree4` feature: `embree4-sys` generates
/// the bindings from the headers it carries and asks for `-lembree4`, but
/// says nothing about where the library lives. Looked for, in order, in
/// 1. `$EMBREE_DIR/lib` (or `lib64`), such as the directory
///    `scripts/embree4.sh` prints (an explicit `EMBREE_DIR` without
///    `libembree4` is an error, never skipped);
/// 2. `pkg-config embree4`;
/// 3. the default library directories.
///
/// A directory the linker would not search by default is added to the
/// search path and, so that the binaries, tests and Python module find the
/// library when they run, to their RPATH.
mod embree4 {
    use crate::find::{fail, has_lib, pkg_config, system_lib_dirs};
    use std::env;
    use std::path::PathBuf;

    /// The one fix to print whenever Embree 4 is missing.
    const FIX: &str = "install your system's Embree 4 (e.g. `dnf install embree-devel`, \
                       `brew install embree`) or, on Debian 12, which has none, \
                       `export EMBREE_DIR=\"$(bash scripts/embree4.sh)\"` (Embree 4.4 \
                       from PyPI's embreex wheel); or use Embree 3 (the default features)";

    fn missing(what: &str) -> ! {
        fail(&format!(
            "the `embree4` feature needs libembree4, but {what}.\n{FIX}"
        ))
    }

    /// Directories to add to the link search path and the RPATH.
    fn locate() -> Vec<PathBuf> {
        println!("cargo:rerun-if-env-changed=EMBREE_DIR");
        println!("cargo:rerun-if-env-changed=PKG_CONFIG_PATH");
        if let Some(dir) = env::var_os("EMBREE_DIR").map(PathBuf::from) {
            let Some(lib) = ["lib", "lib64", ""]
                .iter()
                .map(|l| dir.join(l))
                .find(|l| has_lib(l, "embree4"))
            else {
                missing(&format!(
                    "EMBREE_DIR={} has no lib/libembree4.*",
                    dir.display()
                ));
            };
            return vec![lib];
        }
        if let Some(flags) = pkg_config("embree4") {
            return flags
                .split_whitespace()
                .filter_map(|t| t.strip_prefix("-L"))
                .map(PathBuf::from)
                .collect();
        }
        if system_lib_dirs().iter().any(|d| has_lib(d, "embree4")) {
            return Vec::new();
        }
        missing(
            "neither EMBREE_DIR, nor pkg-config embree4, nor a default library directory has it",
        )
    }

    pub fn run() {
        for dir in locate() {
            println!("cargo:rustc-link-search=native={}", dir.display());
            println!("cargo:rustc-link-arg=-Wl,-rpath,{}", dir.display());
        }
    }
}

/// The build's identity, for `--version` and the farm's provenance
/// (`src/build_info.rs`): `EMBERTRACE_SOURCE_DIGEST`, a 64-bit FNV-1a hash
/// of every file under `src/` (by path, sorted), `build.rs` and
/// `Cargo.lock`, and the enabled features, so that two builds from different
/// code (anything that could change a pixel) differ; and `EMBERTRACE_COMMIT`, the commit the
/// tree was at (`-dirty` when it had changes), or `unknown` outside a git
/// checkout.
mod identity {
    use std::path::{Path, PathBuf};
    use std::process::Command;

    fn files(dir: &Path, out: &mut Vec<PathBuf>) {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        for e in entries.flatten() {
            let p = e.path();
            if p.is_dir() {
                files(&p, out);
            } else {
                out.push(p);
            }
        }
    }

    fn git(args: &[&str]) -> Option<String> {
        let o = Command::new("git").args(args).output().ok()?;
        o.status
            .success()
            .then(|| String::from_utf8_lossy(&o.stdout).trim().to_string())
    }

    pub fn run() {
        let root = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").expect("cargo sets it"));
        let mut paths = vec![root.join("build.rs"), root.join("Cargo.lock")];
        files(&root.join("src"), &mut paths);
        paths.sort();
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        let mut eat = |bytes: &[u8]| {
            for &b in bytes {
                h = (h ^ u64::from(b)).wrapping_mul(0x100_0000_01b3);
            }
        };
        for p in &paths {
            let rel = p.strip_prefix(&root).unwrap_or(p);
            eat(rel.to_string_lossy().as_bytes());
            eat(&[0]);
            eat(&std::fs::read(p).unwrap_or_default());
            eat(&[0]);
        }
        // The features choose the ray backend (Embree 3 or 4 may round a hit
        // differently), so builds of one tree with different features differ.
        let mut features: Vec<String> = std::env::vars()
            .filter_map(|(k, _)| k.strip_prefix("CARGO_FEATURE_").map(str::to_string))
            .collect();
        features.sort();
        eat(features.join(",").as_bytes());
        println!("cargo:rustc-env=EMBERTRACE_SOURCE_DIGEST={h:016x}");
        println!(
            "cargo:rustc-env=EMBERTRACE_FEATURES={}",
            features.join(",").to_lowercase()
        );
        let commit = match git(&["rev-parse", "--short=12", "HEAD"]) {
            Some(c) => {
                let dirty = git(&[
                    "--no-optional-locks",
                    "status",
                    "--porcelain",
                    "--untracked-files=no",
                ])
                .is_some_and(|s| !s.is_empty());
                if dirty { format!("{c}-dirty") } else { c }
            }
            None => "unknown".to_string(),
        };
        println!("cargo:rustc-env=EMBERTRACE_COMMIT={commit}");
        println!("cargo:rerun-if-changed=src");
        println!("cargo:rerun-if-changed=Cargo.lock");
        for f in [".git/HEAD", ".git/index"] {
            if root.join(f).exists() {
                println!("cargo:rerun-if-changed={f}");
            }
        }
    }
}
