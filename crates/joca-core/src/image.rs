//! Images: linear HDR RGB in calibrated digital numbers, and 8-bit RGB frames, one generic type
//! ([`RgbImage`]) with a name for each.
//!
//! Both store pixels row-major with interleaved channels (`[r, g, b, r, g, b, …]`), the layout
//! of PNG files and of libtorch's HWC tensors, so no conversion is needed at either boundary.

use thiserror::Error;

/// Errors when constructing images from raw buffers.
#[derive(Debug, Error, PartialEq, Eq)]
pub enum ImageError {
    /// The buffer length is not `width · height · 3`.
    #[error("image buffer holds {got} values but a {width}x{height} RGB image needs {expected}")]
    BufferSize {
        /// Image width in pixels.
        width: usize,
        /// Image height in pixels.
        height: usize,
        /// `width · height · 3`.
        expected: usize,
        /// The length that was given.
        got: usize,
    },
}

/// An RGB image: `width × height` pixels, row-major, channels interleaved. One type for the
/// two pixel kinds joca uses (see [`HdrImage`] and [`Rgb8Image`]); the optical flow's grey
/// images (`joca_data::flow::Gray`) are single-channel and padded for its search, so they are
/// their own type.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RgbImage<T> {
    width: usize,
    height: usize,
    data: Vec<T>,
}

/// Linear RGB radiometry in calibrated digital numbers (DN): the `I0` of the paper's Eq. 2.
///
/// A value is what the calibration camera (pixel pitch p0, exposure E0, gain G0 of docs/design.md)
/// would record at that pixel before clipping, so daylight white paper reads about 200–230 and
/// values above 255 (a lamp, the sun) are legal: clipping happens in image formation.
pub type HdrImage = RgbImage<f32>;

/// An 8-bit RGB frame, as the camera delivers it after image formation.
pub type Rgb8Image = RgbImage<u8>;

impl<T: Copy + Default + Into<f64>> RgbImage<T> {
    /// A black image.
    pub fn zeros(width: usize, height: usize) -> Self {
        Self { width, height, data: vec![T::default(); width * height * 3] }
    }

    /// Wraps an interleaved RGB buffer of `width · height · 3` values.
    pub fn from_vec(width: usize, height: usize, data: Vec<T>) -> Result<Self, ImageError> {
        check_len(width, height, data.len())?;
        Ok(Self { width, height, data })
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Interleaved RGB values.
    pub fn data(&self) -> &[T] {
        &self.data
    }

    /// Mutable interleaved RGB values.
    pub fn data_mut(&mut self) -> &mut [T] {
        &mut self.data
    }

    /// Consumes the image and returns its values.
    pub fn into_vec(self) -> Vec<T> {
        self.data
    }

    /// The RGB value at column `x`, row `y`.
    pub fn pixel(&self, x: usize, y: usize) -> [T; 3] {
        let i = (y * self.width + x) * 3;
        [self.data[i], self.data[i + 1], self.data[i + 2]]
    }

    /// Sets the RGB value at column `x`, row `y`.
    pub fn set_pixel(&mut self, x: usize, y: usize, rgb: [T; 3]) {
        let i = (y * self.width + x) * 3;
        self.data[i..i + 3].copy_from_slice(&rgb);
    }

    /// Mean over all pixels and channels (in DN for both kinds).
    pub fn mean(&self) -> f64 {
        mean_of(self.data.iter().map(|&v| v.into()), self.data.len())
    }
}

fn check_len(width: usize, height: usize, got: usize) -> Result<(), ImageError> {
    let expected = width * height * 3;
    if got == expected {
        Ok(())
    } else {
        Err(ImageError::BufferSize { width, height, expected, got })
    }
}

fn mean_of(values: impl Iterator<Item = f64>, len: usize) -> f64 {
    if len == 0 {
        return 0.0;
    }
    values.sum::<f64>() / len as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn buffer_size_is_checked() {
        assert!(HdrImage::from_vec(2, 2, vec![0.0; 12]).is_ok());
        assert_eq!(
            Rgb8Image::from_vec(2, 2, vec![0; 11]),
            Err(ImageError::BufferSize { width: 2, height: 2, expected: 12, got: 11 })
        );
    }

    #[test]
    fn pixels_are_row_major_interleaved() {
        let mut img = HdrImage::zeros(3, 2);
        img.set_pixel(2, 1, [1.0, 2.0, 3.0]);
        assert_eq!(&img.data()[15..18], &[1.0, 2.0, 3.0]);
        assert_eq!(img.pixel(2, 1), [1.0, 2.0, 3.0]);
        assert!((img.mean() - 6.0 / 18.0).abs() < 1e-12);
        assert_eq!(Rgb8Image::zeros(0, 0).mean(), 0.0);
    }
}
