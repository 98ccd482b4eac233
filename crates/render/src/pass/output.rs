//! The frame's output image (Rgba8Unorm, sRGB-encoded by the composite or the last style) and
//! its readback: a mappable buffer with rows padded to wgpu's 256-byte copy alignment.

use crate::params::RenderError;

pub(crate) const OUTPUT_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
const OUTPUT_BYTES_PER_PIXEL: u32 = 4;

/// Bytes per readback row: `width` pixels rounded up to wgpu's 256-byte copy alignment.
pub(crate) fn padded_row_bytes(width: u32) -> u64 {
    let unpadded = u64::from(width) * u64::from(OUTPUT_BYTES_PER_PIXEL);
    let align = u64::from(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    unpadded.div_ceil(align) * align
}

/// The output image at the frame's size and its mappable copy.
pub(crate) struct OutputImage {
    pub width: u32,
    pub height: u32,
    texture: wgpu::Texture,
    pub view: wgpu::TextureView,
    /// Mappable copy of `texture`, rows padded to `padded_row` bytes.
    readback: wgpu::Buffer,
    padded_row: u32,
}

impl OutputImage {
    /// `storage`: also written as a storage image (by the compute composite). Sizes must have
    /// been checked against the device limits by the caller.
    pub fn new(device: &wgpu::Device, width: u32, height: u32, storage: bool) -> Self {
        let mut usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC;
        if storage {
            usage |= wgpu::TextureUsages::STORAGE_BINDING;
        }
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("glyptic output"),
            size: wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: OUTPUT_FORMAT,
            usage,
            view_formats: &[],
        });
        let view = texture.create_view(&Default::default());
        let padded_row = padded_row_bytes(width);
        let readback = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("glyptic readback"),
            size: padded_row * u64::from(height),
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Self {
            width,
            height,
            texture,
            view,
            readback,
            // Checked by the caller: at most max_buffer_size / height, far below u32::MAX.
            padded_row: u32::try_from(padded_row).unwrap_or(u32::MAX),
        }
    }

    /// Encodes the copy of the image into the readback buffer.
    pub fn copy_out(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture: &self.texture,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &self.readback,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(self.padded_row),
                    rows_per_image: Some(self.height),
                },
            },
            wgpu::Extent3d {
                width: self.width,
                height: self.height,
                depth_or_array_layers: 1,
            },
        );
    }

    /// Waits for the frame and copies the padded rows into an image. After an error the
    /// buffer may be left in a mapping state: the caller makes a new one.
    pub fn read(&self, device: &wgpu::Device) -> Result<image::RgbaImage, RenderError> {
        let (tx, rx) = std::sync::mpsc::channel();
        let slice = self.readback.slice(..);
        slice.map_async(wgpu::MapMode::Read, move |result| {
            // The receiver outlives the poll below; a send error cannot matter.
            let _ = tx.send(result);
        });
        device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| RenderError::Readback(e.to_string()))?;
        match rx.try_recv() {
            Ok(Ok(())) => {}
            Ok(Err(e)) => return Err(RenderError::Readback(e.to_string())),
            Err(e) => {
                return Err(RenderError::Readback(format!(
                    "mapping did not finish: {e}"
                )));
            }
        }
        let (w, h) = (self.width, self.height);
        let row_bytes = w as usize * 4;
        let mut pixels = Vec::with_capacity(row_bytes * h as usize);
        let copied = (|| {
            let view = slice
                .get_mapped_range()
                .map_err(|e| RenderError::Readback(e.to_string()))?;
            for row in view
                .chunks(self.padded_row.max(1) as usize)
                .take(h as usize)
            {
                let pixels_of_row = row
                    .get(..row_bytes)
                    .ok_or_else(|| RenderError::Readback("readback row too short".into()))?;
                pixels.extend_from_slice(pixels_of_row);
            }
            Ok(())
        })();
        // Unmapped on every path: a buffer left mapped would fail the next frame's copy.
        self.readback.unmap();
        copied?;
        image::RgbaImage::from_raw(w, h, pixels)
            .ok_or_else(|| RenderError::Readback("readback smaller than the image".into()))
    }
}
