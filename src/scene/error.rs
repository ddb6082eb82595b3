//! The scene loader's error: every message names the file it is about and, where known, the
//! key, line or mesh, then the problem, e.g.
//! `scenes/box.toml: [materials.floor] roughness = -1: must be a positive number` or
//! `scenes/box.obj: line 12: face index 9 is out of range (the file has 8 vertices so far)`.

use std::fmt;
use std::path::{Path, PathBuf};

/// Why a scene could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// A file could not be read (missing, unreadable, not UTF-8). The I/O error is part of the
    /// message and deliberately not a `source`, so that a printed error chain names it once.
    #[error("{}: cannot read: {error}", .path.display())]
    Io { path: PathBuf, error: std::io::Error },
    /// The scene TOML is malformed, has a wrong type or an unknown key (the message, from
    /// `toml`, gives line and column).
    #[error("{}: {message}", .path.display())]
    Toml { path: PathBuf, message: String },
    /// A value in the scene file is out of its domain.
    #[error("{}: {}{key}: {problem}", .path.display(), LineNo(*.line))]
    Value { path: PathBuf, line: Option<usize>, key: String, problem: String },
    /// An OBJ or MTL file is malformed (`line` is 1-based when known).
    #[error("{}: {}{problem}", .path.display(), LineNo(*.line))]
    Syntax { path: PathBuf, line: Option<usize>, problem: String },
    /// A mesh of the scene cannot be built (missing material, no faces, ...).
    #[error("{}: {}[[mesh]] #{mesh} (obj = {obj:?}): {problem}", .path.display(), LineNo(*.line))]
    Mesh { path: PathBuf, line: Option<usize>, mesh: usize, obj: String, problem: String },
    /// No triangle of the scene emits light.
    #[error(
        "{}: no emitter: no triangle has a material with non-zero emission (MTL `Ke` or \
         `emission` in [materials])",
        .path.display()
    )]
    NoEmitter { path: PathBuf },
    /// The scene's data break an invariant of [`super::Scene`] (a program building a scene
    /// with [`super::Scene::new`]; the loader's own checks come first).
    #[error("{}: {problem}", .path.display())]
    Invalid { path: PathBuf, problem: String },
}

struct LineNo(Option<usize>);

impl fmt::Display for LineNo {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            Some(l) => write!(f, "line {l}: "),
            None => Ok(()),
        }
    }
}

impl SceneError {
    pub(crate) fn io(path: &Path, error: std::io::Error) -> Self {
        SceneError::Io { path: path.to_path_buf(), error }
    }

    pub(crate) fn syntax(path: &Path, line: Option<usize>, problem: impl Into<String>) -> Self {
        SceneError::Syntax { path: path.to_path_buf(), line, problem: problem.into() }
    }
}

/// Reads a whole text file, mapping failures to [`SceneError::Io`].
pub(crate) fn read_text(path: &Path) -> Result<String, SceneError> {
    std::fs::read_to_string(path).map_err(|e| SceneError::io(path, e))
}
