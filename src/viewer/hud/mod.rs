//! What the previewer draws over its view: a status band across the top
//! (view, the node being moved, the last event's cost), a colour bar with
//! scale, metric and unit along the bottom of a heat-map view, and, on H or
//! F1, a card listing every key, in pages where the window is too small for
//! one. Each is laid out first as a [`Panel`] of boxes (text lines, colour
//! swatches, the bar), so that what is drawn can be checked to fit the
//! window and overlap nothing, then drawn into the frame itself, so it
//! shows without a window manager's title bar and in screenshots.

mod colour_bar;
mod help;
mod status;

pub use colour_bar::colour_bar;
pub use help::{HelpCard, help};
pub use status::{BAND_HEIGHT, StatusPart, status};

use crate::draw::{LINE_HEIGHT, Rgb8Image, Scale};

/// Space around text, in pixels.
const PAD: u32 = 4;
/// From one line of text to the next.
const LINE_STEP: u32 = LINE_HEIGHT + 2;
/// How much of the view shows through a panel's background.
const SHOW_THROUGH: f32 = 0.3;
const TEXT: [u8; 3] = [240, 240, 240];
const HEADING: [u8; 3] = [255, 210, 120];

/// A rectangle of pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rect {
    pub x: u32,
    pub y: u32,
    pub w: u32,
    pub h: u32,
}

#[cfg(test)]
impl Rect {
    /// Whether the two share a pixel.
    #[must_use]
    pub fn overlaps(&self, other: &Rect) -> bool {
        self.x < other.x + other.w
            && other.x < self.x + self.w
            && self.y < other.y + other.h
            && other.y < self.y + self.h
    }

    /// Whether `other` lies wholly inside.
    #[must_use]
    pub fn contains(&self, other: &Rect) -> bool {
        other.x >= self.x
            && other.y >= self.y
            && other.x + other.w <= self.x + self.w
            && other.y + other.h <= self.y + self.h
    }
}

/// What a box of a panel shows.
#[derive(Clone, Debug, PartialEq)]
pub enum Mark {
    /// A line of text in a colour.
    Text(String, [u8; 3]),
    /// A swatch of one colour.
    Fill([u8; 3]),
    /// The colours of a scale from its lower to its upper end, left to right.
    Scale(Scale, f32, f32),
}

/// A box of a panel and what it shows.
#[derive(Clone, Debug, PartialEq)]
pub struct Item {
    pub rect: Rect,
    pub mark: Mark,
}

impl Item {
    /// A line of text with its top left corner at `x, y`.
    fn text(x: u32, y: u32, text: impl Into<String>, color: [u8; 3]) -> Self {
        let text = text.into();
        Item { rect: Rect { x, y, w: Rgb8Image::text_width(&text), h: LINE_HEIGHT }, mark: Mark::Text(text, color) }
    }
}

/// A shaded rectangle over the view and the boxes drawn on it.
#[derive(Clone, Debug, PartialEq)]
pub struct Panel {
    pub rect: Rect,
    pub items: Vec<Item>,
}

/// Draws `panel` into `image`: its background shaded, then its boxes.
pub fn draw(image: &mut Rgb8Image, panel: &Panel) {
    shade(image, &panel.rect);
    for item in &panel.items {
        let Rect { x, y, w, h } = item.rect;
        match &item.mark {
            Mark::Text(text, color) => image.text(i64::from(x), i64::from(y), text, *color),
            Mark::Fill(color) => image.fill_rect(i64::from(x), i64::from(y), i64::from(w), i64::from(h), *color),
            Mark::Scale(scale, lo, hi) => {
                for i in 0..w {
                    let v = lo + (hi - lo) * i as f32 / (w - 1).max(1) as f32;
                    image.fill_rect(i64::from(x + i), i64::from(y), 1, i64::from(h), scale.color(v));
                }
            }
        }
    }
}

/// Darkens `rect` (clipped to the image) so text reads over any view.
fn shade(image: &mut Rgb8Image, rect: &Rect) {
    for row in rect.y..(rect.y + rect.h).min(image.height) {
        for col in rect.x..(rect.x + rect.w).min(image.width) {
            let at = 3 * (row * image.width + col) as usize;
            for c in &mut image.pixels[at..at + 3] {
                *c = (f32::from(*c) * SHOW_THROUGH) as u8;
            }
        }
    }
}

/// The panel around `items`, from `x, y`, `PAD` beyond their right and bottom edges.
fn panel_around(x: u32, y: u32, items: Vec<Item>) -> Panel {
    let right = items.iter().map(|i| i.rect.x + i.rect.w).max().unwrap_or(x) + PAD;
    let bottom = items.iter().map(|i| i.rect.y + i.rect.h).max().unwrap_or(y) + PAD;
    Panel { rect: Rect { x, y, w: right - x, h: bottom - y }, items }
}

/// `text` in lines of at most `chars` characters, broken at spaces; a word
/// longer than a line is cut into pieces that fit.
fn wrapped(text: &str, chars: usize) -> Vec<String> {
    let chars = chars.max(1);
    let mut lines: Vec<String> = vec![];
    for word in text.split(' ') {
        let mut word: Vec<char> = word.chars().collect();
        match lines.last_mut() {
            Some(line) if line.chars().count() + 1 + word.len() <= chars => {
                line.push(' ');
                line.extend(word);
                continue;
            }
            _ => {}
        }
        while word.len() > chars {
            lines.push(word.drain(..chars).collect());
        }
        lines.push(word.into_iter().collect());
    }
    lines
}

/// Characters of text that fit across `width` pixels inside a panel's padding.
fn chars_across(width: u32) -> usize {
    (width.saturating_sub(2 * PAD) / crate::draw::CHAR_WIDTH) as usize
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// Checks that every panel lies inside a `w × h` window, every box
    /// inside its panel, and that no two panels and no two boxes overlap.
    pub fn assert_fits(panels: &[Panel], w: u32, h: u32, what: &str) {
        let window = Rect { x: 0, y: 0, w, h };
        for (k, p) in panels.iter().enumerate() {
            assert!(window.contains(&p.rect), "{what}: panel {k} {:?} leaves the {w}x{h} window", p.rect);
            for item in &p.items {
                assert!(p.rect.contains(&item.rect), "{what}: {item:?} leaves its panel {:?}", p.rect);
            }
            for (i, a) in p.items.iter().enumerate() {
                for b in &p.items[i + 1..] {
                    assert!(!a.rect.overlaps(&b.rect), "{what}: {a:?} overlaps {b:?}");
                }
            }
            for q in &panels[k + 1..] {
                assert!(!p.rect.overlaps(&q.rect), "{what}: panels {:?} and {:?} overlap", p.rect, q.rect);
            }
        }
    }

    #[test]
    fn text_wraps_at_spaces_and_long_words_are_cut() {
        assert_eq!(wrapped("one two three", 7), ["one two", "three"]);
        assert_eq!(wrapped("abcdefghij", 4), ["abcd", "efgh", "ij"]);
        assert!(wrapped("a frame 6: first pass 24 ms, refined 290 ms", 12).iter().all(|l| l.chars().count() <= 12));
    }

    #[test]
    fn a_panel_shades_its_rectangle_and_draws_its_boxes() {
        let mut image = Rgb8Image::filled(60, 40, [128, 128, 128]);
        let panel = panel_around(0, 0, vec![Item::text(PAD, PAD, "ab", TEXT)]);
        draw(&mut image, &panel);
        let at = |x: u32, y: u32| &image.pixels[3 * (y * 60 + x) as usize..][..3];
        assert_eq!(panel.rect, Rect { x: 0, y: 0, w: 16 + 2 * PAD, h: LINE_HEIGHT + 2 * PAD });
        assert!(at(59, 39) == [128, 128, 128], "outside the panel, the view");
        assert!(at(1, 1) == [38, 38, 38], "shaded inside");
        assert!((0..16).any(|y| (0..24).any(|x| at(x, y) == TEXT)), "the text");
    }
}
