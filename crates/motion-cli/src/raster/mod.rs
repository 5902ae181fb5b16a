//! A small RGB canvas: anti-aliased thick lines (coverage from the distance to the segment),
//! rectangles, bitmap text; PNG encoding. Enough for skeletons and charts
//! without a graphics dependency.

mod font;

pub(crate) use font::text_width;
use font::{glyph, ADVANCE, GLYPH_HEIGHT};

/// An RGB colour, components 0..=255.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Rgb(pub u8, pub u8, pub u8);

impl Rgb {
    /// White.
    pub const WHITE: Rgb = Rgb(255, 255, 255);
    /// Black.
    pub const BLACK: Rgb = Rgb(0, 0, 0);

    /// `#rrggbb`, for SVG.
    pub fn hex(self) -> String {
        format!("#{:02x}{:02x}{:02x}", self.0, self.1, self.2)
    }
}

/// Where text is anchored horizontally.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Anchor {
    /// `x` is the left edge.
    Start,
    /// `x` is the centre.
    Middle,
    /// `x` is the right edge.
    End,
}

/// An RGB image in memory, `f32` per channel (0..=255) so that blending does not band.
#[derive(Debug, Clone)]
pub struct Canvas {
    width: usize,
    height: usize,
    pixels: Vec<[f32; 3]>,
}

impl Canvas {
    /// A canvas filled with `background`.
    pub fn new(width: usize, height: usize, background: Rgb) -> Canvas {
        let bg = [
            background.0 as f32,
            background.1 as f32,
            background.2 as f32,
        ];
        Canvas {
            width,
            height,
            pixels: vec![bg; width * height],
        }
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// The pixel at `(x, y)` rounded to 8 bits.
    #[cfg(test)]
    pub fn pixel(&self, x: usize, y: usize) -> Rgb {
        let p = self.pixels[y * self.width + x];
        Rgb(p[0].round() as u8, p[1].round() as u8, p[2].round() as u8)
    }

    fn blend(&mut self, x: usize, y: usize, color: Rgb, alpha: f32) {
        let p = &mut self.pixels[y * self.width + x];
        let c = [color.0 as f32, color.1 as f32, color.2 as f32];
        for k in 0..3 {
            p[k] += (c[k] - p[k]) * alpha;
        }
    }

    /// A line of `width` pixels with round caps from `a` to `b` (pixel coordinates, pixel
    /// centres at `+0.5`), anti-aliased.
    pub fn line(&mut self, a: (f64, f64), b: (f64, f64), width: f64, color: Rgb) {
        if !(a.0.is_finite() && a.1.is_finite() && b.0.is_finite() && b.1.is_finite()) {
            return;
        }
        let r = width / 2.0;
        let x0 = (a.0.min(b.0) - r - 1.0).floor().max(0.0) as usize;
        let y0 = (a.1.min(b.1) - r - 1.0).floor().max(0.0) as usize;
        let x1 = ((a.0.max(b.0) + r + 1.0).ceil().max(0.0) as usize).min(self.width);
        let y1 = ((a.1.max(b.1) + r + 1.0).ceil().max(0.0) as usize).min(self.height);
        let (dx, dy) = (b.0 - a.0, b.1 - a.1);
        let len2 = dx * dx + dy * dy;
        for y in y0..y1 {
            for x in x0..x1 {
                let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
                let t = if len2 > 0.0 {
                    (((px - a.0) * dx + (py - a.1) * dy) / len2).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let (qx, qy) = (a.0 + t * dx - px, a.1 + t * dy - py);
                let d = (qx * qx + qy * qy).sqrt();
                let coverage = (r + 0.5 - d).clamp(0.0, 1.0);
                if coverage > 0.0 {
                    self.blend(x, y, color, coverage as f32);
                }
            }
        }
    }

    /// A dashed line: `dash` pixels drawn, `gap` pixels skipped.
    pub fn dashed_line(
        &mut self,
        a: (f64, f64),
        b: (f64, f64),
        width: f64,
        color: Rgb,
        dash: f64,
        gap: f64,
    ) {
        let len = ((b.0 - a.0).powi(2) + (b.1 - a.1).powi(2)).sqrt();
        if len == 0.0 {
            return;
        }
        let mut s = 0.0;
        while s < len {
            let e = (s + dash).min(len);
            let at = |u: f64| (a.0 + (b.0 - a.0) * u / len, a.1 + (b.1 - a.1) * u / len);
            self.line(at(s), at(e), width, color);
            s += dash + gap;
        }
    }

    /// A filled axis-aligned rectangle (pixel units, clipped).
    pub fn fill_rect(&mut self, x: f64, y: f64, w: f64, h: f64, color: Rgb) {
        let x0 = x.round().max(0.0) as usize;
        let y0 = y.round().max(0.0) as usize;
        let x1 = ((x + w).round().max(0.0) as usize).min(self.width);
        let y1 = ((y + h).round().max(0.0) as usize).min(self.height);
        for yy in y0..y1 {
            for xx in x0..x1 {
                self.blend(xx, yy, color, 1.0);
            }
        }
    }

    /// `text` in the bitmap font, `scale` pixels per font pixel, baseline-free: `y` is the top.
    pub fn text(&mut self, x: f64, y: f64, text: &str, scale: usize, anchor: Anchor, color: Rgb) {
        let scale = scale.max(1);
        let w = (text_width(text) * scale) as f64;
        let left = match anchor {
            Anchor::Start => x,
            Anchor::Middle => x - w / 2.0,
            Anchor::End => x - w,
        }
        .round();
        let top = y.round();
        for (i, c) in text.chars().enumerate() {
            let rows = glyph(c);
            for (row, bits) in rows.iter().enumerate().take(GLYPH_HEIGHT) {
                for col in 0..5 {
                    if bits & (0x10 >> col) != 0 {
                        let px = left + ((i * ADVANCE + col) * scale) as f64;
                        let py = top + (row * scale) as f64;
                        self.fill_rect(px, py, scale as f64, scale as f64, color);
                    }
                }
            }
        }
    }

    /// Copies `other` with its top-left corner at `(x, y)` (clipped).
    pub fn paste(&mut self, other: &Canvas, x: usize, y: usize) {
        for yy in 0..other.height.min(self.height.saturating_sub(y)) {
            for xx in 0..other.width.min(self.width.saturating_sub(x)) {
                self.pixels[(y + yy) * self.width + x + xx] = other.pixels[yy * other.width + xx];
            }
        }
    }

    /// The pixels as 8-bit RGB, row-major.
    pub fn to_rgb8(&self) -> Vec<u8> {
        self.pixels
            .iter()
            .flat_map(|p| p.map(|v| v.round().clamp(0.0, 255.0) as u8))
            .collect()
    }

    /// The image as PNG bytes.
    pub fn encode_png(&self) -> Result<Vec<u8>, png::EncodingError> {
        let mut bytes = Vec::new();
        {
            let mut encoder = png::Encoder::new(&mut bytes, self.width as u32, self.height as u32);
            encoder.set_color(png::ColorType::Rgb);
            encoder.set_depth(png::BitDepth::Eight);
            let mut writer = encoder.write_header()?;
            writer.write_image_data(&self.to_rgb8())?;
            writer.finish()?;
        }
        Ok(bytes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_cover_their_pixels_and_nothing_far_away() {
        let mut c = Canvas::new(20, 10, Rgb::WHITE);
        c.line((2.0, 5.0), (18.0, 5.0), 2.0, Rgb::BLACK);
        assert_eq!(c.pixel(10, 4), Rgb::BLACK);
        assert_eq!(c.pixel(10, 8), Rgb::WHITE);
        assert_eq!(c.pixel(0, 0), Rgb::WHITE);
        // Off-canvas and non-finite lines are clipped, never panic.
        c.line((-50.0, -5.0), (100.0, 30.0), 3.0, Rgb::BLACK);
        c.line((f64::NAN, 0.0), (1.0, 1.0), 3.0, Rgb::BLACK);
        c.text(-10.0, -3.0, "Hi 0.5s", 2, Anchor::Start, Rgb::BLACK);
    }

    #[test]
    fn png_has_the_signature_and_size() {
        let c = Canvas::new(7, 3, Rgb(10, 20, 30));
        let bytes = c.encode_png().unwrap();
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
        let decoder = png::Decoder::new(std::io::Cursor::new(bytes));
        let reader = decoder.read_info().unwrap();
        assert_eq!((reader.info().width, reader.info().height), (7, 3));
    }
}
