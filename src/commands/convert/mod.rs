//! `embertrace convert IN OUT.toml`: any scene the renderer reads, written
//! as a TOML scene with its meshes and images beside it ([`writer`]).

mod writer;

pub use writer::{Written, convert};

use crate::error::Result;
use crate::scene::Scene;
use clap::Args;
use std::path::PathBuf;

/// The arguments of `embertrace convert`.
#[derive(Args)]
pub struct ConvertArgs {
    /// The scene to convert.
    input: PathBuf,
    /// The TOML scene to write (meshes and images go beside it).
    output: PathBuf,
}

/// Run `embertrace convert`.
pub fn run(args: ConvertArgs) -> Result<()> {
    let scene = Scene::load(&args.input)?;
    let w = convert(&scene, &args.output)?;
    crate::log::note(&format!(
        "wrote {} ({} files)",
        args.output.display(),
        w.files.len()
    ));
    Ok(())
}
