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
                let mut h: u64 = 0xcbf2_9ce4_8422_2325;
                let mut eat = |bytes: &[u8]| {
                    for b in bytes {
                        h = (h ^ u64::from(*b)).wrapping_mul(0x0000_0100_0000_01b3);
                    }
                };
                eat(&(img.width as u64).to_le_bytes());
                eat(&(img.height as u64).to_le_bytes());
                for p in &img.pixels {
                    for c in p.to_array() {
                        eat(&c.to_bits().to_le_bytes());
                    }
                }
                println!("{h:016x}  {path}");
            }
            Err(e) => {
                eprintln!("exr_hash: {path}: {e:#}");
                status = ExitCode::FAILURE;
            }
        }
    }
    status
}
