//! The pixels of EXR images as one hash each, for checks that a change leaves images bit for
//! bit as they were (`docs/bitexact.sh`): FNV-1a over the images' size and their float32 bits,
//! row by row, red, green, blue. The header (times, dates) is not hashed.
//!
//! Run: `cargo run --release --example exr_hash -- IMAGE.exr [IMAGE.exr …]`; prints one line
//! per image, `HASH  PATH`.

use std::path::Path;
use std::process::ExitCode;

use pir::image::read_exr;

fn main() -> ExitCode {
    let mut status = ExitCode::SUCCESS;
    for path in std::env::args().skip(1) {
        match read_exr(Path::new(&path)) {
            Ok((img, _)) => {
                let mut h = pir::hash::Fnv1a::default();
                h.u64s(&[img.width as u64, img.height as u64]);
                for p in &img.pixels {
                    h.f32s(&p.to_array());
                }
                println!("{:016x}  {path}", h.finish());
            }
            Err(e) => {
                eprintln!("exr_hash: {path}: {e:#}");
                status = ExitCode::FAILURE;
            }
        }
    }
    status
}
