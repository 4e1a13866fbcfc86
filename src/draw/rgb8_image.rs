//! The 8-bit RGB images heat maps, plots and panels are drawn on, and text
//! on them in the public-domain 8×8 bitmap font, for their scales and titles.

use font8x8::legacy::BASIC_LEGACY;

/// An 8-bit RGB image, row-major, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Rgb8Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width × height × 3` bytes.
    pub pixels: Vec<u8>,
}

/// Height of a line of text in pixels.
pub const LINE_HEIGHT: u32 = 8;
/// Width of one character in pixels.
pub const CHAR_WIDTH: u32 = 8;

impl Rgb8Image {
    /// An image filled with `color`.
    #[must_use]
    pub fn filled(width: u32, height: u32, color: [u8; 3]) -> Self {
        Self { width, height, pixels: color.repeat((width * height) as usize) }
    }

    /// Sets one pixel; coordinates outside the image are ignored.
    pub fn put(&mut self, x: i64, y: i64, color: [u8; 3]) {
        if x >= 0 && y >= 0 && (x as u32) < self.width && (y as u32) < self.height {
            let i = (y as usize * self.width as usize + x as usize) * 3;
            self.pixels[i..i + 3].copy_from_slice(&color);
        }
    }

    /// Fills the `w × h` rectangle with top-left corner (`x`, `y`); clipped.
    pub fn fill_rect(&mut self, x: i64, y: i64, w: i64, h: i64, color: [u8; 3]) {
        for dy in 0..h {
            for dx in 0..w {
                self.put(x + dx, y + dy, color);
            }
        }
    }

    /// A legend entry: an 8×8 swatch of `color` at (`x`, `y`) and `label` beside it.
    pub fn legend_entry(&mut self, x: i64, y: i64, color: [u8; 3], label: &str) {
        self.fill_rect(x, y, 8, 8, color);
        self.text(x + 11, y, label, [0, 0, 0]);
    }

    /// Draws `text` with its top-left corner at (`x`, `y`); the part outside is clipped.
    pub fn text(&mut self, x: i64, y: i64, text: &str, color: [u8; 3]) {
        for (k, ch) in text.chars().enumerate() {
            let glyph = BASIC_LEGACY.get(ch as usize).copied().unwrap_or(BASIC_LEGACY[b'?' as usize]);
            let left = x + (k as i64) * i64::from(CHAR_WIDTH);
            for (row, bits) in glyph.iter().enumerate() {
                for col in 0..8 {
                    // Bit 0 is the leftmost pixel.
                    if bits >> col & 1 == 1 {
                        self.put(left + col, y + row as i64, color);
                    }
                }
            }
        }
    }

    /// Width in pixels of `text` on one line.
    #[must_use]
    pub fn text_width(text: &str) -> u32 {
        text.chars().count() as u32 * CHAR_WIDTH
    }

    /// PNG bytes.
    pub fn png_bytes(&self) -> Result<Vec<u8>, png::EncodingError> {
        crate::frame::srgb_png_bytes(&self.pixels, self.width, self.height)
    }

    /// PNG bytes, with an error naming `path`.
    pub fn png_bytes_for(&self, path: &std::path::Path) -> Result<Vec<u8>, crate::frame::FrameIoError> {
        self.png_bytes().map_err(|e| crate::frame::FrameIoError::Encode(path.display().to_string(), e.to_string()))
    }

    /// Writes a PNG atomically.
    pub fn save_png(&self, path: &std::path::Path) -> Result<(), crate::frame::FrameIoError> {
        use crate::frame::FrameIoError;
        let bytes = self.png_bytes().map_err(|e| FrameIoError::Encode(path.display().to_string(), e.to_string()))?;
        crate::output::write_atomic(path, &bytes).map_err(|e| FrameIoError::Write(path.display().to_string(), e))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_marks_pixels_in_its_box_only() {
        let mut img = Rgb8Image::filled(40, 12, [0, 0, 0]);
        img.text(2, 2, "0.5", [255, 255, 255]);
        let lit: Vec<(u32, u32)> = (0..12)
            .flat_map(|y| (0..40).map(move |x| (x, y)))
            .filter(|&(x, y)| img.pixels[((y * 40 + x) * 3) as usize] == 255)
            .collect();
        assert!(lit.len() > 10);
        assert!(lit.iter().all(|&(x, y)| (2..26).contains(&x) && (2..10).contains(&y)));
    }
}
