//! One hash per channel of an EXR (`layer.channel`, as `ssbc render
//! --layers` writes them), for `scripts/image-hashes.sh`: a layer added to
//! or dropped from a frame then leaves the others' lines unchanged.
//!
//! `cargo run --release --example exr_hashes -- IMAGE.exr`

use std::hash::{Hash, Hasher};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = std::env::args()
        .nth(1)
        .ok_or("usage: exr_hashes IMAGE.exr")?;
    for (name, samples) in ssbc::output::read_exr_channels(path.as_ref())? {
        let mut hasher = std::collections::hash_map::DefaultHasher::new();
        for v in samples {
            v.to_bits().hash(&mut hasher);
        }
        println!("{name} {:016x}", hasher.finish());
    }
    Ok(())
}
