//! The window's surface: a device that can present to it, and an 8-bit image copied onto it
//! byte for byte, from the host or on the device (no filtering, no conversion to floats:
//! the window shows exactly the bytes a file would hold).

use raycaster::gpu::{GpuOptions, GpuRenderer, Presenter};
use std::sync::Arc;
use winit::window::Window;

/// A surface configured for copies, and a renderer on a device that presents to it.
pub struct Screen {
    surface: wgpu::Surface<'static>,
    gpu: GpuRenderer,
    /// Draws a render's tiles onto the surface on the device.
    presenter: Presenter,
    config: wgpu::SurfaceConfiguration,
    /// Where a pixel's red, green and blue bytes go among its four.
    order: [usize; 3],
}

impl Screen {
    /// Opens an adapter that can present to `window` (the first wgpu offers, as
    /// [`GpuRenderer::new`] does), its device, and a renderer on it.
    pub fn open(window: Arc<Window>) -> Result<Screen, String> {
        let instance = GpuRenderer::instance();
        let size = window.inner_size();
        let surface = instance.create_surface(window).map_err(|e| format!("no surface for the window: {e}"))?;
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            compatible_surface: Some(&surface),
            ..Default::default()
        }))
        .map_err(|e| format!("no GPU presents to this display: {e}"))?;
        let caps = surface.get_capabilities(&adapter);
        if !caps.usages.contains(wgpu::TextureUsages::COPY_DST) {
            return Err(format!("{}'s surfaces take no copies", adapter.get_info().name));
        }
        // 8-bit formats that store the bytes as given (sRGB formats would re-encode them).
        let (format, order) = caps
            .formats
            .iter()
            .find_map(|&f| match f {
                wgpu::TextureFormat::Bgra8Unorm => Some((f, [2, 1, 0])),
                wgpu::TextureFormat::Rgba8Unorm => Some((f, [0, 1, 2])),
                _ => None,
            })
            .ok_or_else(|| format!("no 8-bit linear surface format among {:?}", caps.formats))?;
        // One scene at many sizes: a moving camera's small frames would otherwise run a
        // shared kernel, and the first drag would wait for a second compile.
        let gpu = pollster::block_on(GpuRenderer::on_adapter(
            &adapter,
            GpuOptions { share_small_kernels: false, ..GpuOptions::default() },
        ))
        .map_err(|e| e.to_string())?;
        let config = wgpu::SurfaceConfiguration {
            usage: wgpu::TextureUsages::COPY_DST,
            format,
            width: size.width.max(1),
            height: size.height.max(1),
            present_mode: wgpu::PresentMode::Fifo,
            desired_maximum_frame_latency: 2,
            alpha_mode: caps.alpha_modes[0],
            view_formats: vec![],
            color_space: wgpu::SurfaceColorSpace::Auto,
        };
        surface.configure(gpu.device(), &config);
        let presenter = Presenter::new(&gpu);
        Ok(Screen { surface, gpu, presenter, config, order })
    }

    /// The renderer on the presenting device.
    pub fn gpu(&self) -> &GpuRenderer {
        &self.gpu
    }

    /// The pass that draws a render onto the surface on the device.
    pub fn presenter(&self) -> &Presenter {
        &self.presenter
    }

    /// The surface's size in pixels.
    pub fn size(&self) -> (u32, u32) {
        (self.config.width, self.config.height)
    }

    /// Follows the window to its new size.
    pub fn resize(&mut self, width: u32, height: u32) {
        self.config.width = width.max(1);
        self.config.height = height.max(1);
        self.surface.configure(self.gpu.device(), &self.config);
    }

    /// The surface's next texture to draw on, or `None` while the window is being resized
    /// or is hidden (the frame is skipped).
    pub fn next_texture(&mut self) -> Option<wgpu::SurfaceTexture> {
        match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(frame) | wgpu::CurrentSurfaceTexture::Suboptimal(frame) => Some(frame),
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                self.surface.configure(self.gpu.device(), &self.config);
                None
            }
            _ => None,
        }
    }

    /// Copies `rgb`, an image of the surface's size, row by row from the top, onto `frame`.
    pub fn write(&self, frame: &wgpu::SurfaceTexture, rgb: &[u8]) {
        let (width, height) = self.size();
        assert_eq!(rgb.len(), 3 * width as usize * height as usize, "an image of the surface's size");
        let mut texels = vec![255u8; 4 * width as usize * height as usize];
        for (texel, pixel) in texels.chunks_exact_mut(4).zip(rgb.chunks_exact(3)) {
            for (channel, &at) in self.order.iter().enumerate() {
                texel[at] = pixel[channel];
            }
        }
        self.gpu.queue().write_texture(
            frame.texture.as_image_copy(),
            &texels,
            wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(4 * width), rows_per_image: Some(height) },
            wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
        );
    }

    /// Shows `frame`, drawn by [`Screen::write`] or on the device.
    pub fn present(&self, frame: wgpu::SurfaceTexture) {
        // A copy is queued by write: submit it, or the frame is presented cleared.
        self.gpu.queue().submit([]);
        self.gpu.queue().present(frame);
    }
}
