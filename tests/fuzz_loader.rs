//! A seeded, structure-aware mutation fuzzer over the glTF/GLB loader, and
//! the regression tests for what it found.
//!
//! Seeds are valid scenes (JSON with a data-URI buffer, GLB with a binary
//! chunk, files next to the scene, strips and fans, a scene without
//! `scenes`). Each case applies one to four mutations to the JSON tree
//! (deleted fields, swapped types, out-of-range indices, huge counts and
//! offsets, recursive and repeated references, hostile URIs, bad images) and
//! sometimes flips, truncates or re-sizes bytes of the file or its GLB chunk
//! headers. Every case must return (`Ok` or a one-line error) without a
//! panic, within a few seconds, and without any single allocation larger
//! than a fixed multiple of the input's size.
//!
//! The suite runs 5,000 cases. A longer run:
//! `SSBC_FUZZ_CASES=1000000 SSBC_FUZZ_SEED=7 cargo test --release --test fuzz_loader -- --nocapture`
//! (`SSBC_FUZZ_SHOW=text` prints the cases whose error contains `text`;
//! `SSBC_FUZZ_REPLAY=N` skips to case N and writes each case it loads to the
//! temp folder, to turn a finding into a regression test).

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::path::Path;
use std::sync::mpsc;
use std::time::{Duration, Instant};

use base64::Engine as _;
use serde_json::{json, Value};
use ssbc::scene::gltf_loader::{self, BUDGET_BASE, BUDGET_FACTOR};

/// The system allocator, recording the largest single allocation made on
/// this thread while tracking is on.
struct Tracking;

thread_local! {
    static IN_LOADER: Cell<bool> = const { Cell::new(false) };
    static TRACK: Cell<bool> = const { Cell::new(false) };
    static LARGEST: Cell<usize> = const { Cell::new(0) };
}

// SAFETY: forwards to the system allocator; the thread-locals are const-
// initialised Cells (no allocation, no re-entrancy).
unsafe impl GlobalAlloc for Tracking {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: same contract as the caller's.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note(layout.size());
        // SAFETY: same contract as the caller's.
        unsafe { System.alloc_zeroed(layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note(new_size);
        // SAFETY: same contract as the caller's.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

fn note(size: usize) {
    let _ = TRACK.try_with(|t| {
        if t.get() {
            let _ = LARGEST.try_with(|l| l.set(l.get().max(size)));
        }
    });
}

#[global_allocator]
static ALLOCATOR: Tracking = Tracking;

/// splitmix64: small, seeded, reproducible.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
    fn chance(&mut self, p: f64) -> bool {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64 * 1.0 < p
    }
}

fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = 0xffff_ffffu32;
    for &b in bytes {
        crc ^= b as u32;
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xedb8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

/// A 2x2 RGBA PNG.
fn tiny_png() -> Vec<u8> {
    let img = image::RgbaImage::from_fn(2, 2, |x, y| {
        image::Rgba([x as u8 * 200, y as u8 * 200, 90, 255])
    });
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png).unwrap();
    out.into_inner()
}

/// `png` with its header claiming `width` x `height` (CRC fixed).
fn png_claiming(png: &[u8], width: u32, height: u32) -> Vec<u8> {
    let mut p = png.to_vec();
    // Signature (8), IHDR length (4), "IHDR" (4), width, height, ...
    p[16..20].copy_from_slice(&width.to_be_bytes());
    p[20..24].copy_from_slice(&height.to_be_bytes());
    let crc = crc32(&p[12..29]);
    p[29..33].copy_from_slice(&crc.to_be_bytes());
    p
}

fn data_uri(mime: &str, bytes: &[u8]) -> String {
    format!(
        "data:{mime};base64,{}",
        base64::engine::general_purpose::STANDARD.encode(bytes)
    )
}

/// A quad's buffer: positions, normals, uvs (4 vertices each), u16 indices.
fn quad_bin() -> Vec<u8> {
    let mut b = Vec::new();
    for p in [
        [-1.0f32, 0.0, 1.0],
        [1.0, 0.0, 1.0],
        [1.0, 0.0, -1.0],
        [-1.0, 0.0, -1.0],
    ] {
        p.iter().for_each(|c| b.extend(c.to_le_bytes()));
    }
    for _ in 0..4 {
        [0.0f32, 1.0, 0.0]
            .iter()
            .for_each(|c| b.extend(c.to_le_bytes()));
    }
    for uv in [[0.0f32, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]] {
        uv.iter().for_each(|c| b.extend(c.to_le_bytes()));
    }
    for i in [0u16, 1, 2, 0, 2, 3] {
        b.extend(i.to_le_bytes());
    }
    b
}

/// A complete scene document around buffer 0 of `bin_len` bytes (quad_bin's
/// layout), with `mode` (4 triangles, 5 strip, 6 fan) and image 0 `image`.
fn document(buffer: Value, bin_len: usize, mode: u32, image: Value, with_scenes: bool) -> Value {
    let mut doc = json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_emissive_strength"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"type": "point", "intensity": 5.0, "color": [1.0, 0.9, 0.8]},
            {"type": "spot", "intensity": 3.0, "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.5}}
        ]}},
        "nodes": [
            {"children": [1, 2], "translation": [0.0, 1.0, 0.0], "scale": [2.0, 2.0, 2.0]},
            {"mesh": 0, "rotation": [0.0, 0.6, 0.0, 0.8]},
            {"camera": 0, "translation": [0.0, 1.0, 5.0],
             "extensions": {"KHR_lights_punctual": {"light": 0}}},
            {"extensions": {"KHR_lights_punctual": {"light": 1}}, "translation": [0.0, 3.0, 0.0]}
        ],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1}}],
        "meshes": [{"primitives": [{
            "attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2},
            "indices": 3, "material": 0, "mode": mode
        }]}],
        "materials": [{
            "pbrMetallicRoughness": {
                "baseColorFactor": [0.8, 0.7, 0.6, 1.0], "baseColorTexture": {"index": 0}
            },
            "emissiveFactor": [1.0, 0.5, 0.2], "emissiveTexture": {"index": 0},
            "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 3.0}},
            "normalTexture": {"index": 0, "scale": 0.8},
            "alphaMode": "MASK", "alphaCutoff": 0.4, "doubleSided": false
        }],
        "textures": [{"source": 0, "sampler": 0}],
        "samplers": [{"wrapS": 33071, "wrapT": 33648, "magFilter": 9728}],
        "images": [image],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
             "min": [-1.0, 0.0, -1.0], "max": [1.0, 0.0, 1.0]},
            {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"},
            {"bufferView": 3, "componentType": 5123, "count": 6, "type": "SCALAR"}
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 48},
            {"buffer": 0, "byteOffset": 48, "byteLength": 48},
            {"buffer": 0, "byteOffset": 96, "byteLength": 32},
            {"buffer": 0, "byteOffset": 128, "byteLength": 12}
        ],
        "buffers": [buffer]
    });
    doc["buffers"][0]["byteLength"] = json!(bin_len);
    if with_scenes {
        doc["scenes"] = json!([{"nodes": [0, 3]}]);
        doc["scene"] = json!(0);
    }
    doc
}

/// A GLB container of `json` and `bin`.
fn glb(json_text: &[u8], bin: &[u8]) -> Vec<u8> {
    let pad = |v: &mut Vec<u8>, with: u8| {
        while v.len() % 4 != 0 {
            v.push(with);
        }
    };
    let mut j = json_text.to_vec();
    pad(&mut j, b' ');
    let mut b = bin.to_vec();
    pad(&mut b, 0);
    let total = 12 + 8 + j.len() + 8 + b.len();
    let mut out = Vec::with_capacity(total);
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((j.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(&j);
    out.extend((b.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(&b);
    out
}

/// How a seed is serialised.
#[derive(Clone, Copy)]
enum Container {
    Json,
    Glb,
}

struct Seed {
    doc: Value,
    container: Container,
    bin: Vec<u8>,
}

fn seeds(png: &[u8]) -> Vec<Seed> {
    let bin = quad_bin();
    // The GLB's binary chunk holds the quad's data and then the PNG.
    let mut glb_bin = bin.clone();
    let png_offset = glb_bin.len();
    glb_bin.extend(png);
    let mut glb_doc = document(
        json!({}),
        glb_bin.len(),
        4,
        json!({"bufferView": 4, "mimeType": "image/png"}),
        true,
    );
    glb_doc["bufferViews"]
        .as_array_mut()
        .unwrap()
        .push(json!({"buffer": 0, "byteOffset": png_offset, "byteLength": png.len()}));
    // A strip and a fan over the same 4 vertices (indices 0 1 3 2 / 0 1 2 3).
    let strip = document(
        json!({"uri": data_uri("application/octet-stream", &bin)}),
        bin.len(),
        5,
        json!({"uri": data_uri("image/png", png)}),
        false,
    );
    vec![
        Seed {
            doc: document(
                json!({"uri": data_uri("application/octet-stream", &bin)}),
                bin.len(),
                4,
                json!({"uri": data_uri("image/png", png)}),
                true,
            ),
            container: Container::Json,
            bin: Vec::new(),
        },
        Seed {
            doc: deformed(png),
            container: Container::Json,
            bin: Vec::new(),
        },
        Seed {
            doc: glb_doc,
            container: Container::Glb,
            bin: glb_bin,
        },
        Seed {
            doc: document(
                json!({"uri": "quad.bin"}),
                bin.len(),
                4,
                json!({"uri": "tex.png"}),
                true,
            ),
            container: Container::Json,
            bin: Vec::new(),
        },
        Seed {
            doc: strip,
            container: Container::Json,
            bin: Vec::new(),
        },
        Seed {
            doc: document(
                json!({"uri": data_uri("application/octet-stream", &bin)}),
                bin.len(),
                6,
                json!({"uri": "sub/tex%20copy.png"}),
                false,
            ),
            container: Container::Json,
            bin: Vec::new(),
        },
    ]
}

/// The first seed's quad skinned by two joints (nodes 0 and 2, with
/// inverse bind matrices) and displaced by a morph target (its normals as
/// positions and normals) at weight 0.5 (the node's own: 0.25).
fn deformed(png: &[u8]) -> Value {
    let mut bin = quad_bin();
    bin.extend([0u8, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0]); // JOINTS_0 at 140
    for w in [
        [1.0f32, 0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0, 0.0],
        [0.5, 0.5, 0.0, 0.0],
        [1.0, 0.0, 0.0, 0.0],
    ] {
        w.iter().for_each(|c| bin.extend(c.to_le_bytes())); // WEIGHTS_0 at 156
    }
    for m in [
        glam::Mat4::IDENTITY,
        glam::Mat4::from_translation(glam::Vec3::new(0.0, -1.0, -5.0)),
    ] {
        m.to_cols_array()
            .iter()
            .for_each(|c| bin.extend(c.to_le_bytes())); // at 220
    }
    let mut doc = document(
        json!({"uri": data_uri("application/octet-stream", &bin)}),
        bin.len(),
        4,
        json!({"uri": data_uri("image/png", png)}),
        true,
    );
    let views = doc["bufferViews"].as_array_mut().unwrap();
    views.push(json!({"buffer": 0, "byteOffset": 140, "byteLength": 16}));
    views.push(json!({"buffer": 0, "byteOffset": 156, "byteLength": 64}));
    views.push(json!({"buffer": 0, "byteOffset": 220, "byteLength": 128}));
    let accessors = doc["accessors"].as_array_mut().unwrap();
    accessors.push(json!({"bufferView": 4, "componentType": 5121, "count": 4, "type": "VEC4"}));
    accessors.push(json!({"bufferView": 5, "componentType": 5126, "count": 4, "type": "VEC4"}));
    accessors.push(json!({"bufferView": 6, "componentType": 5126, "count": 2, "type": "MAT4"}));
    let primitive = &mut doc["meshes"][0]["primitives"][0];
    primitive["attributes"]["JOINTS_0"] = json!(4);
    primitive["attributes"]["WEIGHTS_0"] = json!(5);
    primitive["targets"] = json!([{"POSITION": 1, "NORMAL": 1}]);
    doc["meshes"][0]["weights"] = json!([0.5]);
    doc["nodes"][1]["skin"] = json!(0);
    doc["nodes"][1]["weights"] = json!([0.25]);
    doc["skins"] = json!([{"joints": [0, 2], "inverseBindMatrices": 6, "skeleton": 0}]);
    doc
}

/// Values a mutated field may take.
fn odd_value(rng: &mut Rng, png: &[u8]) -> Value {
    match rng.below(24) {
        0 => Value::Null,
        1 => json!(true),
        2 => json!(0),
        3 => json!(-1),
        4 => json!(1),
        5 => json!(4294967295u64),
        6 => json!(4294967296u64),
        7 => json!(9007199254740993u64),
        8 => json!(1e308),
        9 => json!(-2147483649i64),
        10 => json!(0.5),
        11 => json!("x"),
        12 => json!([]),
        13 => json!({}),
        14 => json!([0, 0, 0, 0]),
        15 => json!(rng.below(1 << 20)),
        16 => json!("../outside.bin"),
        17 => json!("/etc/hostname"),
        18 => json!("file:///etc/hostname"),
        19 => json!("%zz%"),
        20 => json!("escape.bin"),
        21 => json!(data_uri("image/png", &png_claiming(png, 60000, 60000))),
        22 => json!("data:application/octet-stream;base64,@@@@"),
        _ => json!(data_uri("image/webp", b"RIFF\x10\0\0\0WEBPVP8 ")),
    }
}

/// A random node of the tree: (path of keys and indices).
fn random_path(v: &Value, rng: &mut Rng) -> Vec<Value> {
    let mut path = Vec::new();
    let mut cur = v;
    loop {
        let next = match cur {
            Value::Object(m) if !m.is_empty() && (path.is_empty() || !rng.chance(0.25)) => {
                let k = m.keys().nth(rng.below(m.len())).unwrap().clone();
                let child = &m[&k];
                path.push(json!(k));
                Some(child)
            }
            Value::Array(a) if !a.is_empty() && !rng.chance(0.25) => {
                let i = rng.below(a.len());
                path.push(json!(i));
                Some(&a[i])
            }
            _ => None,
        };
        match next {
            Some(c) => cur = c,
            None => return path,
        }
    }
}

fn at<'a>(v: &'a mut Value, path: &[Value]) -> &'a mut Value {
    path.iter().fold(v, |cur, k| match k {
        Value::String(s) => &mut cur[s.as_str()],
        Value::Number(n) => &mut cur[n.as_u64().unwrap() as usize],
        _ => unreachable!(),
    })
}

/// One structural mutation; returns what it did.
fn mutate(doc: &mut Value, rng: &mut Rng, png: &[u8]) -> String {
    let path = random_path(doc, rng);
    let where_ = path
        .iter()
        .map(|p| p.to_string())
        .collect::<Vec<_>>()
        .join("/");
    match rng.below(8) {
        // Delete the field or element.
        0 if !path.is_empty() => {
            let (last, parent) = path.split_last().unwrap();
            match (at(doc, parent), last) {
                (Value::Object(m), Value::String(k)) => {
                    m.remove(k);
                }
                (Value::Array(a), Value::Number(i)) => {
                    a.remove(i.as_u64().unwrap() as usize);
                }
                _ => {}
            }
            format!("delete {where_}")
        }
        // Repeat an array's first element many times.
        1 => {
            let target = at(doc, &path);
            if let Value::Array(a) = target {
                if let Some(first) = a.first().cloned() {
                    // Bounded in bytes: repeats of repeats would otherwise
                    // grow the case itself without bound.
                    let size = serde_json::to_vec(&first).map_or(1, |v| v.len().max(1));
                    let n = [2, 50, 5000][rng.below(3)].min((4 << 20) / size);
                    a.extend(std::iter::repeat_n(first, n));
                }
            }
            format!("repeat {where_}")
        }
        // Children that point back up or at themselves.
        2 => {
            let nodes = doc
                .get("nodes")
                .and_then(Value::as_array)
                .map_or(0, Vec::len);
            let (i, j) = (rng.below(nodes), rng.below(nodes));
            match doc
                .pointer_mut(&format!("/nodes/{i}"))
                .and_then(Value::as_object_mut)
            {
                Some(node) => {
                    node.insert("children".into(), json!([j, j, i]));
                    format!("children of node {i} = [{j}, {j}, {i}]")
                }
                None => "no node to change".into(),
            }
        }
        // An index field out of range.
        3 => {
            let target = at(doc, &path);
            if target.is_number() {
                *target = json!([1000, 4, 65536, 7, 1 << 31][rng.below(5)]);
            }
            format!("index {where_}")
        }
        // Counts, lengths and offsets far too large.
        4 => {
            let field = ["count", "byteLength", "byteOffset", "byteStride"][rng.below(4)];
            let (list, n) = match field {
                "count" => ("accessors", 4),
                _ => ("bufferViews", 4),
            };
            let i = rng.below(n);
            let v = [65536u64, 1 << 31, (1u64 << 32) + 8, 1 << 52][rng.below(4)];
            match doc
                .pointer_mut(&format!("/{list}/{i}"))
                .and_then(Value::as_object_mut)
            {
                Some(entry) => {
                    entry.insert(field.into(), json!(v));
                    format!("{list}/{i}/{field} = {v}")
                }
                None => format!("no {list}/{i}"),
            }
        }
        // Something else in its place: mostly of the same JSON type (so that
        // the case gets past the parser), sometimes anything.
        _ => {
            let target = at(doc, &path);
            let v = loop {
                let v = odd_value(rng, png);
                let same_type = std::mem::discriminant(&v) == std::mem::discriminant(target);
                if same_type || rng.chance(0.15) {
                    break v;
                }
            };
            let shown = v.to_string();
            *at(doc, &path) = v;
            format!("{where_} = {}", &shown[..shown.len().min(40)])
        }
    }
}

/// Byte-level damage to the serialised file.
fn damage(bytes: &mut Vec<u8>, rng: &mut Rng) -> String {
    match rng.below(4) {
        0 if !bytes.is_empty() => {
            let n = rng.below(bytes.len());
            bytes.truncate(n);
            format!("truncate to {n}")
        }
        1 if bytes.len() > 24 && bytes.starts_with(b"glTF") => {
            // A GLB length field: total, JSON chunk or the next chunk.
            let o = [8usize, 12, 20][rng.below(3)];
            let v = [0u32, 1, 0xffff_fff0, bytes.len() as u32 + 4][rng.below(4)];
            bytes[o..o + 4].copy_from_slice(&v.to_le_bytes());
            format!("GLB length at {o} = {v}")
        }
        _ => {
            let flips = 1 + rng.below(8);
            for _ in 0..flips {
                if !bytes.is_empty() {
                    let i = rng.below(bytes.len());
                    bytes[i] ^= 1 << rng.below(8);
                }
            }
            format!("{flips} bit flips")
        }
    }
}

fn serialise(doc: &Value, seed: &Seed) -> Vec<u8> {
    let text = serde_json::to_vec(doc).unwrap();
    match seed.container {
        Container::Json => text,
        Container::Glb => glb(&text, &seed.bin),
    }
}

/// The scene folder: a buffer and textures the seeds name, and a symlink
/// that leads out of it.
fn scene_folder(png: &[u8]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("quad.bin"), quad_bin()).unwrap();
    std::fs::write(dir.path().join("tex.png"), png).unwrap();
    std::fs::create_dir(dir.path().join("sub")).unwrap();
    std::fs::write(dir.path().join("sub/tex copy.png"), png).unwrap();
    let outside = tempfile::NamedTempFile::new()
        .unwrap()
        .into_temp_path()
        .keep()
        .unwrap();
    std::fs::write(&outside, b"outside").unwrap();
    std::os::unix::fs::symlink(&outside, dir.path().join("escape.bin")).unwrap();
    dir
}

/// What the cases came to: loaded, or refused with which kind of error
/// (the message up to its first number or quote).
#[derive(Default)]
struct Outcomes {
    loaded: u64,
    refused: std::collections::BTreeMap<String, u64>,
}

impl Outcomes {
    fn note(&mut self, result: &ssbc::Result<ssbc::Scene>) {
        match result {
            Ok(_) => self.loaded += 1,
            Err(e) => {
                let message = e.to_string();
                let kind: String = message
                    .trim_start_matches("scene fuzz.gltf: ")
                    .chars()
                    .take_while(|c| !c.is_ascii_digit() && *c != '\'' && *c != ':')
                    .collect();
                *self.refused.entry(kind.trim().to_string()).or_default() += 1;
            }
        }
    }
}

/// Runs `cases` cases from `seed_value`; returns (cases run, findings).
fn fuzz(
    cases: u64,
    seed_value: u64,
    base: &Path,
    progress: &mpsc::Sender<String>,
    outcomes: &mut Outcomes,
) -> (u64, Vec<String>) {
    let png = tiny_png();
    let seeds = seeds(&png);
    let mut rng = Rng(seed_value);
    let mut findings = Vec::new();
    let external = 4096; // the folder's files a case may read
                         // SSBC_FUZZ_REPLAY=N generates cases 0..N without loading them, then
                         // writes case N (and later ones) to the temp folder before loading it.
    let replay: Option<u64> = std::env::var("SSBC_FUZZ_REPLAY")
        .ok()
        .and_then(|v| v.parse().ok());
    for case in 0..cases {
        let seed = &seeds[rng.below(seeds.len())];
        let mut doc = seed.doc.clone();
        let mut what: Vec<String> = (0..1 + rng.below(4))
            .map(|_| mutate(&mut doc, &mut rng, &png))
            .collect();
        let mut bytes = serialise(&doc, seed);
        if rng.chance(0.1) {
            what.push(damage(&mut bytes, &mut rng));
        }
        let description = format!("case {case} (seed {seed_value}): {}", what.join("; "));
        let _ = progress.send(description.clone());
        if let Some(dump) = replay {
            if case < dump {
                continue;
            }
            let path = std::env::temp_dir().join(format!("ssbc-fuzz-{seed_value}-{case}.gltf"));
            std::fs::write(&path, &bytes).expect("write the replayed case");
            eprintln!("{description}\n    written to {}", path.display());
        }
        LARGEST.with(|l| l.set(0));
        TRACK.with(|t| t.set(true));
        let start = Instant::now();
        IN_LOADER.with(|f| f.set(true));
        let result = std::panic::catch_unwind(|| {
            gltf_loader::load_bytes("fuzz.gltf", &bytes, base, Some(0.5))
        });
        IN_LOADER.with(|f| f.set(false));
        TRACK.with(|t| t.set(false));
        let elapsed = start.elapsed();
        let largest = LARGEST.with(|l| l.get()) as u64;
        let limit = 3 * (BUDGET_BASE + BUDGET_FACTOR * (bytes.len() as u64 + external));
        if let Ok(r) = &result {
            outcomes.note(r);
            if std::env::var("SSBC_FUZZ_SHOW")
                .is_ok_and(|v| r.as_ref().err().is_some_and(|e| e.to_string().contains(&v)))
            {
                eprintln!("{description}\n    -> {}", r.as_ref().err().unwrap());
            }
        }
        match result {
            Err(_) => findings.push(format!("PANIC in {description}")),
            Ok(Err(e)) if e.to_string().contains('\n') => {
                findings.push(format!("multi-line error in {description}: {e}"))
            }
            _ => {}
        }
        if largest > limit {
            findings.push(format!(
                "allocation of {largest} bytes (> {limit}) for {} input bytes in {description}",
                bytes.len()
            ));
        }
        if elapsed > Duration::from_secs(2) {
            findings.push(format!("{:.1} s in {description}", elapsed.as_secs_f64()));
        }
    }
    (cases, findings)
}

#[test]
fn loader_survives_mutated_scenes() {
    let cases: u64 = std::env::var("SSBC_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(5000);
    let seed: u64 = std::env::var("SSBC_FUZZ_SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1);
    let png = tiny_png();
    let folder = scene_folder(&png);
    let base = folder.path().canonicalize().unwrap();
    // Panics inside the loader are findings, not noise; anything else (the
    // harness, other tests) keeps the default report.
    let default_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        if !IN_LOADER.with(|f| f.get()) {
            default_hook(info);
        }
    }));
    let (tx, rx) = mpsc::channel();
    let start = Instant::now();
    let worker = std::thread::Builder::new()
        .name("fuzz-loader".into())
        .spawn(move || {
            let mut outcomes = Outcomes::default();
            let (run, findings) = fuzz(cases, seed, &base, &tx, &mut outcomes);
            (run, findings, outcomes)
        })
        .expect("fuzzer thread");
    // A watchdog: a case that never returns is a hang.
    let mut last = String::from("(before the first case)");
    loop {
        match rx.recv_timeout(Duration::from_secs(30)) {
            Ok(d) => last = d,
            Err(mpsc::RecvTimeoutError::Disconnected) => break,
            Err(mpsc::RecvTimeoutError::Timeout) => {
                panic!("hang: no progress for 30 s after {last}");
            }
        }
    }
    let (run, findings, outcomes) = worker.join().expect("fuzzer thread");
    eprintln!(
        "loader fuzzing: {run} cases (seed {seed}) in {:.1} s, {} findings; {} loaded, {} refused:",
        start.elapsed().as_secs_f64(),
        findings.len(),
        outcomes.loaded,
        outcomes.refused.values().sum::<u64>()
    );
    let mut kinds: Vec<_> = outcomes.refused.iter().collect();
    kinds.sort_by(|a, b| b.1.cmp(a.1));
    for (kind, n) in kinds.iter().take(25) {
        eprintln!("  {n:>7}  {kind}");
    }
    // The mutations must reach past the JSON parser, into the loader.
    assert!(
        outcomes.loaded > run / 20,
        "only {} cases loaded",
        outcomes.loaded
    );
    assert!(kinds.len() >= 15, "only {} kinds of refusal", kinds.len());
    assert!(findings.is_empty(), "{}", findings.join("\n"));
}

/// Regression and boundary cases, each a clear error.
fn load_doc(doc: &Value, folder: &Path) -> ssbc::Result<ssbc::Scene> {
    gltf_loader::load_bytes("case.gltf", &serde_json::to_vec(doc).unwrap(), folder, None)
}

fn base_doc(png: &[u8]) -> Value {
    let bin = quad_bin();
    document(
        json!({"uri": data_uri("application/octet-stream", &bin)}),
        bin.len(),
        4,
        json!({"uri": data_uri("image/png", png)}),
        true,
    )
}

#[test]
fn every_seed_loads() {
    let png = tiny_png();
    let folder = scene_folder(&png);
    let base = folder.path().canonicalize().unwrap();
    for (i, seed) in seeds(&png).iter().enumerate() {
        let bytes = serialise(&seed.doc, seed);
        let scene = gltf_loader::load_bytes("seed.gltf", &bytes, &base, None)
            .unwrap_or_else(|e| panic!("seed {i}: {e}"));
        assert!(scene.triangle_count() >= 2, "seed {i}");
        assert_eq!(scene.textures.len(), 1, "seed {i}");
        assert_eq!(scene.lights.len(), 2, "seed {i}");
    }
}

#[test]
fn a_png_claiming_60000_by_60000_is_refused_before_decoding() {
    let png = tiny_png();
    let folder = tempfile::tempdir().unwrap();
    let mut doc = base_doc(&png);
    doc["images"][0]["uri"] = json!(data_uri("image/png", &png_claiming(&png, 60000, 60000)));
    LARGEST.with(|l| l.set(0));
    TRACK.with(|t| t.set(true));
    let e = load_doc(&doc, folder.path()).unwrap_err().to_string();
    TRACK.with(|t| t.set(false));
    assert!(e.contains("60000x60000") && e.contains("8192"), "{e}");
    let largest = LARGEST.with(|l| l.get());
    assert!(largest < 1 << 20, "{largest} bytes allocated");
}

#[test]
fn unsupported_image_formats_are_named() {
    let png = tiny_png();
    let folder = tempfile::tempdir().unwrap();
    let mut doc = base_doc(&png);
    doc["images"][0]["uri"] = json!(data_uri("image/gif", b"GIF89a\x01\0\x01\0\0\0\0;"));
    let e = load_doc(&doc, folder.path()).unwrap_err().to_string();
    assert!(e.contains("is GIF") && e.contains("PNG and JPEG"), "{e}");
    doc["images"][0]["uri"] = json!(data_uri("image/ktx2", b"not an image at all"));
    let e = load_doc(&doc, folder.path()).unwrap_err().to_string();
    assert!(
        e.contains("image/ktx2") && e.contains("PNG and JPEG"),
        "{e}"
    );
}

#[test]
fn shared_and_cyclic_children_are_refused() {
    let png = tiny_png();
    let folder = tempfile::tempdir().unwrap();
    for children in [json!([1, 1]), json!([1, 0]), json!([0])] {
        let mut doc = base_doc(&png);
        doc["nodes"][0]["children"] = children.clone();
        let e = load_doc(&doc, folder.path()).unwrap_err().to_string();
        assert!(e.contains("reached twice"), "{children}: {e}");
    }
    // 30 levels of nodes that each list the next twice would be 2^30 visits.
    let mut doc = base_doc(&png);
    let nodes: Vec<Value> = (0..30)
        .map(|i| {
            if i < 29 {
                json!({"children": [i + 1, i + 1], "mesh": 0})
            } else {
                json!({"mesh": 0})
            }
        })
        .collect();
    doc["nodes"] = json!(nodes);
    doc["scenes"] = json!([{"nodes": [0]}]);
    let start = Instant::now();
    assert!(load_doc(&doc, folder.path()).is_err());
    assert!(start.elapsed() < Duration::from_secs(1));
}

#[test]
fn many_instances_of_a_mesh_hit_the_world_triangle_limit() {
    let png = tiny_png();
    let folder = tempfile::tempdir().unwrap();
    // A 8192-triangle grid instanced by 200,000 nodes: a few MB of JSON
    // asking for 1.6 billion triangles. The mesh is stored once, but ray
    // casting and drawing see every instance: the world's triangles are
    // bounded.
    let mut doc = base_doc(&png);
    let n = 65u32;
    let mut bin = Vec::new();
    for y in 0..n {
        for x in 0..n {
            [x as f32, 0.0, y as f32]
                .iter()
                .for_each(|c| bin.extend(c.to_le_bytes()));
        }
    }
    let positions = bin.len();
    for y in 0..n - 1 {
        for x in 0..n - 1 {
            let i = y * n + x;
            for v in [i, i + 1, i + n, i + 1, i + n + 1, i + n] {
                bin.extend(v.to_le_bytes());
            }
        }
    }
    let index_count = (n - 1) * (n - 1) * 6;
    doc["buffers"] =
        json!([{"uri": data_uri("application/octet-stream", &bin), "byteLength": bin.len()}]);
    doc["bufferViews"] = json!([
        {"buffer": 0, "byteOffset": 0, "byteLength": positions},
        {"buffer": 0, "byteOffset": positions, "byteLength": bin.len() - positions}
    ]);
    doc["accessors"] = json!([
        {"bufferView": 0, "componentType": 5126, "count": n * n, "type": "VEC3"},
        {"bufferView": 1, "componentType": 5125, "count": index_count, "type": "SCALAR"}
    ]);
    doc["meshes"] = json!([{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}]);
    doc["materials"] = json!([]);
    let instances = 200_000;
    let mut nodes: Vec<Value> = vec![json!({"children": (1..=instances).collect::<Vec<_>>()})];
    nodes.extend((0..instances).map(|i| json!({"mesh": 0, "translation": [i as f32, 0.0, 0.0]})));
    doc["nodes"] = json!(nodes);
    doc["scenes"] = json!([{"nodes": [0]}]);
    let e = load_doc(&doc, folder.path()).unwrap_err().to_string();
    assert!(e.contains("triangles in the world"), "{e}");
}

#[test]
fn a_hundred_thousand_nodes_sharing_a_mesh_load_without_quadratic_work() {
    let png = tiny_png();
    let folder = tempfile::tempdir().unwrap();
    // The base document's quad mesh drawn by 100,000 nodes: 200,000
    // triangles, one mesh. Numbering objects again at every node (or
    // summing the meshes for the budget) would take minutes.
    let mut doc = base_doc(&png);
    let instances = 100_000;
    let mut nodes: Vec<Value> = vec![json!({"children": (1..=instances).collect::<Vec<_>>()})];
    nodes.extend((0..instances).map(|i| json!({"mesh": 0, "translation": [i as f32, 0.0, 0.0]})));
    doc["nodes"] = json!(nodes);
    doc["scenes"] = json!([{"nodes": [0]}]);
    doc.as_object_mut().unwrap().remove("animations");
    let start = Instant::now();
    let scene = load_doc(&doc, folder.path()).unwrap();
    assert_eq!(scene.meshes().len(), 1);
    assert_eq!(scene.objects().len(), instances);
    assert_eq!(scene.triangle_count(), 2 * instances);
    assert!(
        start.elapsed() < Duration::from_secs(20),
        "{:?}",
        start.elapsed()
    );
}
