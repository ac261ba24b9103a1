//! The shared libraries Vulkan loads for ssbc (the loader, the driver and
//! its dependencies, layers), kept mapped for the rest of the process.
//!
//! The loader unloads the driver when the last instance is destroyed.
//! NVIDIA's Linux driver (580.159 on an H100) leaves thread-exit destructors
//! behind in every thread that called into it, so a thread that outlived
//! its renderer crashed when it exited, jumping into the unmapped driver: a
//! test binary whose tests each create and drop a renderer on their own
//! thread crashed in 5 of 5 runs, and in 0 of 2 with the driver preloaded
//! (so never unloaded). Other Vulkan projects meet the same (wgpu issue
//! 8365). An instance made by ssbc therefore marks the libraries that
//! appeared while it and its device were created as never to be unloaded
//! (`RTLD_NODELETE`); a host's own instance is the host's business.
//!
//! Only libraries new since the instance began loading are pinned, so a
//! host's plugins stay unloadable, unless the host loads one between
//! creating ssbc's instance and its device (`Renderer::new` does both at
//! once). Linux only; elsewhere nothing is done.

use std::collections::HashSet;

/// The shared objects mapped into the process at one moment.
#[derive(Debug, Default)]
pub(crate) struct LoadedLibraries(HashSet<String>);

impl LoadedLibraries {
    /// The shared objects mapped now (from `/proc/self/maps`; none where
    /// that cannot be read).
    pub(crate) fn now() -> Self {
        let maps = std::fs::read_to_string("/proc/self/maps").unwrap_or_default();
        Self(
            maps.lines()
                .filter_map(|line| line.split_whitespace().nth(5))
                .filter(|path| path.starts_with('/') && path.contains(".so"))
                .map(str::to_owned)
                .collect(),
        )
    }

    /// Marks every shared object mapped now but not in `self` as never to
    /// be unloaded. Returns how many it marked.
    pub(crate) fn pin_new(&self) -> usize {
        let pinned = Self::now()
            .0
            .difference(&self.0)
            .filter(|path| pin(path))
            .count();
        if pinned > 0 {
            log::debug!("{pinned} shared libraries Vulkan loaded are kept loaded");
        }
        pinned
    }
}

/// Marks the library mapped from `path` never to be unloaded; false if it
/// is not loaded (or this is not Linux).
#[cfg(target_os = "linux")]
fn pin(path: &str) -> bool {
    let Ok(name) = std::ffi::CString::new(path) else {
        return false;
    };
    // SAFETY: with RTLD_NOLOAD dlopen loads nothing and runs no initialiser:
    // it returns the library already mapped from that file (or null) and,
    // with RTLD_NODELETE, marks it never to be unloaded. The extra reference
    // it returns is never closed.
    let handle = unsafe {
        libc::dlopen(
            name.as_ptr(),
            libc::RTLD_NOW | libc::RTLD_NOLOAD | libc::RTLD_NODELETE,
        )
    };
    !handle.is_null()
}

#[cfg(not(target_os = "linux"))]
fn pin(_path: &str) -> bool {
    false
}
