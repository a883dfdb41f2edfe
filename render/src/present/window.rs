//! Presenting to a window: a surface and swapchain that survive resizes, minimising and
//! out-of-date swapchains. The window itself (winit) lives in the application; this module takes
//! its raw handles.
//!
//! Each frame slot owns an acquire semaphore; each swapchain image owns a render-finished
//! semaphore (an image's semaphore is only reused once that image is acquired again, which is
//! when its previous present has consumed it).

use std::ffi::CStr;

use ash::{khr, vk};
use raw_window_handle::{RawDisplayHandle, RawWindowHandle};

use crate::RenderError;
use crate::gpu::FRAMES_IN_FLIGHT;
use crate::gpu::device::GpuContext;
use crate::graph::ImageState;

/// The instance extensions a surface on `display` needs.
pub fn required_extensions(display: RawDisplayHandle) -> Result<Vec<&'static CStr>, RenderError> {
    let names = ash_window::enumerate_required_extensions(display)?;
    // SAFETY: ash-window returns pointers to 'static, NUL-terminated extension-name constants.
    Ok(names.iter().map(|&p| unsafe { CStr::from_ptr(p) }).collect())
}

/// A window's surface and swapchain.
pub struct WindowSurface {
    surface_fn: khr::surface::Instance,
    swapchain_fn: khr::swapchain::Device,
    surface: vk::SurfaceKHR,
    swapchain: vk::SwapchainKHR,
    /// Swapchain images.
    pub images: Vec<vk::Image>,
    /// Their views.
    pub views: Vec<vk::ImageView>,
    /// Their tracked states.
    pub states: Vec<ImageState>,
    render_done: Vec<vk::Semaphore>,
    acquired: [vk::Semaphore; FRAMES_IN_FLIGHT],
    /// Colour format of the images.
    pub format: vk::Format,
    /// Current size.
    pub extent: vk::Extent2D,
    wanted: vk::Extent2D,
    stale: bool,
}

impl WindowSurface {
    /// Creates the surface for a window and a swapchain of `width`×`height`.
    pub fn new(ctx: &GpuContext, display: RawDisplayHandle, window: RawWindowHandle, width: u32, height: u32) -> Result<Self, RenderError> {
        // SAFETY: the handles come from a live window that the caller keeps alive longer than
        // this surface (the application drops the surface first).
        let surface = unsafe { ash_window::create_surface(&ctx.entry, &ctx.instance, display, window, None) }?;
        let surface_fn = khr::surface::Instance::new(&ctx.entry, &ctx.instance);
        // SAFETY: valid physical device, queue family and surface.
        let supported = unsafe { surface_fn.get_physical_device_surface_support(ctx.physical, ctx.queue_family, surface) }?;
        if !supported {
            // SAFETY: the surface is unused.
            unsafe { surface_fn.destroy_surface(surface, None) };
            return Err(RenderError::NoVulkan(format!("{} cannot present to this window", ctx.device_name)));
        }
        // SAFETY: as above.
        let formats = unsafe { surface_fn.get_physical_device_surface_formats(ctx.physical, surface) }?;
        let format = formats
            .iter()
            .find(|f| f.format == vk::Format::B8G8R8A8_SRGB && f.color_space == vk::ColorSpaceKHR::SRGB_NONLINEAR)
            .or_else(|| formats.iter().find(|f| f.format == vk::Format::R8G8B8A8_SRGB))
            .map(|f| f.format)
            .ok_or_else(|| RenderError::Other("the window offers no sRGB 8-bit format".into()))?;
        let semaphore = || {
            // SAFETY: a plain binary semaphore; destroyed in `destroy`.
            unsafe { ctx.device.create_semaphore(&vk::SemaphoreCreateInfo::default(), None) }
        };
        let acquired = [semaphore()?, semaphore()?];
        let mut this = Self {
            swapchain_fn: khr::swapchain::Device::new(&ctx.instance, &ctx.device),
            surface_fn,
            surface,
            swapchain: vk::SwapchainKHR::null(),
            images: Vec::new(),
            views: Vec::new(),
            states: Vec::new(),
            render_done: Vec::new(),
            acquired,
            format,
            extent: vk::Extent2D::default(),
            wanted: vk::Extent2D { width, height },
            stale: true,
        };
        this.recreate(ctx)?;
        Ok(this)
    }

    /// Asks for a new size; the swapchain is rebuilt before the next frame.
    pub fn resize(&mut self, width: u32, height: u32) {
        self.wanted = vk::Extent2D { width, height };
        self.stale = true;
    }

    /// True while the window has no area (minimised): nothing is drawn.
    pub fn is_minimised(&self) -> bool {
        self.wanted.width == 0 || self.wanted.height == 0
    }

    fn recreate(&mut self, ctx: &GpuContext) -> Result<(), RenderError> {
        ctx.wait_idle();
        // SAFETY: valid physical device and surface.
        let caps = unsafe { self.surface_fn.get_physical_device_surface_capabilities(ctx.physical, self.surface) }?;
        let extent = if caps.current_extent.width != u32::MAX {
            caps.current_extent
        } else {
            vk::Extent2D {
                width: self.wanted.width.clamp(caps.min_image_extent.width, caps.max_image_extent.width),
                height: self.wanted.height.clamp(caps.min_image_extent.height, caps.max_image_extent.height),
            }
        };
        if extent.width == 0 || extent.height == 0 {
            return Ok(()); // minimised: keep the old swapchain until there is area again
        }
        let image_count = (caps.min_image_count + 1).min(if caps.max_image_count == 0 { u32::MAX } else { caps.max_image_count });
        let info = vk::SwapchainCreateInfoKHR::default()
            .surface(self.surface)
            .min_image_count(image_count)
            .image_format(self.format)
            .image_color_space(vk::ColorSpaceKHR::SRGB_NONLINEAR)
            .image_extent(extent)
            .image_array_layers(1)
            .image_usage(vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::TRANSFER_SRC)
            .image_sharing_mode(vk::SharingMode::EXCLUSIVE)
            .pre_transform(caps.current_transform)
            .composite_alpha(vk::CompositeAlphaFlagsKHR::OPAQUE)
            .present_mode(vk::PresentModeKHR::FIFO)
            .clipped(true)
            .old_swapchain(self.swapchain);
        // SAFETY: valid create info; the old swapchain is retired by passing it as old_swapchain
        // and destroyed below after the GPU went idle.
        let swapchain = unsafe { self.swapchain_fn.create_swapchain(&info, None) }?;
        self.destroy_images(ctx);
        ctx.note_destroyed();
        // SAFETY: the GPU is idle; the old swapchain is no longer used.
        unsafe { self.swapchain_fn.destroy_swapchain(self.swapchain, None) };
        self.swapchain = swapchain;
        // SAFETY: the swapchain was just created.
        self.images = unsafe { self.swapchain_fn.get_swapchain_images(swapchain) }?;
        let range = vk::ImageSubresourceRange {
            aspect_mask: vk::ImageAspectFlags::COLOR,
            base_mip_level: 0,
            level_count: 1,
            base_array_layer: 0,
            layer_count: 1,
        };
        for &image in &self.images {
            let view_info = vk::ImageViewCreateInfo::default()
                .image(image)
                .view_type(vk::ImageViewType::TYPE_2D)
                .format(self.format)
                .subresource_range(range);
            // SAFETY: a view of a live swapchain image; destroyed with the swapchain.
            self.views.push(unsafe { ctx.device.create_image_view(&view_info, None) }?);
            self.states.push(ImageState::default());
            // SAFETY: a plain binary semaphore.
            self.render_done.push(unsafe { ctx.device.create_semaphore(&vk::SemaphoreCreateInfo::default(), None) }?);
        }
        self.extent = extent;
        self.stale = false;
        tracing::debug!(width = extent.width, height = extent.height, images = self.images.len(), "swapchain ready");
        Ok(())
    }

    fn destroy_images(&mut self, ctx: &GpuContext) {
        for v in self.views.drain(..) {
            // SAFETY: the GPU is idle (callers wait first).
            unsafe { ctx.destroying().destroy_image_view(v, None) };
        }
        for s in self.render_done.drain(..) {
            // SAFETY: as above.
            unsafe { ctx.device.destroy_semaphore(s, None) };
        }
        self.images.clear();
        self.states.clear();
    }

    /// Acquires the next image for frame slot `slot`: `Ok(None)` when there is nothing to draw
    /// into this frame (minimised, or the swapchain had to be rebuilt).
    pub fn acquire(&mut self, ctx: &GpuContext, slot: usize) -> Result<Option<AcquiredImage>, RenderError> {
        if self.is_minimised() {
            return Ok(None);
        }
        if self.stale || self.images.is_empty() {
            self.recreate(ctx)?;
            if self.images.is_empty() {
                return Ok(None);
            }
        }
        // SAFETY: the semaphore of this frame slot is unsignalled: its previous wait belonged to
        // the slot's previous submission, which has completed.
        let result = unsafe { self.swapchain_fn.acquire_next_image(self.swapchain, u64::MAX, self.acquired[slot], vk::Fence::null()) };
        match result {
            Ok((index, suboptimal)) => {
                if suboptimal {
                    self.stale = true;
                }
                Ok(Some(AcquiredImage { index, wait: self.acquired[slot], signal: self.render_done[index as usize] }))
            }
            Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => {
                self.stale = true;
                Ok(None)
            }
            Err(e) => Err(e.into()),
        }
    }

    /// Presents `image` once `image.signal` is signalled.
    pub fn present(&mut self, ctx: &GpuContext, image: &AcquiredImage) -> Result<(), RenderError> {
        let swapchains = [self.swapchain];
        let indices = [image.index];
        let waits = [image.signal];
        let info = vk::PresentInfoKHR::default().wait_semaphores(&waits).swapchains(&swapchains).image_indices(&indices);
        // SAFETY: the image was acquired and rendered; its semaphore is signalled by the submit.
        match unsafe { self.swapchain_fn.queue_present(ctx.queue, &info) } {
            Ok(false) => Ok(()),
            Ok(true) | Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => {
                self.stale = true;
                Ok(())
            }
            Err(e) => Err(e.into()),
        }
    }

    /// Destroys the swapchain and surface; the GPU must be idle.
    pub fn destroy(mut self, ctx: &GpuContext) {
        ctx.wait_idle();
        self.destroy_images(ctx);
        // SAFETY: the GPU is idle; nothing uses these any more.
        unsafe {
            for s in self.acquired {
                ctx.device.destroy_semaphore(s, None);
            }
            self.swapchain_fn.destroy_swapchain(self.swapchain, None);
            self.surface_fn.destroy_surface(self.surface, None);
        }
    }
}

/// A swapchain image acquired for one frame.
pub struct AcquiredImage {
    /// Index into the swapchain's images.
    pub index: u32,
    /// Signalled when the image may be written.
    pub wait: vk::Semaphore,
    /// To signal when rendering is done (presentation waits on it).
    pub signal: vk::Semaphore,
}
