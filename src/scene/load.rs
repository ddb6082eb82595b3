//! Placeholder for the scene loader (being written).
use std::path::Path;

use super::Scene;

#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct SceneError(pub String);

pub fn load(path: &Path) -> Result<Scene, SceneError> {
    Err(SceneError(format!("{}: scene loading is not written yet", path.display())))
}
