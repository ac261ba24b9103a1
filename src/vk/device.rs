//! Physical-device choice, the logical device, its queue, memory allocator,
//! submission tracking (a timeline semaphore) and deferred destruction.
//!
//! Resources never destroy their Vulkan handles directly: `Drop` hands them to
//! `Device::defer_destroy`, tagged with the last submission that may still
//! use them. They are destroyed once the timeline semaphore has passed that
//! submission (or when the device is dropped, after `vkDeviceWaitIdle`).

use std::ffi::CStr;
use std::mem::ManuallyDrop;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

use ash::vk;
use gpu_allocator::vulkan::{Allocation, Allocator, AllocatorCreateDesc};

use super::instance::Instance;
use crate::error::{Error, Result, VkResultExt};

/// A Vulkan object waiting for the GPU to finish with it.
pub(crate) enum Garbage {
    /// A buffer and its own memory (none: it was bound to aliased memory).
    Buffer(vk::Buffer, Option<Allocation>),
    BufferView(vk::BufferView),
    /// An image and its own memory (as a buffer's).
    Image(vk::Image, Option<Allocation>),
    /// Memory resources of several phases shared (queued after them).
    Memory(Allocation),
    ImageView(vk::ImageView),
    Sampler(vk::Sampler),
    Pipeline(vk::Pipeline),
    PipelineLayout(vk::PipelineLayout),
    DescriptorSetLayout(vk::DescriptorSetLayout),
    DescriptorPool(vk::DescriptorPool),
    QueryPool(vk::QueryPool),
    CommandPool(vk::CommandPool),
    AccelerationStructure(vk::AccelerationStructureKHR),
}

/// Which physical device to use.
#[derive(Clone, Debug, Default)]
pub struct DeviceSelector {
    /// Case-insensitive substring of the device name; None: best available
    /// (discrete, then integrated, then virtual, then CPU).
    pub name_contains: Option<String>,
}

/// The device features ssbc needs enabled (all core in Vulkan 1.3).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RequiredFeatures {
    /// `VkPhysicalDeviceVulkan13Features::synchronization2`.
    pub synchronization2: bool,
    /// `VkPhysicalDeviceVulkan13Features::dynamicRendering`.
    pub dynamic_rendering: bool,
    /// `VkPhysicalDeviceVulkan12Features::timelineSemaphore`.
    pub timeline_semaphore: bool,
    /// `VkPhysicalDeviceVulkan12Features::hostQueryReset`.
    pub host_query_reset: bool,
}

impl RequiredFeatures {
    /// Every feature ssbc needs: what the [`crate::Renderer`] uses.
    pub const ALL: Self = Self {
        synchronization2: true,
        dynamic_rendering: true,
        timeline_semaphore: true,
        host_query_reset: true,
    };

    /// What [`crate::postprocess::SsbcPostProcess`] alone uses: barriers
    /// (synchronization2) and the timeline its resources are destroyed on.
    /// It draws nothing and resets its queries in the host's command buffer.
    pub const POST_PROCESS: Self = Self {
        synchronization2: true,
        dynamic_rendering: false,
        timeline_semaphore: true,
        host_query_reset: false,
    };

    /// Sets these features in the host's Vulkan 1.2 and 1.3 feature
    /// structs, to chain into its `VkDeviceCreateInfo`; what the host set
    /// itself stays set.
    pub fn merge_into<'a>(
        &self,
        v12: vk::PhysicalDeviceVulkan12Features<'a>,
        v13: vk::PhysicalDeviceVulkan13Features<'a>,
    ) -> (
        vk::PhysicalDeviceVulkan12Features<'a>,
        vk::PhysicalDeviceVulkan13Features<'a>,
    ) {
        let on = |host: vk::Bool32, ours: bool| host == vk::TRUE || ours;
        (
            v12.timeline_semaphore(on(v12.timeline_semaphore, self.timeline_semaphore))
                .host_query_reset(on(v12.host_query_reset, self.host_query_reset)),
            v13.synchronization2(on(v13.synchronization2, self.synchronization2))
                .dynamic_rendering(on(v13.dynamic_rendering, self.dynamic_rendering)),
        )
    }

    /// Names of the features [`RequiredFeatures::ALL`] needs that are not set.
    pub fn missing(&self) -> Vec<&'static str> {
        self.missing_from(Self::ALL)
    }

    /// Names of the features `needed` sets that are not set here.
    pub fn missing_from(&self, needed: Self) -> Vec<&'static str> {
        [
            (
                self.synchronization2,
                needed.synchronization2,
                "synchronization2",
            ),
            (
                self.dynamic_rendering,
                needed.dynamic_rendering,
                "dynamicRendering",
            ),
            (
                self.timeline_semaphore,
                needed.timeline_semaphore,
                "timelineSemaphore",
            ),
            (
                self.host_query_reset,
                needed.host_query_reset,
                "hostQueryReset",
            ),
        ]
        .iter()
        .filter(|(on, need, _)| *need && !on)
        .map(|(.., name)| *name)
        .collect()
    }
}

/// What a device was created with, for [`Device::from_parts`].
struct Enabled {
    features: RequiredFeatures,
    /// ssbc created it (and destroys it).
    owns_device: bool,
    pipeline_statistics: bool,
    /// VK_EXT_calibrated_timestamps.
    calibrated: bool,
    /// VK_KHR_ray_query and what it needs.
    ray_queries: bool,
}

/// A device a host engine created and owns, handed to ssbc.
pub struct HostDevice {
    /// The physical device it was created from.
    pub physical: vk::PhysicalDevice,
    /// The device (ssbc never destroys it).
    pub device: ash::Device,
    /// Family of the queue ssbc may submit to (graphics + compute, with timestamps).
    pub queue_family: u32,
    /// Index of that queue in its family. The host must not use it from
    /// another thread while ssbc records or submits.
    pub queue_index: u32,
    /// The features the host enabled at device creation: at least
    /// [`RequiredFeatures::POST_PROCESS`]; [`RequiredFeatures::ALL`] for a
    /// [`crate::Renderer`].
    pub enabled_features: RequiredFeatures,
}

/// The logical device and everything that is per-device.
pub struct Device {
    /// The instance this device came from (kept alive by this Arc).
    pub instance: Arc<Instance>,
    /// The physical device.
    pub physical: vk::PhysicalDevice,
    /// The raw device.
    pub raw: ash::Device,
    /// The one graphics+compute queue used for everything.
    pub queue: vk::Queue,
    /// Its family index.
    pub queue_family: u32,
    /// Physical-device properties (limits, timestamp period).
    pub properties: vk::PhysicalDeviceProperties,
    name: String,
    allocator: ManuallyDrop<Mutex<Allocator>>,
    /// Timeline semaphore counting finished submissions.
    timeline: vk::Semaphore,
    /// Value the next submission will signal.
    next_submission: AtomicU64,
    garbage: Mutex<Vec<(u64, Garbage)>>,
    owns_device: bool,
    /// The features enabled on it (all of them on a device ssbc creates).
    features: RequiredFeatures,
    /// Object names and command labels (None without VK_EXT_debug_utils:
    /// then naming and labelling cost nothing).
    debug_utils: Option<ash::ext::debug_utils::Device>,
    /// Optional capabilities for profiling.
    profiling: ProfilingSupport,
    /// Buffers, images and descriptor pools created so far (a frame that
    /// reuses its resources adds none).
    resources_created: AtomicU64,
    /// ...and destroyed so far.
    resources_destroyed: AtomicU64,
    /// Bytes written by the host into buffers the GPU reads.
    bytes_uploaded: AtomicU64,
    /// GPU/CPU clock pairs (VK_EXT_calibrated_timestamps with the device and
    /// CLOCK_MONOTONIC domains).
    calibration: Option<ash::ext::calibrated_timestamps::Device>,
    /// Acceleration structures and ray queries (VK_KHR_ray_query), where
    /// the device offers them: exact VPL visibility.
    ray_queries: Option<RayQueries>,
}

/// What ray queries need on a device: the acceleration-structure entry
/// points and the scratch alignment.
pub struct RayQueries {
    /// VK_KHR_acceleration_structure's device functions.
    pub functions: ash::khr::acceleration_structure::Device,
    /// `minAccelerationStructureScratchOffsetAlignment`.
    pub scratch_alignment: u64,
}

/// The extensions exact visibility needs.
const RAY_QUERY_EXTENSIONS: [&CStr; 3] = [
    ash::khr::acceleration_structure::NAME,
    ash::khr::ray_query::NAME,
    ash::khr::deferred_host_operations::NAME,
];

/// Whether `pd` offers ray queries: the extensions and the features
/// (accelerationStructure, rayQuery, bufferDeviceAddress).
fn offers_ray_queries(instance: &ash::Instance, pd: vk::PhysicalDevice) -> bool {
    if !RAY_QUERY_EXTENSIONS
        .iter()
        .all(|e| has_device_extension(instance, pd, e))
    {
        return false;
    }
    let mut accel = vk::PhysicalDeviceAccelerationStructureFeaturesKHR::default();
    let mut query = vk::PhysicalDeviceRayQueryFeaturesKHR::default();
    let mut v12 = vk::PhysicalDeviceVulkan12Features::default();
    let mut f2 = vk::PhysicalDeviceFeatures2::default()
        .push_next(&mut accel)
        .push_next(&mut query)
        .push_next(&mut v12);
    // SAFETY: a live physical device of this instance.
    unsafe { instance.get_physical_device_features2(pd, &mut f2) };
    accel.acceleration_structure == vk::TRUE
        && query.ray_query == vk::TRUE
        && v12.buffer_device_address == vk::TRUE
}

/// What the device offers for profiling (each optional).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ProfilingSupport {
    /// Valid bits of the queue's timestamps (0: no timestamps; ssbc's timings
    /// are then absent).
    pub timestamp_valid_bits: u32,
    /// Nanoseconds per timestamp tick.
    pub timestamp_period_ns: f32,
    /// `pipelineStatisticsQuery` is enabled (compute invocations per pass).
    pub pipeline_statistics: bool,
    /// GPU timestamps can be placed on CLOCK_MONOTONIC
    /// (VK_EXT_calibrated_timestamps).
    pub calibrated_timestamps: bool,
}

/// Whether VK_EXT_calibrated_timestamps on `pd` relates the device clock to
/// CLOCK_MONOTONIC (the clock ssbc's CPU trace events use).
fn calibrates_to_monotonic(instance: &Instance, pd: vk::PhysicalDevice) -> bool {
    if !cfg!(unix)
        || !has_device_extension(&instance.raw, pd, ash::ext::calibrated_timestamps::NAME)
    {
        return false;
    }
    let ext = ash::ext::calibrated_timestamps::Instance::new(&instance.entry, &instance.raw);
    // SAFETY: the extension is offered by `pd`, enumerated from this instance.
    let domains =
        unsafe { ext.get_physical_device_calibrateable_time_domains(pd) }.unwrap_or_default();
    domains.contains(&vk::TimeDomainEXT::DEVICE)
        && domains.contains(&vk::TimeDomainEXT::CLOCK_MONOTONIC)
}

fn has_device_extension(instance: &ash::Instance, pd: vk::PhysicalDevice, name: &CStr) -> bool {
    // SAFETY: `pd` was enumerated from this instance.
    unsafe { instance.enumerate_device_extension_properties(pd) }
        .map(|exts| {
            exts.iter()
                .any(|e| e.extension_name_as_c_str().ok() == Some(name))
        })
        .unwrap_or(false)
}

fn device_type_rank(t: vk::PhysicalDeviceType) -> u32 {
    match t {
        vk::PhysicalDeviceType::DISCRETE_GPU => 0,
        vk::PhysicalDeviceType::INTEGRATED_GPU => 1,
        vk::PhysicalDeviceType::VIRTUAL_GPU => 2,
        vk::PhysicalDeviceType::CPU => 3,
        _ => 4,
    }
}

/// Why a physical device cannot run ssbc, or None when it can.
fn unsuitable_reason(instance: &ash::Instance, pd: vk::PhysicalDevice) -> Option<String> {
    // SAFETY: `pd` was enumerated from this instance.
    let props = unsafe { instance.get_physical_device_properties(pd) };
    if props.api_version < vk::API_VERSION_1_3 {
        return Some("needs Vulkan 1.3".into());
    }
    let mut f12 = vk::PhysicalDeviceVulkan12Features::default();
    let mut f13 = vk::PhysicalDeviceVulkan13Features::default();
    let mut f2 = vk::PhysicalDeviceFeatures2::default()
        .push_next(&mut f12)
        .push_next(&mut f13);
    // SAFETY: valid physical device and a correctly chained query struct.
    unsafe { instance.get_physical_device_features2(pd, &mut f2) };
    let missing = RequiredFeatures {
        synchronization2: f13.synchronization2 == vk::TRUE,
        dynamic_rendering: f13.dynamic_rendering == vk::TRUE,
        timeline_semaphore: f12.timeline_semaphore == vk::TRUE,
        host_query_reset: f12.host_query_reset == vk::TRUE,
    }
    .missing();
    if !missing.is_empty() {
        return Some(format!("missing features {}", missing.join(", ")));
    }
    if queue_family_index(instance, pd).is_none() {
        return Some("no graphics+compute queue".into());
    }
    None
}

fn queue_family_index(instance: &ash::Instance, pd: vk::PhysicalDevice) -> Option<u32> {
    // SAFETY: valid physical device.
    let families = unsafe { instance.get_physical_device_queue_family_properties(pd) };
    let usable = |f: &&vk::QueueFamilyProperties| {
        f.queue_flags
            .contains(vk::QueueFlags::GRAPHICS | vk::QueueFlags::COMPUTE)
    };
    // A family with timestamps if there is one (timings need them).
    let with_timestamps = families
        .iter()
        .position(|f| usable(&f) && f.timestamp_valid_bits > 0);
    with_timestamps
        .or_else(|| families.iter().position(|f| usable(&f)))
        .map(|i| i as u32)
}

/// The driver's name and version as it reports them (Vulkan 1.2's
/// driverName and driverInfo, e.g. "llvmpipe, Mesa 25.0.7-2~bpo12+1 (LLVM
/// 15.0.6)"): what tells two drivers of one device name apart.
fn driver_description(instance: &ash::Instance, physical: vk::PhysicalDevice) -> String {
    let mut v12 = vk::PhysicalDeviceVulkan12Properties::default();
    let mut props2 = vk::PhysicalDeviceProperties2::default().push_next(&mut v12);
    // SAFETY: a live physical device of this Vulkan 1.3 instance.
    unsafe { instance.get_physical_device_properties2(physical, &mut props2) };
    let text = |c: Result<&CStr, _>| {
        c.map(|c| c.to_string_lossy().into_owned())
            .unwrap_or_default()
    };
    let (name, info) = (
        text(v12.driver_name_as_c_str()),
        text(v12.driver_info_as_c_str()),
    );
    match (name.is_empty(), info.is_empty()) {
        (true, true) => "(driver not named)".into(),
        (false, false) => format!("{name}, {info}"),
        _ => format!("{name}{info}"),
    }
}

fn device_name(props: &vk::PhysicalDeviceProperties) -> String {
    props
        .device_name_as_c_str()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|_| "(unnamed)".into())
}

impl Device {
    /// Picks a physical device and creates the logical device with the
    /// features ssbc needs, plus `extra_extensions` (e.g. the swapchain).
    pub fn new(
        instance: Arc<Instance>,
        selector: &DeviceSelector,
        extra_extensions: &[&CStr],
    ) -> Result<Arc<Self>> {
        // SAFETY: enumeration on a live instance.
        let physicals = unsafe { instance.raw.enumerate_physical_devices() }
            .map_err(|e| Error::NoDevice(format!("vkEnumeratePhysicalDevices returned {e}")))?;
        if physicals.is_empty() {
            return Err(Error::NoDevice("the Vulkan loader found no device".into()));
        }
        let mut candidates = Vec::new();
        let mut rejected = Vec::new();
        for &pd in &physicals {
            // SAFETY: enumerated above.
            let props = unsafe { instance.raw.get_physical_device_properties(pd) };
            let name = device_name(&props);
            if let Some(filter) = &selector.name_contains {
                if !name.to_lowercase().contains(&filter.to_lowercase()) {
                    rejected.push(format!("{name} (name does not match '{filter}')"));
                    continue;
                }
            }
            match unsuitable_reason(&instance.raw, pd) {
                Some(why) => rejected.push(format!("{name} ({why})")),
                None => candidates.push((device_type_rank(props.device_type), pd, props)),
            }
        }
        candidates.sort_by_key(|c| c.0);
        let Some(&(_, physical, properties)) = candidates.first() else {
            return Err(Error::NoDevice(format!(
                "no suitable device among: {}",
                rejected.join("; ")
            )));
        };
        let queue_family = queue_family_index(&instance.raw, physical).expect("checked suitable");

        let priorities = [1.0f32];
        let queue_info = [vk::DeviceQueueCreateInfo::default()
            .queue_family_index(queue_family)
            .queue_priorities(&priorities)];
        let mut ext_ptrs: Vec<*const i8> = extra_extensions.iter().map(|e| e.as_ptr()).collect();
        // Optional profiling features, enabled when offered.
        let calibrated = calibrates_to_monotonic(&instance, physical);
        if calibrated {
            ext_ptrs.push(ash::ext::calibrated_timestamps::NAME.as_ptr());
        }
        // SAFETY: valid physical device.
        let offered = unsafe { instance.raw.get_physical_device_features(physical) };
        let statistics = offered.pipeline_statistics_query == vk::TRUE;
        // Ray queries for exact visibility, enabled when offered.
        let ray_queries = offers_ray_queries(&instance.raw, physical);
        if ray_queries {
            ext_ptrs.extend(RAY_QUERY_EXTENSIONS.iter().map(|e| e.as_ptr()));
        }
        let mut f12 = vk::PhysicalDeviceVulkan12Features::default()
            .timeline_semaphore(true)
            .host_query_reset(true)
            .buffer_device_address(ray_queries);
        let mut f13 = vk::PhysicalDeviceVulkan13Features::default()
            .synchronization2(true)
            .dynamic_rendering(true);
        let mut accel = vk::PhysicalDeviceAccelerationStructureFeaturesKHR::default()
            .acceleration_structure(true);
        let mut query = vk::PhysicalDeviceRayQueryFeaturesKHR::default().ray_query(true);
        let base = vk::PhysicalDeviceFeatures::default().pipeline_statistics_query(statistics);
        let mut create_info = vk::DeviceCreateInfo::default()
            .queue_create_infos(&queue_info)
            .enabled_extension_names(&ext_ptrs)
            .enabled_features(&base)
            .push_next(&mut f12)
            .push_next(&mut f13);
        if ray_queries {
            create_info = create_info.push_next(&mut accel).push_next(&mut query);
        }
        // SAFETY: the physical device supports every feature requested (checked).
        let raw = unsafe { instance.raw.create_device(physical, &create_info, None) }
            .vk("vkCreateDevice")?;
        instance.pin_driver_libraries();
        let name = device_name(&properties);
        log::info!(
            "using Vulkan device '{name}' (driver: {})",
            driver_description(&instance.raw, physical)
        );
        Self::from_parts(
            instance,
            physical,
            raw,
            (queue_family, 0),
            properties,
            name,
            Enabled {
                features: RequiredFeatures::ALL,
                owns_device: true,
                pipeline_statistics: statistics,
                calibrated,
                ray_queries,
            },
        )
    }

    /// Wraps a host engine's device. Checks the API version, the queue
    /// family and the enabled features, naming whatever is missing. ssbc
    /// creates its own allocator, semaphore, pools and resources on it and
    /// destroys only those.
    pub fn from_host(instance: Arc<Instance>, host: HostDevice) -> Result<Arc<Self>> {
        // SAFETY: the host guarantees `physical` belongs to `instance`.
        let properties = unsafe { instance.raw.get_physical_device_properties(host.physical) };
        let mut problems = Vec::new();
        if properties.api_version < vk::API_VERSION_1_3 {
            problems.push("the physical device does not support Vulkan 1.3".to_string());
        }
        let missing = host
            .enabled_features
            .missing_from(RequiredFeatures::POST_PROCESS);
        if !missing.is_empty() {
            problems.push(format!("features not enabled: {}", missing.join(", ")));
        }
        // SAFETY: as above.
        let families = unsafe {
            instance
                .raw
                .get_physical_device_queue_family_properties(host.physical)
        };
        match families.get(host.queue_family as usize) {
            None => problems.push(format!("queue family {} does not exist", host.queue_family)),
            Some(f) => {
                if !f
                    .queue_flags
                    .contains(vk::QueueFlags::GRAPHICS | vk::QueueFlags::COMPUTE)
                {
                    problems.push(format!(
                        "queue family {} lacks graphics+compute",
                        host.queue_family
                    ));
                }
                if host.queue_index >= f.queue_count {
                    problems.push(format!("queue index {} out of range", host.queue_index));
                }
            }
        }
        if !problems.is_empty() {
            return Err(Error::NoDevice(format!(
                "the host device cannot run ssbc: {}",
                problems.join("; ")
            )));
        }
        let name = device_name(&properties);
        Self::from_parts(
            instance,
            host.physical,
            host.device,
            (host.queue_family, host.queue_index),
            properties,
            name,
            // Pipeline statistics, calibrated timestamps and ray queries
            // are not used: ssbc cannot know whether the host enabled them.
            Enabled {
                features: host.enabled_features,
                owns_device: false,
                pipeline_statistics: false,
                calibrated: false,
                ray_queries: false,
            },
        )
    }

    fn from_parts(
        instance: Arc<Instance>,
        physical: vk::PhysicalDevice,
        raw: ash::Device,
        (queue_family, queue_index): (u32, u32),
        properties: vk::PhysicalDeviceProperties,
        name: String,
        enabled: Enabled,
    ) -> Result<Arc<Self>> {
        let Enabled {
            features,
            owns_device,
            pipeline_statistics,
            calibrated,
            ray_queries,
        } = enabled;
        // SAFETY: the family was created with at least `queue_index + 1` queues.
        let queue = unsafe { raw.get_device_queue(queue_family, queue_index) };
        let allocator = Allocator::new(&AllocatorCreateDesc {
            instance: instance.raw.clone(),
            device: raw.clone(),
            physical_device: physical,
            debug_settings: Default::default(),
            buffer_device_address: ray_queries,
            allocation_sizes: Default::default(),
        })?;
        let mut type_info = vk::SemaphoreTypeCreateInfo::default()
            .semaphore_type(vk::SemaphoreType::TIMELINE)
            .initial_value(0);
        let sem_info = vk::SemaphoreCreateInfo::default().push_next(&mut type_info);
        // SAFETY: timeline semaphores were enabled on this device.
        let timeline = unsafe { raw.create_semaphore(&sem_info, None) }.vk("vkCreateSemaphore")?;
        let debug_utils = instance
            .debug_utils_enabled()
            .then(|| ash::ext::debug_utils::Device::new(&instance.raw, &raw));
        let calibration =
            calibrated.then(|| ash::ext::calibrated_timestamps::Device::new(&instance.raw, &raw));
        let ray_queries = ray_queries.then(|| {
            let mut accel = vk::PhysicalDeviceAccelerationStructurePropertiesKHR::default();
            let mut props2 = vk::PhysicalDeviceProperties2::default().push_next(&mut accel);
            // SAFETY: a live physical device of this instance.
            unsafe {
                instance
                    .raw
                    .get_physical_device_properties2(physical, &mut props2)
            };
            RayQueries {
                functions: ash::khr::acceleration_structure::Device::new(&instance.raw, &raw),
                scratch_alignment: accel
                    .min_acceleration_structure_scratch_offset_alignment
                    .max(1) as u64,
            }
        });
        // SAFETY: valid instance and physical device.
        let families = unsafe {
            instance
                .raw
                .get_physical_device_queue_family_properties(physical)
        };
        let profiling = ProfilingSupport {
            timestamp_valid_bits: families[queue_family as usize].timestamp_valid_bits,
            timestamp_period_ns: properties.limits.timestamp_period,
            pipeline_statistics,
            calibrated_timestamps: calibrated,
        };
        let device = Arc::new(Self {
            instance,
            physical,
            raw,
            queue,
            queue_family,
            properties,
            name,
            allocator: ManuallyDrop::new(Mutex::new(allocator)),
            timeline,
            next_submission: AtomicU64::new(1),
            garbage: Mutex::new(Vec::new()),
            owns_device,
            features,
            debug_utils,
            profiling,
            calibration,
            resources_created: AtomicU64::new(0),
            resources_destroyed: AtomicU64::new(0),
            bytes_uploaded: AtomicU64::new(0),
            ray_queries,
        });
        device.set_name(device.timeline, "ssbc.timeline");
        Ok(device)
    }

    /// Names a Vulkan object for validation messages and capture tools
    /// (RenderDoc, Nsight); nothing happens without VK_EXT_debug_utils.
    pub fn set_name(&self, handle: impl vk::Handle, name: &str) {
        let Some(debug_utils) = &self.debug_utils else {
            return;
        };
        let Ok(name) = std::ffi::CString::new(name) else {
            return;
        };
        let info = vk::DebugUtilsObjectNameInfoEXT::default()
            .object_handle(handle)
            .object_name(&name);
        // SAFETY: `handle` is a live object of this device; a failure only
        // loses a name.
        let _ = unsafe { debug_utils.set_debug_utils_object_name(&info) };
    }

    /// Opens a labelled region in a command buffer (nothing without debug utils).
    pub fn begin_label(&self, cmd: vk::CommandBuffer, name: &str) {
        let Some(debug_utils) = &self.debug_utils else {
            return;
        };
        // (Always open the region: end_label closes one.)
        let name = std::ffi::CString::new(name).unwrap_or_else(|_| c"(unnamed)".into());
        let label = vk::DebugUtilsLabelEXT::default().label_name(&name);
        // SAFETY: `cmd` is recording on this device.
        unsafe { debug_utils.cmd_begin_debug_utils_label(cmd, &label) };
    }

    /// Closes the region [`Device::begin_label`] opened.
    pub fn end_label(&self, cmd: vk::CommandBuffer) {
        if let Some(debug_utils) = &self.debug_utils {
            // SAFETY: `cmd` is recording with a label region open.
            unsafe { debug_utils.cmd_end_debug_utils_label(cmd) };
        }
    }

    /// Buffers, images and descriptor pools ssbc has created on this device
    /// so far (for checking that frames allocate nothing).
    pub fn resources_created(&self) -> u64 {
        self.resources_created.load(Ordering::Relaxed)
    }

    /// Buffers, images and descriptor pools alive now (created, not yet
    /// destroyed; including those waiting for deferred destruction).
    pub fn live_resources(&self) -> u64 {
        self.resources_created.load(Ordering::Relaxed)
            - self.resources_destroyed.load(Ordering::Relaxed)
    }

    /// Objects waiting in the deferred-destruction queue.
    pub fn pending_destruction(&self) -> usize {
        self.garbage.lock().unwrap_or_else(|p| p.into_inner()).len()
    }

    /// Bytes ssbc has written from the host into GPU-visible buffers on
    /// this device so far (meshes, textures, VPLs, points, transforms).
    pub fn bytes_uploaded(&self) -> u64 {
        self.bytes_uploaded.load(Ordering::Relaxed)
    }

    /// Counts `bytes` written for the GPU (see [`Device::bytes_uploaded`]).
    pub(crate) fn count_upload(&self, bytes: usize) {
        self.bytes_uploaded
            .fetch_add(bytes as u64, Ordering::Relaxed);
    }

    /// Counts one created resource (see [`Device::resources_created`]).
    pub(crate) fn count_resource(&self) {
        self.resources_created.fetch_add(1, Ordering::Relaxed);
    }

    /// What the device offers for profiling.
    pub fn profiling(&self) -> ProfilingSupport {
        self.profiling
    }

    /// A simultaneous (device timestamp, CLOCK_MONOTONIC ns) pair, when the
    /// device supports calibrated timestamps.
    pub fn calibrated_timestamps(&self) -> Option<(u64, u64)> {
        let calibration = self.calibration.as_ref()?;
        let infos = [
            vk::CalibratedTimestampInfoEXT::default().time_domain(vk::TimeDomainEXT::DEVICE),
            vk::CalibratedTimestampInfoEXT::default()
                .time_domain(vk::TimeDomainEXT::CLOCK_MONOTONIC),
        ];
        // SAFETY: both domains were reported calibrateable for this device.
        let (values, _deviation) = unsafe { calibration.get_calibrated_timestamps(&infos) }.ok()?;
        Some((values[0], values[1]))
    }

    /// Device name as the driver reports it.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Acceleration structures and ray queries, where the device offers
    /// them (exact VPL visibility).
    pub fn ray_queries(&self) -> Option<&RayQueries> {
        self.ray_queries.as_ref()
    }

    /// The driver's name and version (driverName, driverInfo).
    pub fn driver(&self) -> String {
        driver_description(&self.instance.raw, self.physical)
    }

    /// Device limits.
    pub fn limits(&self) -> &vk::PhysicalDeviceLimits {
        &self.properties.limits
    }

    /// The features enabled on the device ([`RequiredFeatures::ALL`] on one
    /// ssbc created; what the host said for a host's).
    pub fn enabled_features(&self) -> RequiredFeatures {
        self.features
    }

    /// Bytes of device memory ssbc's resources on this device take now (its
    /// allocator's live allocations; a host's own memory is not counted).
    pub fn memory_in_use(&self) -> u64 {
        self.allocator().generate_report().total_allocated_bytes
    }

    /// ssbc's live allocations on this device, with their debug names and
    /// sizes.
    pub fn allocation_report(&self) -> Vec<gpu_allocator::AllocationReport> {
        self.allocator().generate_report().allocations
    }

    /// What images of `format` in optimal tiling can do on this device
    /// (sampled, storage, ...).
    pub fn format_features(&self, format: vk::Format) -> vk::FormatFeatureFlags {
        // SAFETY: a live physical device of this instance; any format value
        // is valid to query.
        unsafe {
            self.instance
                .raw
                .get_physical_device_format_properties(self.physical, format)
        }
        .optimal_tiling_features
    }

    /// Size of the largest device-local memory heap (bytes): what a frame's
    /// resources must fit in.
    pub fn device_local_heap(&self) -> u64 {
        // SAFETY: a live physical device of this instance.
        let memory = unsafe {
            self.instance
                .raw
                .get_physical_device_memory_properties(self.physical)
        };
        memory.memory_heaps[..memory.memory_heap_count as usize]
            .iter()
            .filter(|h| h.flags.contains(vk::MemoryHeapFlags::DEVICE_LOCAL))
            .map(|h| h.size)
            .max()
            .unwrap_or(0)
    }

    /// The memory allocator.
    pub(crate) fn allocator(&self) -> std::sync::MutexGuard<'_, Allocator> {
        self.allocator.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Submits command buffers on the queue and returns the timeline value
    /// that signals their completion.
    pub fn submit(&self, command_buffers: &[vk::CommandBuffer]) -> Result<u64> {
        self.submit_with(command_buffers, &[], &[])
    }

    /// Submits, waiting on binary semaphores at the given stages and
    /// signalling `signals` as well as the timeline (whose value is returned).
    pub fn submit_with(
        &self,
        command_buffers: &[vk::CommandBuffer],
        waits: &[(vk::Semaphore, vk::PipelineStageFlags2)],
        signals: &[vk::Semaphore],
    ) -> Result<u64> {
        let value = self.next_submission.fetch_add(1, Ordering::SeqCst);
        let cmd_infos: Vec<_> = command_buffers
            .iter()
            .map(|&c| vk::CommandBufferSubmitInfo::default().command_buffer(c))
            .collect();
        let mut signal = vec![vk::SemaphoreSubmitInfo::default()
            .semaphore(self.timeline)
            .value(value)
            .stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)];
        signal.extend(signals.iter().map(|&s| {
            vk::SemaphoreSubmitInfo::default()
                .semaphore(s)
                .stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)
        }));
        let wait: Vec<_> = waits
            .iter()
            .map(|&(s, stage)| {
                vk::SemaphoreSubmitInfo::default()
                    .semaphore(s)
                    .stage_mask(stage)
            })
            .collect();
        let submit = vk::SubmitInfo2::default()
            .command_buffer_infos(&cmd_infos)
            .wait_semaphore_infos(&wait)
            .signal_semaphore_infos(&signal);
        // SAFETY: the command buffers are recorded and ended by the caller; the
        // queue is only used from the thread that owns the renderer.
        unsafe {
            self.raw
                .queue_submit2(self.queue, &[submit], vk::Fence::null())
        }
        .vk("vkQueueSubmit2")?;
        Ok(value)
    }

    /// Blocks until the submission with timeline `value` has finished, then
    /// destroys garbage that is no longer in use.
    pub fn wait(&self, value: u64) -> Result<()> {
        if self.instance.validation_mode() == super::Validation::GpuAssisted {
            // GPU-assisted validation (layer 1.3.239) loses track of timeline
            // signals and times out in vkWaitSemaphores; idling the queue
            // retires every submission for it.
            // SAFETY: the queue is only used from the thread that owns the renderer.
            unsafe { self.raw.queue_wait_idle(self.queue) }.vk("vkQueueWaitIdle")?;
            self.collect_garbage();
            return Ok(());
        }
        let semaphores = [self.timeline];
        let values = [value];
        let info = vk::SemaphoreWaitInfo::default()
            .semaphores(&semaphores)
            .values(&values);
        // SAFETY: valid timeline semaphore; the value was or will be signalled.
        unsafe { self.raw.wait_semaphores(&info, u64::MAX) }.vk("vkWaitSemaphores")?;
        self.collect_garbage();
        Ok(())
    }

    /// The timeline semaphore every submission signals (its value is the
    /// submission's number).
    pub fn timeline(&self) -> vk::Semaphore {
        self.timeline
    }

    /// Timeline value of the last finished submission.
    pub fn completed_submission(&self) -> u64 {
        if self.instance.validation_mode() == super::Validation::GpuAssisted {
            // See `wait`: ask the queue, not the semaphore.
            // SAFETY: the queue is only used from the thread that owns the renderer.
            if unsafe { self.raw.queue_wait_idle(self.queue) }.is_ok() {
                return self.next_submission.load(Ordering::SeqCst) - 1;
            }
        }
        // SAFETY: valid timeline semaphore.
        unsafe { self.raw.get_semaphore_counter_value(self.timeline) }.unwrap_or(0)
    }

    /// Queues a handle for destruction once every submission made so far is done.
    pub(crate) fn defer_destroy(&self, garbage: Garbage) {
        let last_submitted = self.next_submission.load(Ordering::SeqCst) - 1;
        self.garbage
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .push((last_submitted, garbage));
    }

    /// Destroys the queued objects whose submissions have finished.
    pub fn collect_garbage(&self) {
        let done = self.completed_submission();
        let mut queue = self.garbage.lock().unwrap_or_else(|p| p.into_inner());
        let (ready, waiting): (Vec<_>, Vec<_>) = queue.drain(..).partition(|(s, _)| *s <= done);
        *queue = waiting;
        drop(queue);
        for (_, g) in ready {
            self.destroy_now(g);
        }
    }

    fn destroy_now(&self, garbage: Garbage) {
        // SAFETY (all arms): the timeline says no submission still uses the
        // handle, and each handle was created from this device and queued once.
        unsafe {
            match garbage {
                Garbage::Buffer(b, a) => {
                    self.raw.destroy_buffer(b, None);
                    if let Some(a) = a {
                        self.free_allocation(a);
                    }
                    self.resources_destroyed.fetch_add(1, Ordering::Relaxed);
                }
                Garbage::Image(i, a) => {
                    self.raw.destroy_image(i, None);
                    if let Some(a) = a {
                        self.free_allocation(a);
                    }
                    self.resources_destroyed.fetch_add(1, Ordering::Relaxed);
                }
                Garbage::Memory(a) => self.free_allocation(a),
                Garbage::BufferView(v) => self.raw.destroy_buffer_view(v, None),
                Garbage::ImageView(v) => self.raw.destroy_image_view(v, None),
                Garbage::Sampler(s) => self.raw.destroy_sampler(s, None),
                Garbage::Pipeline(p) => self.raw.destroy_pipeline(p, None),
                Garbage::PipelineLayout(l) => self.raw.destroy_pipeline_layout(l, None),
                Garbage::DescriptorSetLayout(l) => self.raw.destroy_descriptor_set_layout(l, None),
                Garbage::DescriptorPool(p) => {
                    self.raw.destroy_descriptor_pool(p, None);
                    self.resources_destroyed.fetch_add(1, Ordering::Relaxed);
                }
                Garbage::QueryPool(p) => self.raw.destroy_query_pool(p, None),
                Garbage::CommandPool(p) => self.raw.destroy_command_pool(p, None),
                Garbage::AccelerationStructure(a) => {
                    if let Some(rq) = &self.ray_queries {
                        rq.functions.destroy_acceleration_structure(a, None);
                    }
                }
            }
        }
    }

    fn free_allocation(&self, allocation: Allocation) {
        if let Err(e) = self.allocator().free(allocation) {
            log::error!("freeing GPU memory failed: {e}");
        }
    }

    /// Waits until the queue is idle.
    pub fn wait_idle(&self) -> Result<()> {
        // SAFETY: valid device.
        unsafe { self.raw.device_wait_idle() }.vk("vkDeviceWaitIdle")
    }
}

impl Drop for Device {
    fn drop(&mut self) {
        // SAFETY: nothing else holds the device (this is the last Arc); after
        // wait-idle no submission uses any queued object.
        unsafe {
            let _ = self.raw.device_wait_idle();
        }
        let queued: Vec<_> = self
            .garbage
            .get_mut()
            .unwrap_or_else(|p| p.into_inner())
            .drain(..)
            .collect();
        for (_, g) in queued {
            self.destroy_now(g);
        }
        // SAFETY: the allocator's memory blocks must be freed before the device.
        unsafe {
            ManuallyDrop::drop(&mut self.allocator);
            self.raw.destroy_semaphore(self.timeline, None);
            if self.owns_device {
                self.raw.destroy_device(None);
            }
        }
    }
}
