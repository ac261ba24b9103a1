//! Profiling for engine programmers: debug names that reach validation
//! messages, warm-frame statistics, the Chrome trace, pipeline statistics,
//! and a device without timestamps.

mod common;

use std::process::Command;

use ash::vk;
use serde_json::Value;
use ssbc::profile::{render_frames, ChromeTrace};
use ssbc::renderer::{RenderSettings, Renderer, RendererConfig};
use ssbc::vk::CommandPool;

fn settings() -> RenderSettings {
    common::tiny_settings()
}

fn validated() -> Renderer {
    common::validated_renderer()
}

/// A deliberately invalid command on ssbc's final image: the validation
/// message must call the image by its ssbc name, not by a bare handle.
#[test]
fn a_validation_message_names_the_object_by_its_ssbc_name() {
    let mut renderer = validated();
    assert!(renderer.device().instance.debug_utils_enabled());
    let log = renderer.validation_log();
    let mut scene = ssbc::scene::builtin::cornell();
    scene.ensure_light();
    let frame = renderer.render(&scene, &settings()).expect("render");
    assert_eq!(log.total(), 0, "{:?}", log.messages());
    // Pipeline statistics where the device has them (lavapipe has).
    let counted = renderer.device().profiling().pipeline_statistics;
    assert!(frame
        .timings
        .timed_passes()
        .iter()
        .filter(|p| !p.name.contains('/'))
        .all(|p| p.compute_invocations.is_some() == counted));
    let out = renderer.output_image().expect("an output image");
    let device = renderer.device().clone();
    device.wait(out.value).unwrap();

    // Clear the storage-only image as if it were a transfer destination in
    // TRANSFER_DST_OPTIMAL: wrong usage and wrong layout.
    let mut pool = CommandPool::new(&device).unwrap();
    let rec = pool.begin().unwrap();
    let range = vk::ImageSubresourceRange::default()
        .aspect_mask(vk::ImageAspectFlags::COLOR)
        .level_count(1)
        .layer_count(1);
    // SAFETY: a valid command buffer and a live image; the call is invalid
    // on purpose, and the layer reports it before the driver sees it.
    unsafe {
        device.raw.cmd_clear_color_image(
            rec.cmd,
            out.image,
            vk::ImageLayout::TRANSFER_DST_OPTIMAL,
            &vk::ClearColorValue::default(),
            &[range],
        )
    };
    // Not submitted: recording alone provokes the message.
    drop(rec);
    drop(pool);
    let messages = log.messages();
    assert!(log.total() > 0, "the invalid clear was not reported");
    assert!(
        messages.iter().any(|m| m.contains("ssbc.s0")),
        "no message names ssbc.s0: {messages:#?}"
    );
    drop(renderer);
}

/// Three warm frames after a warm-up: per-pass min <= median <= max for the
/// same passes as a single frame, and a trace with every frame on both
/// tracks, GPU passes inside their frame, and (calibrated) GPU work between
/// submission and the end of the wait for it.
#[test]
fn frames_give_spreads_and_a_trace_with_gpu_and_cpu_tracks() {
    let mut renderer = validated();
    let log = renderer.validation_log();
    let support = renderer.device().profiling();
    let mut scene = ssbc::scene::builtin::cornell();
    scene.ensure_light();
    let s = settings();
    let mut trace = ChromeTrace::new();
    let frame = render_frames(&mut renderer, &scene, &s, 3, Some(&mut trace)).expect("frames");
    let stats = frame.timings.stats.as_ref().expect("stats");
    assert_eq!(stats.frames, 3);
    let passes = frame.timings.passes.as_ref().expect("timed");
    let names: Vec<&str> = stats.passes.iter().map(|p| p.name.as_str()).collect();
    let expected: Vec<&str> = passes.iter().map(|p| p.name.as_str()).collect();
    assert_eq!(names, expected);
    for p in stats.passes.iter().chain(&stats.cpu_ms) {
        let v = p.ms;
        assert!(
            v.min <= v.median && v.median <= v.max && v.min >= 0.0,
            "{}: {v:?}",
            p.name
        );
    }
    let f = stats.frame_gpu_ms.expect("frame spread");
    assert!(f.min > 0.0 && f.min <= f.median && f.median <= f.max);
    for stage in ["bvh_build", "vpl_generation", "point_sampling", "record"] {
        assert!(
            stats.cpu_ms.iter().any(|p| p.name == stage),
            "CPU stage {stage} missing"
        );
    }

    // Pipeline statistics: the lighting kernels run at least once per pixel.
    let pixels = (s.width * s.height) as u64;
    for p in passes {
        if !support.pipeline_statistics || p.name.contains('/') {
            assert_eq!(p.compute_invocations, None, "{}", p.name);
            continue;
        }
        let n = p.compute_invocations.expect("statistics");
        match p.name.as_str() {
            "direct_lighting" | "indirect_bounded" => {
                assert!(n >= pixels, "{}: {n} < {pixels} invocations", p.name)
            }
            "gbuffer" => {
                assert_eq!(n, 0, "{}", p.name);
                assert!(p.fragment_invocations.unwrap() > 0, "{}", p.name);
            }
            // Opaque casters draw depth only, with no fragment shader: a
            // device may count none (NVIDIA) or one per fragment (lavapipe).
            "shadow_maps" => {
                assert_eq!(n, 0, "{}", p.name);
                assert!(p.fragment_invocations.is_some(), "{}", p.name);
            }
            _ => {}
        }
    }

    let json = trace.to_json();
    let events = json["traceEvents"].as_array().unwrap();
    let spans = |tid: u64| -> Vec<&Value> {
        events
            .iter()
            .filter(|e| e["ph"] == "X" && e["tid"] == tid)
            .collect()
    };
    let (gpu, cpu) = (spans(1), spans(2));
    let frames: Vec<&&Value> = gpu
        .iter()
        .filter(|e| e["name"].as_str().unwrap().starts_with("frame "))
        .collect();
    assert_eq!(frames.len(), 4, "warm-up + 3 frames on the GPU track");
    assert_eq!(gpu.len(), 4 * (passes.len() + 1));
    assert!(cpu.len() >= 4 * 5, "{} CPU events", cpu.len());
    let range = |e: &Value| {
        let ts = e["ts"].as_f64().unwrap();
        (ts, ts + e["dur"].as_f64().unwrap())
    };
    for e in &gpu {
        let k = e["args"]["frame"].as_u64().unwrap();
        let (f0, f1) = range(frames[k as usize]);
        let (p0, p1) = range(e);
        assert!(
            p0 >= f0 - 1.0 && p1 <= f1 + 1.0,
            "{} of frame {k} at {p0}..{p1} µs outside {f0}..{f1}",
            e["name"]
        );
    }
    let alignment = json["metadata"]["ssbc.clock_alignment"].as_str().unwrap();
    if support.calibrated_timestamps {
        assert!(alignment.starts_with("calibrated"), "{alignment}");
        // The GPU ran each frame after recording began and before the wait
        // for it ended (1 ms of slack for the calibration's deviation).
        for (k, f) in frames.iter().enumerate() {
            let of_frame = |name: &str| {
                cpu.iter()
                    .find(|e| e["name"] == name && e["args"]["frame"] == k as u64)
                    .map(|e| range(e))
                    .unwrap_or_else(|| panic!("no {name} of frame {k}"))
            };
            let (record_start, _) = of_frame("record");
            let (_, wait_end) = of_frame("wait_for_gpu");
            let (g0, g1) = range(f);
            assert!(
                g0 >= record_start - 1000.0 && g1 <= wait_end + 1000.0,
                "frame {k}: GPU {g0}..{g1} µs, recording from {record_start}, wait until {wait_end}"
            );
        }
    } else {
        assert!(alignment.starts_with("submission"), "{alignment}");
    }
    drop(renderer);
    assert_eq!(log.total(), 0, "{:?}", log.messages());
}

/// A renderer whose passes are not timed (what a queue without timestamps
/// gets): timings are null, labels and everything else still work.
#[test]
fn without_timestamps_timings_are_null() {
    let mut renderer = Renderer::new(&RendererConfig {
        validation: true,
        no_gpu_timestamps: true,
        ..Default::default()
    })
    .unwrap();
    let log = renderer.validation_log();
    let mut scene = ssbc::scene::builtin::cornell();
    scene.ensure_light();
    let frame = render_frames(&mut renderer, &scene, &settings(), 2, None).unwrap();
    let t = &frame.timings;
    assert!(t.passes.is_none() && t.frame_gpu_ms.is_none());
    assert!(t.ssbc_steps.iter().all(|s| s.gpu_ms.is_none()));
    let stats = t.stats.as_ref().unwrap();
    assert!(stats.frame_gpu_ms.is_none() && stats.passes.is_empty());
    let json = serde_json::to_value(t).unwrap();
    assert!(json["passes"].is_null() && json["frame_gpu_ms"].is_null());
    assert!(ssbc::output::timings_table(&frame).contains("no GPU timestamps"));
    // The image is still there.
    assert!(frame.image.rgba.iter().any(|&v| v > 0.0));
    drop(renderer);
    assert_eq!(log.total(), 0, "{:?}", log.messages());
}

/// The CLI: `--frames N --trace FILE` writes stats into the timings JSON and
/// a trace that parses.
#[test]
fn cli_frames_and_trace() {
    let dir = tempfile::tempdir().unwrap();
    let (json, trace) = (dir.path().join("t.json"), dir.path().join("trace.json"));
    let out = Command::new(env!("CARGO_BIN_EXE_ssbc"))
        .args([
            "render",
            "--size",
            "32x24",
            "--vpls",
            "8",
            "--steps",
            "1",
            "--frames",
            "2",
            "--validate",
            "-o",
        ])
        .arg(dir.path().join("o.exr"))
        .arg("--timings")
        .arg(&json)
        .arg("--trace")
        .arg(&trace)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("min / median / max"), "{stderr}");
    let t: Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    assert_eq!(t["stats"]["frames"], 2);
    let step = t["stats"]["passes"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["name"] == "ssbc_step_1")
        .expect("ssbc_step_1 in the stats");
    assert!(step["ms"]["median"].as_f64().unwrap() > 0.0);
    let tr: Value = serde_json::from_slice(&std::fs::read(&trace).unwrap()).unwrap();
    assert!(tr["traceEvents"].as_array().unwrap().len() > 20);
    let (ok, _, err) = {
        let o = Command::new(env!("CARGO_BIN_EXE_ssbc"))
            .args(["render", "--size", "8x8", "--frames", "0"])
            .output()
            .unwrap();
        (
            o.status.success(),
            (),
            String::from_utf8_lossy(&o.stderr).into_owned(),
        )
    };
    assert!(!ok && err.contains("--frames"), "{err}");
}
