//! `pir convert SCENE.toml --to SCENE.xml`: a scene written as a Mitsuba 3 scene file.

use anyhow::{Result, bail};
use clap::Args;
use std::path::PathBuf;

/// Write a scene as a Mitsuba 3 scene file (and its meshes as PLY files beside it), so that
/// Mitsuba can render it: `mitsuba OUT.xml`, or `mi.load_file` with `resx`, `resy`, `spp` and
/// `max_depth` as parameters. What each material becomes: docs/mitsuba.md.
#[derive(Args, Debug)]
pub struct ConvertArgs {
    /// The scene file (pir's TOML, or a Mitsuba 3 .xml, which is written back as pir reads it).
    pub scene: PathBuf,
    /// The Mitsuba scene file to write (.xml); its meshes go beside it as OUT-mesh-K.ply.
    #[arg(long, value_name = "OUT.xml")]
    pub to: PathBuf,
    #[command(flatten)]
    pub options: pir::render::SceneOptions,
}

pub fn run(a: ConvertArgs) -> Result<()> {
    if !a.to.extension().is_some_and(|e| e.eq_ignore_ascii_case("xml")) {
        bail!("--to {}: the Mitsuba scene file must end in .xml", a.to.display());
    }
    // (Before the scene is read: a missing folder is named as such, not as a mesh file's.)
    super::setup::check_writable(&a.to)?;
    let scene = a.options.load(&a.scene)?;
    let files = pir::scene::mitsuba::write(&scene, &a.to)?;
    eprintln!("pir: wrote {} ({} mesh files beside it)", a.to.display(), files.len() - 1);
    Ok(())
}
