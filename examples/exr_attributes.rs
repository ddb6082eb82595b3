//! The text attributes of EXR images, one `KEY=VALUE` line each in the file's order, for
//! checks that a change leaves an image's metadata as it was but for additions. The
//! attributes that vary from run to run (`pir.render_time_s`, `pir.accel`, `pir.version`)
//! are left out.
//!
//! Run: `cargo run --release --example exr_attributes -- IMAGE.exr [IMAGE.exr …]`; prints
//! `== PATH` before each image's lines.

use std::path::Path;
use std::process::ExitCode;

use pir::image::read_exr;

const VARYING: [&str; 3] = ["pir.render_time_s", "pir.accel", "pir.version"];

fn main() -> ExitCode {
    let mut status = ExitCode::SUCCESS;
    for path in std::env::args().skip(1) {
        match read_exr(Path::new(&path)) {
            Ok((_, attributes)) => {
                println!("== {path}");
                for (k, v) in attributes.iter().filter(|(k, _)| !VARYING.contains(&k.as_str())) {
                    println!("{k}={v}");
                }
            }
            Err(e) => {
                eprintln!("exr_attributes: {path}: {e:#}");
                status = ExitCode::FAILURE;
            }
        }
    }
    status
}
