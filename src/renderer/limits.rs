//! What the device and the settings allow, checked before a frame.

use crate::error::{Error, Result};
use crate::settings::{Bound, RenderSettings};
use crate::vk::Device;

/// Largest number of ISM points uploaded (VPLs x points per VPL).
const MAX_ISM_POINTS: u64 = 1 << 26;

/// Validates an image size against the device.
fn check_size(device: &Device, width: u32, height: u32) -> Result<()> {
    let max = device.limits().max_image_dimension2_d;
    if width == 0 || height == 0 {
        return Err(Error::InvalidParameter(format!(
            "image size {width}x{height} is empty"
        )));
    }
    if width > max || height > max {
        return Err(Error::InvalidParameter(format!(
            "image size {width}x{height} exceeds the device limit of {max} pixels per side"
        )));
    }
    Ok(())
}

/// Checks `settings` against what `device` can do.
pub(super) fn check_settings(device: &Device, settings: &RenderSettings) -> Result<()> {
    check_size(device, settings.width, settings.height)?;
    let max = device.limits().max_image_dimension2_d;
    let sm = settings.shadow_map_size;
    if sm < 16 || sm > max {
        return Err(Error::InvalidParameter(format!(
            "shadow_map_size {sm} outside 16..={max}"
        )));
    }
    if let Bound::Value(b) = settings.bound {
        if b.is_nan() || b <= 0.0 {
            return Err(Error::InvalidParameter(format!(
                "bound {b} must be positive (or inf)"
            )));
        }
    }
    if settings.vpl.count > 0 && settings.points_per_vpl == 0 {
        return Err(Error::InvalidParameter(
            "points_per_vpl must be at least 1".into(),
        ));
    }
    // Every ISM point is 16 bytes in one storage buffer.
    let max_range = device.limits().max_storage_buffer_range as u64;
    let points = settings.vpl.count as u64 * settings.points_per_vpl as u64;
    if points * 16 > max_range {
        return Err(Error::InvalidParameter(format!(
            "{} VPLs x {} points per VPL need {} MiB of ISM points; this device's storage \
             buffers hold at most {} MiB (maxStorageBufferRange): use fewer VPLs or points",
            settings.vpl.count,
            settings.points_per_vpl,
            (points * 16) >> 20,
            max_range >> 20
        )));
    }
    if settings.ssbc.steps > 0 {
        crate::passes::ssbc::check_size(
            device,
            settings.width,
            settings.height,
            settings.ssbc.second_layer(),
        )?;
    }
    if settings.vpl.count as u64 * settings.points_per_vpl as u64 > MAX_ISM_POINTS {
        return Err(Error::InvalidParameter(format!(
            "{} VPLs x {} points per VPL exceeds {MAX_ISM_POINTS} ISM points",
            settings.vpl.count, settings.points_per_vpl
        )));
    }
    settings.validate()
}
