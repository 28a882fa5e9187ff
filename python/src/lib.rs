//! `import embertrace`: the renderer from Python, an image as a NumPy array.
//!
//! ```python
//! import embertrace
//! image = embertrace.render("scenes/cornell-box.toml", spp=64)  # (h, w, 3) float32
//! scene = embertrace.load("scenes/cornell-box.toml"); scene.plan()["effects"]
//! ```
//!
//! How a render runs: a worker thread renders in passes
//! ([`Renderer::render_in_passes`]) while the calling thread, with the GIL
//! released, waits for the passes' reports. Between reports (at least every
//! [`POLL`]) it takes the GIL back to call the progress callback and to
//! run Python's signal handlers: Ctrl-C (`KeyboardInterrupt`), or an
//! exception from the callback, asks the worker to stop after its pass,
//! waits for it, and raises. Other Python threads run meanwhile. The image
//! is the same, bit for bit, as `embertrace render`'s with the same
//! settings, whatever the passes or threads.
//!
//! No `unsafe` here: what PyO3 and rust-numpy do with the C API stays in
//! those crates.

#![deny(unsafe_code)]

use embertrace::guiding::GuidingMode;
use embertrace::plan::Plan;
use embertrace::scene::LoadOptions;
use embertrace::settings::{self, Flags};
use embertrace::{Backend, Error, PassProgress, Renderer, Scene as CoreScene};
use numpy::{PyArray1, PyArray3, PyArrayMethods};
use pyo3::create_exception;
use pyo3::exceptions::{PyKeyboardInterrupt, PyOSError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::time::Duration;

create_exception!(
    embertrace,
    SceneError,
    PyValueError,
    "A scene file that cannot be read: the message names the file and line."
);

/// How long the calling thread waits, GIL released, before it looks at
/// Python's signals again when no pass has finished.
const POLL: Duration = Duration::from_millis(50);

/// Passes a render is split into when the caller does not say: enough that
/// Ctrl-C and the progress callback come every 1/64 of the render, few
/// enough that the pass boundaries (where the threads wait for the slowest
/// tile) cost nothing measurable.
const DEFAULT_PASSES: u32 = 64;

/// The Python exception for one of the crate's errors.
fn to_py(e: Error) -> PyErr {
    let message = e.to_string();
    match e {
        Error::Input { .. } => SceneError::new_err(message),
        Error::Io { .. } => PyOSError::new_err(message),
        Error::Settings(_) | Error::Strict(_) => PyValueError::new_err(message),
        Error::Interrupted(_) => PyKeyboardInterrupt::new_err(message),
        _ => PyRuntimeError::new_err(message),
    }
}

/// A loaded scene: `embertrace.load(path)`.
#[pyclass(name = "Scene", module = "embertrace", frozen)]
struct Scene {
    inner: CoreScene,
}

/// What one render asks for; `None` takes the scene's own setting.
struct Options {
    spp: Option<u32>,
    resolution: Option<(u32, u32)>,
    seed: u64,
    threads: usize,
    /// `None`: the command line's default for the scene.
    accel: Option<String>,
    max_depth: Option<u32>,
    passes: Option<u32>,
    denoise: bool,
    guiding: String,
}

#[pymethods]
impl Scene {
    /// The file the scene came from.
    #[getter]
    fn path(&self) -> PathBuf {
        self.inner.source.clone()
    }

    /// The scene's own resolution, `(width, height)`.
    #[getter]
    fn resolution(&self) -> (u32, u32) {
        let [w, h] = self.inner.resolution;
        (w, h)
    }

    /// Triangles in the scene.
    #[getter]
    fn triangles(&self) -> usize {
        self.inner.triangle_count()
    }

    /// The effects plan, as `embertrace plan --json` prints it: `effects`
    /// (the names that are on), `kernel`, `details`.
    #[pyo3(signature = (max_depth=None))]
    fn plan<'py>(&self, py: Python<'py>, max_depth: Option<u32>) -> PyResult<Bound<'py, PyAny>> {
        let flags = Flags {
            max_depth,
            ..Flags::default()
        };
        let s =
            settings::resolve(&self.inner.render, self.inner.resolution, &flags).map_err(to_py)?;
        let json = Plan::new(&self.inner, &s.integrator).json();
        py.import("json")?.call_method1("loads", (json,))
    }

    /// Render the scene; see `embertrace.render`.
    #[pyo3(signature = (spp=None, resolution=None, seed=0, threads=0, accel=None, denoise=false, *, max_depth=None, passes=None, progress=None, guiding="auto"))]
    #[allow(clippy::too_many_arguments)] // Python's keyword arguments
    fn render<'py>(
        &self,
        py: Python<'py>,
        spp: Option<u32>,
        resolution: Option<(u32, u32)>,
        seed: u64,
        threads: usize,
        accel: Option<&str>,
        denoise: bool,
        max_depth: Option<u32>,
        passes: Option<u32>,
        progress: Option<Bound<'py, PyAny>>,
        guiding: &str,
    ) -> PyResult<Bound<'py, PyArray3<f32>>> {
        let options = Options {
            spp,
            resolution,
            seed,
            threads,
            accel: accel.map(str::to_string),
            max_depth,
            passes,
            denoise,
            guiding: guiding.to_string(),
        };
        render_scene(py, &self.inner, &options, progress.as_ref())
    }

    fn __repr__(&self) -> String {
        let [w, h] = self.inner.resolution;
        format!(
            "<embertrace.Scene {:?}: {} triangles, {w}x{h}>",
            self.inner.source.display().to_string(),
            self.inner.triangle_count()
        )
    }
}

/// Render `scene` as [`Options`] say, reporting passes to `progress`.
fn render_scene<'py>(
    py: Python<'py>,
    scene: &CoreScene,
    o: &Options,
    progress: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyArray3<f32>>> {
    let backend: Option<Backend> = o
        .accel
        .as_deref()
        .map(|a| {
            a.parse()
                .map_err(|e| PyValueError::new_err(format!("accel={a:?}: {e}")))
        })
        .transpose()?;
    let guiding: GuidingMode = o
        .guiding
        .parse()
        .map_err(|e| PyValueError::new_err(format!("guiding={:?}: {e}", o.guiding)))?;
    let mut renderer = Renderer::new(scene)
        .guiding(guiding)
        .seed(o.seed)
        .threads(o.threads)
        .denoise(o.denoise);
    if let Some(backend) = backend {
        renderer = renderer.backend(backend);
    }
    if let Some(spp) = o.spp {
        renderer = renderer.spp(spp);
    }
    if let Some((w, h)) = o.resolution {
        renderer = renderer.resolution(w, h);
    }
    if let Some(d) = o.max_depth {
        renderer = renderer.max_depth(d);
    }
    let passes = o.passes.unwrap_or(DEFAULT_PASSES);
    if passes == 0 {
        return Err(PyValueError::new_err("passes must be at least 1"));
    }
    let stop = AtomicBool::new(false);
    let (tx, mut rx) = mpsc::channel::<PassProgress>();
    let (rendered, python_error) = std::thread::scope(|s| {
        let renderer = &renderer;
        let stop = &stop;
        let worker = s.spawn(move || {
            // `tx` moves here and drops when the render ends, which
            // disconnects the channel and ends the loop below.
            let tx = tx;
            renderer.render_in_passes(passes, stop, &|p| {
                let _ = tx.send(p);
            })
        });
        let mut python_error = None;
        loop {
            // The receiver is not `Sync`, so it travels into the closure
            // that runs without the GIL and back.
            let (message, back) = py.detach(move || (rx.recv_timeout(POLL), rx));
            rx = back;
            let outcome = match message {
                Ok(p) => progress.map_or(Ok(()), |f| report(py, f, &p)),
                Err(RecvTimeoutError::Timeout) => Ok(()),
                Err(RecvTimeoutError::Disconnected) => break,
            }
            .and_then(|()| py.check_signals());
            if let Err(e) = outcome {
                stop.store(true, Ordering::SeqCst);
                python_error = Some(e);
                break;
            }
        }
        let rendered = py.detach(|| worker.join());
        (rendered, python_error)
    });
    if let Some(e) = python_error {
        return Err(e);
    }
    let rendered = rendered
        .map_err(|_| PyRuntimeError::new_err("the render thread panicked"))?
        .map_err(to_py)?;
    let [w, h] = [rendered.film.width(), rendered.film.height()];
    let rgb: Vec<f32> = rendered.pixels().into_iter().flatten().collect();
    PyArray1::from_vec(py, rgb).reshape([h as usize, w as usize, 3])
}

/// Call `progress` with one pass's report, as a dict.
fn report(py: Python<'_>, progress: &Bound<'_, PyAny>, p: &PassProgress) -> PyResult<()> {
    let d = PyDict::new(py);
    d.set_item("pass", p.pass)?;
    d.set_item("passes", p.passes)?;
    d.set_item("samples", p.samples)?;
    d.set_item("spp", p.spp)?;
    d.set_item("seconds", p.seconds)?;
    progress.call1((d,)).map(drop)
}

/// Load a scene file (TOML, OBJ, PLY, glTF, pbrt-v4, Mitsuba 3 XML, CS184
/// `.dae`, CSE 167/168 `.test`); `camera` picks one by name in a file that
/// holds several.
#[pyfunction]
#[pyo3(signature = (path, camera=None))]
fn load(py: Python<'_>, path: PathBuf, camera: Option<String>) -> PyResult<Scene> {
    let inner = py
        .detach(move || CoreScene::load_with(&path, &LoadOptions { camera }))
        .map_err(to_py)?;
    Ok(Scene { inner })
}

/// Render a scene (a path or a loaded `Scene`) and return the image as a
/// NumPy array of shape `(height, width, 3)`, float32, linear RGB, rows from
/// the top. `spp`, `resolution` (`(width, height)`) and `max_depth` default
/// to the scene's; `threads=0` uses every core; `accel` is `"embree"`,
/// `"bvh"`, `"naive"` or `"embree+naive"` (`None`: the command line's
/// default for the scene); `denoise` runs Intel Open Image Denoise at the end (a module built
/// with the `denoise` feature); `passes` (default 64) splits the samples, and `progress` is
/// called after each pass with a dict (`pass`, `passes`, `samples`, `spp`,
/// `seconds`); `guiding` is `"auto"`, `"on"` or `"off"`, as `render
/// --guiding`. Ctrl-C stops the render after the pass under way.
#[pyfunction]
#[pyo3(signature = (scene, spp=None, resolution=None, seed=0, threads=0, accel=None, denoise=false, *, max_depth=None, passes=None, progress=None, guiding="auto"))]
#[allow(clippy::too_many_arguments)] // Python's keyword arguments
fn render<'py>(
    py: Python<'py>,
    scene: &Bound<'py, PyAny>,
    spp: Option<u32>,
    resolution: Option<(u32, u32)>,
    seed: u64,
    threads: usize,
    accel: Option<&str>,
    denoise: bool,
    max_depth: Option<u32>,
    passes: Option<u32>,
    progress: Option<Bound<'py, PyAny>>,
    guiding: &str,
) -> PyResult<Bound<'py, PyArray3<f32>>> {
    let loaded = match scene.cast::<Scene>() {
        Ok(s) => s.clone(),
        Err(_) => Bound::new(py, load(py, scene.extract()?, None)?)?,
    };
    loaded.get().render(
        py, spp, resolution, seed, threads, accel, denoise, max_depth, passes, progress, guiding,
    )
}

/// The build: `version`, `commit`, `source` (the digest of its code),
/// `features` and `embree` (the Embree library it runs on, or None).
#[pyfunction]
fn build_info(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    use embertrace::build_info as b;
    let d = PyDict::new(py);
    d.set_item("version", b::VERSION)?;
    d.set_item("commit", b::COMMIT)?;
    d.set_item("source", b::SOURCE_DIGEST)?;
    d.set_item("features", b::FEATURES)?;
    d.set_item("embree", embertrace::accel::embree_library())?;
    Ok(d)
}

#[pymodule(name = "embertrace")]
fn embertrace_module(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", embertrace::build_info::VERSION)?;
    m.add("SceneError", m.py().get_type::<SceneError>())?;
    m.add_class::<Scene>()?;
    m.add_function(wrap_pyfunction!(load, m)?)?;
    m.add_function(wrap_pyfunction!(render, m)?)?;
    m.add_function(wrap_pyfunction!(build_info, m)?)?;
    Ok(())
}
