//! The renderer's size limits: plain numbers, so the error messages that quote them
//! ([`GpuError::OffscreenSize`](crate::error::GpuError::OffscreenSize)) need nothing
//! else of the renderer.

/// Longest side of an offscreen image (pixels).
pub const MAX_OFFSCREEN_SIDE: u32 = 8192;
/// Most pixels of one offscreen image: 4K UHD, 3840 x 2160. A headless run's peak
/// memory grows with its pixels (multisampled colour and depth targets, both eyes and
/// the composite, their readbacks and the encoded PNGs), so this caps it: 8192 x 8192
/// in dual mode peaked at 12.7 GB.
pub const MAX_OFFSCREEN_PIXELS: u64 = 3840 * 2160;
