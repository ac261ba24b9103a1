//! The viewer under Xvfb on lavapipe: it opens a window, renders a few
//! frames with validation on, and its screenshot is the image the headless
//! renderer makes with the same settings. A missing Xvfb fails the test
//! under the test command (a setup error) and skips it, saying so,
//! elsewhere; an Xvfb that cannot start, or a display the viewer cannot
//! open, always fails it and says why.
#![cfg(feature = "viewer")]

mod common;

use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

struct Xvfb(Child);

impl Drop for Xvfb {
    fn drop(&mut self) {
        // SIGTERM lets Xvfb remove its lock file and socket; SIGKILL left
        // them behind, and every run used up a display number.
        // SAFETY: kill(2) on the pid of our own, not yet reaped child.
        unsafe { libc::kill(self.0.id() as libc::pid_t, libc::SIGTERM) };
        let start = Instant::now();
        while start.elapsed() < Duration::from_secs(5) {
            if let Ok(Some(_)) = self.0.try_wait() {
                return;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Whether display `n` is free. The lock file and socket of a server that
/// is no longer running (killed before it could clean up) are removed.
fn display_is_free(n: u32) -> bool {
    let lock = format!("/tmp/.X{n}-lock");
    let socket = format!("/tmp/.X11-unix/X{n}");
    if let Ok(text) = std::fs::read_to_string(&lock) {
        let alive = text
            .trim()
            .parse::<libc::pid_t>()
            // SAFETY: signal 0 only checks that the process exists (EPERM:
            // it does, as another user's).
            .map(|pid| {
                pid > 0
                    && (unsafe { libc::kill(pid, 0) } == 0
                        || std::io::Error::last_os_error().raw_os_error() != Some(libc::ESRCH))
            })
            .unwrap_or(true);
        if alive {
            return false;
        }
        let _ = std::fs::remove_file(&lock);
        let _ = std::fs::remove_file(&socket);
    }
    !std::path::Path::new(&lock).exists() && !std::path::Path::new(&socket).exists()
}

/// Why the X server is missing: not installed (skip) or broken (fail).
enum NoServer {
    NotInstalled(String),
    Broken(String),
}

/// Starts Xvfb on a free display number.
fn start_xvfb() -> Result<(Xvfb, String), NoServer> {
    for display in 90..120 {
        if !display_is_free(display) {
            continue;
        }
        let child = Command::new("Xvfb")
            .args([
                format!(":{display}"),
                "-screen".into(),
                "0".into(),
                "320x240x24".into(),
                "-nolisten".into(),
                "tcp".into(),
            ])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .map_err(|e| match e.kind() {
                std::io::ErrorKind::NotFound => NoServer::NotInstalled(format!(
                    "Xvfb is not installed ({e}); install xvfb (scripts/setup.sh does)"
                )),
                _ => NoServer::Broken(format!("Xvfb could not be started: {e}")),
            })?;
        let server = Xvfb(child);
        let start = Instant::now();
        while start.elapsed() < Duration::from_secs(10) {
            if std::path::Path::new(&format!("/tmp/.X11-unix/X{display}")).exists() {
                return Ok((server, format!(":{display}")));
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        return Err(NoServer::Broken(format!(
            "Xvfb :{display} did not open its socket within 10 s"
        )));
    }
    Err(NoServer::Broken(
        "no free X display number in :90..:119".into(),
    ))
}

/// `ssbc view SCENE` at 96x72 with 32 VPLs for 3 frames on `display`,
/// validation on, a screenshot to `shot` on exit.
fn view(
    display: &str,
    shot: &std::path::Path,
    scene: &str,
    extra: &[&str],
) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_ssbc"))
        .args(["view", scene, "--size", "96x72", "--frames", "3"])
        .args(["--vpls", "32", "--validate", "--screenshot"])
        .arg(shot)
        .args(extra)
        .env("DISPLAY", display)
        .env_remove("WAYLAND_DISPLAY")
        .env("RUST_LOG", "warn")
        .output()
        .expect("run ssbc view")
}

#[test]
fn viewer_renders_under_xvfb_and_matches_the_headless_image() {
    let (_server, display) = match start_xvfb() {
        Ok(s) => s,
        Err(NoServer::NotInstalled(reason)) => {
            common::cannot_check(&reason);
            return;
        }
        Err(NoServer::Broken(reason)) => panic!("no X server for the viewer: {reason}"),
    };
    let dir = tempfile::tempdir().unwrap();
    let shot = dir.path().join("shot");
    // Frames standing alone, as the headless render (history: below).
    let out = view(&display, &shot, "cornell", &["--no-history"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "viewer failed:\n{stderr}");
    assert!(
        !stderr.contains("validation"),
        "validation messages:\n{stderr}"
    );

    let (w, h, shown) = ssbc::output::read_exr_rgb(&shot.with_extension("exr")).unwrap();
    assert_eq!(
        (w, h),
        (96, 72),
        "the window (and so the render) is the requested size"
    );
    let mut settings = common::small(w, h);
    settings.vpl.count = 32;
    let headless = common::render_validated(&ssbc::scene::builtin::cornell(), &settings);
    let c = ssbc::compare::compare(&shown, &headless.image.rgba).unwrap();
    eprintln!(
        "viewer screenshot vs headless render: relMSE {:.2e}, mean ratio {:.5}",
        c.rel_mse, c.mean_ratio
    );
    assert!(
        c.rel_mse < 1e-6 && (c.mean_ratio - 1.0).abs() < 1e-4,
        "{c:?}"
    );

    // What the GPU path put on screen (present.comp's 8-bit sRGB) is the
    // headless image, encoded: within one step of 8-bit rounding.
    let shown = image::open(dir.path().join("shot-display.png"))
        .expect("displayed frame")
        .into_rgb8();
    let mut worst = 0i32;
    for (i, p) in shown.pixels().enumerate() {
        for c in 0..3 {
            let v = headless.image.rgba[i * 4 + c].clamp(0.0, 1.0);
            let want = (ssbc::output::srgb_encode(v) * 255.0).round() as i32;
            worst = worst.max((p[c] as i32 - want).abs());
        }
    }
    eprintln!("displayed 8-bit frame vs headless render: worst difference {worst}/255");
    assert!(worst <= 1, "displayed frame differs by {worst}/255");

    // With history (the default) a still view averages its frames: the
    // screenshot is the mean of as many frames with independent VPL sets
    // (ISMs for both: `auto` gives a still view's later frames exact
    // visibility where the device has ray queries, an accumulation every
    // frame).
    let out = view(&display, &shot, "cornell", &["--visibility", "ism"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "viewer failed:\n{stderr}");
    let accumulated: u32 = stderr
        .lines()
        .find_map(|l| {
            let (_, rest) = l.split_once(" (")?;
            rest.strip_suffix(" frames accumulated)")?.parse().ok()
        })
        .unwrap_or_else(|| panic!("no accumulated count in:\n{stderr}"));
    assert!(accumulated >= 3, "{accumulated} frames accumulated");
    let (_, _, shown) = ssbc::output::read_exr_rgb(&shot.with_extension("exr")).unwrap();
    let mut renderer = common::validated_renderer();
    let stop = std::sync::atomic::AtomicBool::new(false);
    settings.visibility = ssbc::settings::Visibility::Ism;
    let mean = renderer
        .render_accumulated(
            &ssbc::scene::builtin::cornell(),
            &settings,
            accumulated,
            &stop,
            |_| {},
        )
        .unwrap();
    let c = ssbc::compare::compare(&shown, &mean.image.rgba).unwrap();
    eprintln!(
        "viewer with history, {accumulated} still frames vs their mean: relMSE {:.2e}",
        c.rel_mse
    );
    assert!(c.rel_mse < 1e-6, "{c:?}");

    // A glTF animation plays: the screenshot is a later pose than the
    // start, validation stays clean while the meshes are reloaded.
    let anim = dir.path().join("anim.gltf");
    std::fs::write(&anim, common::animated_quad("LINEAR", common::CHANNEL)).unwrap();
    let out = view(&display, &shot, anim.to_str().unwrap(), &["--no-history"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "viewer failed:\n{stderr}");
    assert!(
        !stderr.contains("validation"),
        "validation messages:\n{stderr}"
    );
    let (_, _, played) = ssbc::output::read_exr_rgb(&shot.with_extension("exr")).unwrap();
    let mut start = ssbc::scene::load(anim.to_str().unwrap()).unwrap();
    start.ensure_light();
    let at_start = common::render_validated(&start, &settings);
    assert!(
        ssbc::compare::compare(&played, &at_start.image.rgba)
            .unwrap()
            .rel_mse
            > 1e-3,
        "the animation did not play"
    );
}
