//! Panels: several images side by side, each under its title, ready to drop
//! into a paper or an issue.

use super::rgb8_image::{LINE_HEIGHT, Rgb8Image};
use crate::frame::Frame;

/// Space between images and around the panel.
const GAP: u32 = 8;

/// The frame's colour as an 8-bit sRGB image.
#[must_use]
pub fn frame_image(frame: &Frame) -> Rgb8Image {
    Rgb8Image { width: frame.width, height: frame.height, pixels: frame.to_srgb8() }
}

/// Lays `items` (title, image) out in rows of at most `per_row`, each image
/// under its title (wrapped at spaces to the image's width), on white.
#[must_use]
pub fn panel(items: &[(String, Rgb8Image)], per_row: usize) -> Rgb8Image {
    let per_row = per_row.max(1);
    let rows: Vec<&[(String, Rgb8Image)]> = items.chunks(per_row).collect();
    let cell_w = items.iter().map(|(_, i)| i.width).max().unwrap_or(0);
    let lines = |title: &str| wrap(title, cell_w);
    let title_h = |row: &[(String, Rgb8Image)]| {
        row.iter().map(|(t, _)| lines(t).len() as u32).max().unwrap_or(1).max(1) * LINE_HEIGHT
    };
    let row_h = |row: &[(String, Rgb8Image)]| row.iter().map(|(_, i)| i.height).max().unwrap_or(0) + title_h(row) + GAP;
    let width = GAP + per_row.min(items.len()) as u32 * (cell_w + GAP);
    let height = GAP + rows.iter().map(|r| row_h(r)).sum::<u32>();
    let mut out = Rgb8Image::filled(width, height, [255, 255, 255]);
    let mut top = GAP;
    for row in rows {
        for (k, (title, img)) in row.iter().enumerate() {
            let left = GAP + k as u32 * (cell_w + GAP);
            for (n, line) in lines(title).iter().enumerate() {
                out.text(i64::from(left), i64::from(top + n as u32 * LINE_HEIGHT), line, [0, 0, 0]);
            }
            blit(&mut out, img, left, top + title_h(row) + 2);
        }
        top += row_h(row);
    }
    out
}

/// `title` in lines no wider than `width` pixels, broken at spaces where it can be.
fn wrap(title: &str, width: u32) -> Vec<String> {
    let mut lines: Vec<String> = vec![];
    for word in title.split(' ') {
        match lines.last_mut() {
            Some(line) if Rgb8Image::text_width(&format!("{line} {word}")) <= width => {
                line.push(' ');
                line.push_str(word);
            }
            _ => lines.push(word.to_string()),
        }
    }
    lines
}

fn blit(dst: &mut Rgb8Image, src: &Rgb8Image, left: u32, top: u32) {
    for y in 0..src.height {
        for x in 0..src.width {
            let i = ((y * src.width + x) * 3) as usize;
            dst.put(i64::from(left + x), i64::from(top + y), [src.pixels[i], src.pixels[i + 1], src.pixels[i + 2]]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn long_titles_wrap_at_spaces_to_the_image_width() {
        let lines = wrap("depth error: bias +0.115, mean 0.145 cells", 20 * 8);
        assert_eq!(lines, ["depth error: bias", "+0.115, mean 0.145", "cells"]);
        let img = Rgb8Image::filled(20 * 8, 6, [255, 0, 0]);
        let p = panel(&[("depth error: bias +0.115, mean 0.145 cells".into(), img)], 1);
        assert_eq!(p.height, GAP + 6 + 3 * LINE_HEIGHT + GAP, "three lines of title above the image");
    }

    #[test]
    fn panel_holds_every_image_in_rows() {
        let red = Rgb8Image::filled(10, 6, [255, 0, 0]);
        let items: Vec<(String, Rgb8Image)> = (0..5).map(|i| (format!("{i}"), red.clone())).collect();
        let p = panel(&items, 3);
        assert_eq!(p.width, GAP + 3 * (10 + GAP));
        assert_eq!(p.height, GAP + 2 * (6 + LINE_HEIGHT + GAP));
        let reds = p.pixels.chunks(3).filter(|c| c == &[255, 0, 0]).count();
        assert_eq!(reds, 5 * 60);
    }
}
