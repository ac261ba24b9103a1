//! One hash per channel of an EXR (`layer.channel`, as `ssbc render
//! --layers` writes them), for `scripts/image-hashes.sh`: a layer added to
//! or dropped from a frame then leaves the others' lines unchanged.
//!
//! `cargo run --release --example exr_hashes -- IMAGE.exr`

use std::hash::{Hash, Hasher};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    use exr::prelude::*;
    let path = std::env::args()
        .nth(1)
        .ok_or("usage: exr_hashes IMAGE.exr")?;
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .from_file(&path)?;
    let mut lines = Vec::new();
    for layer in &image.layer_data {
        for channel in &layer.channel_data.list {
            let mut hasher = std::collections::hash_map::DefaultHasher::new();
            for v in channel.sample_data.values_as_f32() {
                v.to_bits().hash(&mut hasher);
            }
            lines.push(format!("{} {:016x}", channel.name, hasher.finish()));
        }
    }
    lines.sort();
    println!("{}", lines.join("\n"));
    Ok(())
}
