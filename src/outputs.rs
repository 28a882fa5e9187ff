//! No input is ever overwritten: the files a command writes are checked,
//! before anything is rendered or written, against each other and against
//! every file it reads (the scene, its textures and environment map, a
//! reference image, the parts of a merge).
//!
//! Two paths are the same file when they name the same place once `.`,
//! `..` and symbolic links are resolved (the folder of a file that does not
//! exist yet is resolved and its name joined), or, where both exist, when
//! they share a device and inode (a hard link). Writes go through a
//! temporary file renamed over the target, so an output onto an input
//! would replace it whole: hence a refusal rather than a warning.

use crate::error::{Error, Result};
use crate::scene::Scene;
use std::path::{Path, PathBuf};

/// Where a path leads: its resolved form and, if it exists, its device and
/// inode.
#[derive(Debug, Clone, PartialEq, Eq)]
struct FileId {
    resolved: Option<PathBuf>,
    inode: Option<(u64, u64)>,
}

impl FileId {
    fn of(path: &Path) -> FileId {
        let resolved = std::fs::canonicalize(path).ok().or_else(|| {
            // not there yet: its folder resolved, its name joined
            let name = path.file_name()?;
            let dir = match path.parent() {
                Some(p) if !p.as_os_str().is_empty() => p,
                _ => Path::new("."),
            };
            Some(std::fs::canonicalize(dir).ok()?.join(name))
        });
        FileId {
            inode: inode(path),
            resolved,
        }
    }

    fn same(&self, other: &FileId) -> bool {
        (self.resolved.is_some() && self.resolved == other.resolved)
            || (self.inode.is_some() && self.inode == other.inode)
    }
}

#[cfg(unix)]
fn inode(path: &Path) -> Option<(u64, u64)> {
    use std::os::unix::fs::MetadataExt;
    std::fs::metadata(path).ok().map(|m| (m.dev(), m.ino()))
}

#[cfg(not(unix))]
fn inode(_: &Path) -> Option<(u64, u64)> {
    None
}

/// Whether `a` and `b` name the same file (see the module header).
pub fn same_file(a: &Path, b: &Path) -> bool {
    FileId::of(a).same(&FileId::of(b))
}

/// One file a command reads.
#[derive(Debug, Clone)]
struct Input {
    path: PathBuf,
    /// What it is, for messages: "the scene file", "a texture of s.toml".
    what: String,
    id: FileId,
}

/// The files a command reads.
#[derive(Debug, Clone, Default)]
pub struct Inputs {
    files: Vec<Input>,
}

impl Inputs {
    /// No files.
    pub fn new() -> Self {
        Inputs::default()
    }

    /// Add `path`, described as `what` in messages.
    pub fn add(&mut self, path: &Path, what: impl Into<String>) {
        self.files.push(Input {
            path: path.to_path_buf(),
            what: what.into(),
            id: FileId::of(path),
        });
    }

    /// The files `scene` was read from that it remembers: the scene file,
    /// its textures and its environment map.
    ///
    /// Mesh files and material libraries are not among them: the scene does
    /// not keep their paths.
    pub fn of_scene(scene: &Scene) -> Self {
        let mut inputs = Inputs::new();
        let name = scene.source.display().to_string();
        inputs.add(&scene.source, "the scene file");
        // every texture: textured parameters, normal and bump maps
        let mut textures: Vec<&Path> = scene
            .materials
            .iter()
            .flat_map(|m| {
                let maps = m.textured().into_iter().map(|(_, t)| t);
                let normal = m.maps.normal.as_ref();
                let bump = m.maps.bump.as_ref().map(|b| &b.texture);
                maps.chain(normal).chain(bump)
            })
            .filter_map(|t| t.source())
            .collect();
        textures.sort();
        textures.dedup();
        for t in textures {
            inputs.add(t, format!("a texture {name} reads"));
        }
        for f in &scene.mesh_files {
            inputs.add(f, format!("a mesh file {name} reads"));
        }
        if let Some(map) = scene
            .environment_map
            .as_ref()
            .and_then(|m| m.map().source())
        {
            inputs.add(map, format!("the environment map {name} reads"));
        }
        inputs
    }

    /// Refuse if the output `label` (a flag and its file, as the user
    /// wrote them: `-o out.png`) at `path` is one of these files.
    pub fn check_output(&self, label: &str, path: &Path) -> Result<()> {
        let id = FileId::of(path);
        match self.files.iter().find(|i| i.id.same(&id)) {
            None => Ok(()),
            Some(i) => Err(Error::Settings(format!(
                "{label} would overwrite {}, {}{}: choose another file",
                i.path.display(),
                i.what,
                if i.id.resolved == id.resolved {
                    ""
                } else {
                    " (the same file under another name)"
                }
            ))),
        }
    }
}

/// A file a command writes: the flag that names it (`-o`, `--report`) and
/// the path.
pub type Output<'a> = (&'a str, &'a Path);

/// Refuse if two of `outputs` name the same file (the later write would
/// leave only itself).
pub fn check_distinct(outputs: &[Output<'_>]) -> Result<()> {
    let ids: Vec<FileId> = outputs.iter().map(|(_, p)| FileId::of(p)).collect();
    for (j, b) in ids.iter().enumerate() {
        if let Some(i) = ids[..j].iter().position(|a| a.same(b)) {
            let ((fa, a), (fb, b)) = (outputs[i], outputs[j]);
            return Err(Error::Settings(format!(
                "{fa} {} and {fb} {} are the same file: give each output its own",
                a.display(),
                b.display()
            )));
        }
    }
    Ok(())
}

/// Refuse if two of `outputs` are one file or any is one of `inputs`.
pub fn check(outputs: &[Output<'_>], inputs: &Inputs) -> Result<()> {
    check_distinct(outputs)?;
    for (flag, path) in outputs {
        inputs.check_output(&format!("{flag} {}", path.display()), path)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_are_compared_where_they_lead() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        std::fs::write(d.join("a.png"), b"a").unwrap();
        std::fs::create_dir(d.join("sub")).unwrap();
        assert!(same_file(&d.join("a.png"), &d.join("sub/../a.png")));
        assert!(same_file(&d.join("new.png"), &d.join("./sub/../new.png")));
        assert!(!same_file(&d.join("a.png"), &d.join("b.png")));
        #[cfg(unix)]
        {
            std::fs::hard_link(d.join("a.png"), d.join("h.png")).unwrap();
            std::os::unix::fs::symlink(d.join("a.png"), d.join("l.png")).unwrap();
            assert!(same_file(&d.join("a.png"), &d.join("h.png")));
            assert!(same_file(&d.join("a.png"), &d.join("l.png")));
        }
        let mut inputs = Inputs::new();
        inputs.add(&d.join("a.png"), "a texture");
        let e = inputs
            .check_output("-o x", &d.join("sub/../a.png"))
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("-o x would overwrite ") && e.contains("a texture"),
            "{e}"
        );
        assert!(inputs.check_output("-o y", &d.join("y.png")).is_ok());
        let e = check_distinct(&[("-o", &d.join("x.png")), ("--report", &d.join("./x.png"))])
            .unwrap_err()
            .to_string();
        assert!(e.contains("are the same file"), "{e}");
    }
}
