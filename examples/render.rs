//! Render a scene from Rust: `cargo run --example render -- SCENE OUT.png
//! [SPP]`. The library API in a few lines: load, configure, render, write.

use embertrace::{Renderer, Scene};
use std::path::PathBuf;
use std::process::ExitCode;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (Some(scene), Some(out)) = (args.first(), args.get(1)) else {
        eprintln!("usage: render SCENE OUT.png [SPP]");
        return ExitCode::FAILURE;
    };
    let spp = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(16);
    let result = Scene::load(&PathBuf::from(scene)).and_then(|scene| {
        let image = Renderer::new(&scene).spp(spp).render()?;
        image.write(&PathBuf::from(out))?;
        println!(
            "{out}: {} rays in {:.2} s",
            image.rays.total(),
            image.seconds
        );
        Ok(())
    });
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("render: {e}");
            ExitCode::FAILURE
        }
    }
}
