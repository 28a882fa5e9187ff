//! The library's `Renderer`: a render in passes is the one-pass render bit
//! for bit, reports each pass, and stops between passes when asked (what the
//! Python module's progress callback and Ctrl-C rest on).

use embertrace::{Error, PassProgress, Renderer, Scene};
use std::path::Path;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};

fn cornell() -> Scene {
    Scene::load(Path::new("scenes/cornell-box.toml")).expect("bundled scene loads")
}

#[test]
fn passes_render_the_same_bits_as_one_pass() {
    let scene = cornell();
    let r = Renderer::new(&scene).resolution(24, 16).spp(7).seed(3);
    let one = r.render().unwrap().pixels();
    let reports = Mutex::new(Vec::new());
    let three = r
        .render_in_passes(3, &AtomicBool::new(false), &|p| {
            reports.lock().unwrap().push(p)
        })
        .unwrap()
        .pixels();
    assert_eq!(one, three, "three passes differ from one");
    let reports = reports.into_inner().unwrap();
    let samples: Vec<(u32, u32)> = reports.iter().map(|p| (p.pass, p.samples)).collect();
    // 7 samples in 3 passes end at floor(7 k / 3): 2, 4, 7
    assert_eq!(samples, [(1, 2), (2, 4), (3, 7)]);
    assert!(
        reports
            .iter()
            .all(|p: &PassProgress| p.passes == 3 && p.spp == 7)
    );
    assert!(reports.windows(2).all(|w| w[0].seconds <= w[1].seconds));
}

#[test]
fn more_passes_than_samples_gives_one_pass_per_sample() {
    let scene = cornell();
    let r = Renderer::new(&scene).resolution(8, 8).spp(2);
    let count = Mutex::new(0);
    r.render_in_passes(50, &AtomicBool::new(false), &|p| {
        assert_eq!(p.passes, 2);
        *count.lock().unwrap() += 1;
    })
    .unwrap();
    assert_eq!(*count.lock().unwrap(), 2);
}

#[test]
fn a_stop_set_during_a_pass_ends_the_render_after_it() {
    let scene = cornell();
    let stop = AtomicBool::new(false);
    let passes = Mutex::new(0);
    let r = Renderer::new(&scene).resolution(16, 16).spp(8);
    let err = r
        .render_in_passes(4, &stop, &|_| {
            *passes.lock().unwrap() += 1;
            stop.store(true, Ordering::SeqCst);
        })
        .expect_err("a stopped render is an error");
    assert!(matches!(err, Error::Interrupted(_)), "{err:?}");
    assert!(err.to_string().contains("after 2 of 8 samples"), "{err}");
    assert_eq!(*passes.lock().unwrap(), 1);
}
