//! What the previewer draws over its view: a status line (view, evaluation,
//! the node being moved, the last frame's cost), a colour bar with scale and
//! unit over a heat-map view, and, on H or F1, a card listing every key.
//! Drawn into the frame itself, so it shows without a window manager's title
//! bar and in screenshots.

use crate::compare::{CHAR_WIDTH, ColourKey, LINE_HEIGHT, OVER_RANGE, Rgb8Image, Scale};

/// Space around text, in pixels.
const PAD: u32 = 4;
/// How much of the view shows through a panel's background.
const SHOW_THROUGH: f32 = 0.3;
const TEXT: [u8; 3] = [240, 240, 240];
const HEADING: [u8; 3] = [255, 210, 120];

/// Darkens the rectangle `x, y, w, h` (clipped to the image) so text reads over any view.
fn shade(image: &mut Rgb8Image, x: u32, y: u32, w: u32, h: u32) {
    for row in y..(y + h).min(image.height) {
        for col in x..(x + w).min(image.width) {
            let at = 3 * (row * image.width + col) as usize;
            for c in &mut image.pixels[at..at + 3] {
                *c = (f32::from(*c) * SHOW_THROUGH) as u8;
            }
        }
    }
}

/// Lines of text on a shaded panel whose top left corner is `x, y`.
fn panel(image: &mut Rgb8Image, x: u32, y: u32, lines: &[(String, [u8; 3])]) {
    let width = lines.iter().map(|(l, _)| Rgb8Image::text_width(l)).max().unwrap_or(0) + 2 * PAD;
    let height = lines.len() as u32 * (LINE_HEIGHT + 2) + 2 * PAD;
    shade(image, x, y, width, height);
    for (k, (line, color)) in lines.iter().enumerate() {
        let top = y + PAD + k as u32 * (LINE_HEIGHT + 2);
        image.text(i64::from(x + PAD), i64::from(top), line, *color);
    }
}

/// The status line across the top of the view: `parts` joined by bars,
/// wrapped onto more lines where the view is too narrow for one, a part
/// too long for a line of its own wrapped at its spaces.
pub fn status(image: &mut Rgb8Image, parts: &[String]) {
    let fits = |line: &str| Rgb8Image::text_width(line) + 2 * PAD <= image.width;
    let mut lines: Vec<String> = vec![];
    for part in parts {
        let mut pieces = words_wrapped(part, &fits).into_iter();
        let first = pieces.next().unwrap_or_default();
        match lines.last_mut() {
            Some(line) if fits(&format!("{line} | {first}")) => *line = format!("{line} | {first}"),
            _ => lines.push(first),
        }
        lines.extend(pieces);
    }
    panel(image, 0, 0, &lines.into_iter().map(|l| (l, TEXT)).collect::<Vec<_>>());
}

/// `text` in lines that each `fits`, broken at spaces (a word too long for
/// a line keeps one of its own).
fn words_wrapped(text: &str, fits: &impl Fn(&str) -> bool) -> Vec<String> {
    let mut lines: Vec<String> = vec![];
    for word in text.split(' ') {
        match lines.last_mut() {
            Some(line) if fits(&format!("{line} {word}")) => *line = format!("{line} {word}"),
            _ => lines.push(word.to_string()),
        }
    }
    lines
}

/// The help card: every key and what it does, centred on the view; a
/// description too long for the view goes on under itself.
pub fn help(image: &mut Rgb8Image, keys: &[(String, &str)]) {
    let mut lines = vec![("Keys (H or F1 hides this card)".to_string(), HEADING)];
    let key_width = keys.iter().map(|(k, _)| k.chars().count()).max().unwrap_or(0);
    let indent = " ".repeat(key_width + 2);
    let fits = |line: &str| Rgb8Image::text_width(&format!("{indent}{line}")) + 2 * PAD <= image.width;
    for (k, what) in keys {
        for (i, part) in words_wrapped(what, &fits).into_iter().enumerate() {
            let line = if i == 0 { format!("{k:<key_width$}  {part}") } else { format!("{indent}{part}") };
            lines.push((line, TEXT));
        }
    }
    let width = lines.iter().map(|(l, _)| Rgb8Image::text_width(l)).max().unwrap_or(0) + 2 * PAD;
    let height = lines.len() as u32 * (LINE_HEIGHT + 2) + 2 * PAD;
    panel(image, image.width.saturating_sub(width) / 2, image.height.saturating_sub(height) / 2, &lines);
}

/// A colour bar along the bottom left of a heat-map view: the key's title,
/// the colours of its scale with its ends and middle in its unit, and a
/// line for each special colour the view shows (values beyond the scale
/// always have one).
pub fn colour_bar(image: &mut Rgb8Image, key: &ColourKey) {
    let bar_width = (image.width / 3).max(120).min(image.width.saturating_sub(2 * PAD));
    let (lo, hi, signed) = match key.scale {
        Scale::Signed { max } => (-max, max, true),
        Scale::Magnitude { max } => (0.0, max, false),
    };
    let label = |v: f32| match (signed, hi >= 10.0) {
        (true, _) => format!("{v:+.3}"),
        (false, true) => format!("{v:.0}"),
        (false, false) => format!("{v:.3}"),
    };
    let labels = [label(lo), label(0.5 * (lo + hi)), format!("{} {}", label(hi), key.unit)];
    let mut specials = key.specials.clone();
    if !specials.iter().any(|&(colour, _)| colour == OVER_RANGE) {
        specials.push((OVER_RANGE, "beyond the scale".into()));
    }
    let widest = specials.iter().map(|(_, text)| Rgb8Image::text_width(text) + 12).max().unwrap_or(0);
    let label_width = Rgb8Image::text_width(&labels[2]);
    let width = bar_width.max(Rgb8Image::text_width(key.title)).max(widest) + label_width + 2 * PAD;
    // The title, the bar and its labels, then a line per special colour.
    let n = specials.len() as u32;
    let height = (3 + n) * LINE_HEIGHT + (4 + n) * PAD + 8;
    let top = image.height.saturating_sub(height);
    shade(image, 0, top, width, height);
    image.text(i64::from(PAD), i64::from(top + PAD), key.title, TEXT);
    let bar_top = top + 2 * PAD + LINE_HEIGHT;
    for i in 0..bar_width {
        let v = lo + (hi - lo) * i as f32 / (bar_width - 1).max(1) as f32;
        image.fill_rect(i64::from(PAD + i), i64::from(bar_top), 1, 8, key.scale.color(v));
    }
    let label_top = i64::from(bar_top + 8 + PAD);
    image.text(i64::from(PAD), label_top, &labels[0], TEXT);
    let middle = i64::from(PAD + bar_width / 2) - i64::from(Rgb8Image::text_width(&labels[1]) / 2);
    image.text(middle, label_top, &labels[1], TEXT);
    image.text(i64::from(PAD + bar_width) - i64::from(CHAR_WIDTH) * 6, label_top, &labels[2], TEXT);
    for (row, (colour, text)) in specials.iter().enumerate() {
        let line_top = label_top + (row as i64 + 1) * i64::from(LINE_HEIGHT + PAD);
        image.fill_rect(i64::from(PAD), line_top + 2, 8, 8, *colour);
        image.text(i64::from(PAD + 12), line_top, text, TEXT);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compare::NO_VALUE;

    fn grey(w: u32, h: u32) -> Rgb8Image {
        Rgb8Image::filled(w, h, [128, 128, 128])
    }

    #[test]
    fn the_status_line_shades_the_top_and_writes_on_it() {
        let mut image = grey(200, 100);
        status(&mut image, &["field".to_string()]);
        let at = |x: u32, y: u32| &image.pixels[3 * (y * 200 + x) as usize..][..3];
        assert!(at(199, 99) == [128, 128, 128], "below the line, the view");
        assert!((0..16).any(|y| (0..48).any(|x| at(x, y) == TEXT)), "the text");
        assert!(at(44, 1) == [38, 38, 38], "shaded around the text");
        assert!(at(60, 1) == [128, 128, 128], "no wider than the text");
    }

    #[test]
    fn a_long_status_wraps_onto_more_lines() {
        let parts: Vec<String> = (0..6).map(|k| format!("part {k} of it")).collect();
        let (mut narrow, mut wide) = (grey(160, 100), grey(1000, 100));
        status(&mut narrow, &parts);
        status(&mut wide, &parts);
        let shaded_rows = |image: &Rgb8Image| {
            (0..image.height).filter(|&y| image.pixels[3 * (y * image.width) as usize] != 128).count()
        };
        assert!(shaded_rows(&narrow) > shaded_rows(&wide), "more lines where narrow");
        // One part longer than the view breaks at its spaces, and no line runs past the edge.
        let fits = |line: &str| Rgb8Image::text_width(line) + 2 * PAD <= 160;
        let long = "frame 6: first pass 24 ms, refined 290 ms (0.3 M rays/s, 6.0 evaluations per ray)";
        let lines = words_wrapped(long, &fits);
        assert!(lines.len() > 1 && lines.iter().all(|l| fits(l)), "{lines:?}");
        assert_eq!(lines.join(" "), long);
    }

    #[test]
    fn the_help_card_lists_every_key_it_is_given_and_fits() {
        let mut image = grey(400, 300);
        let keys = vec![("a, d".to_string(), "orbit"), ("h, f1".to_string(), "help")];
        help(&mut image, &keys);
        let shaded_rows = (0..300).filter(|&y| image.pixels[3 * (y * 400 + 200) as usize] != 128).count() as u32;
        assert_eq!(shaded_rows, 3 * (LINE_HEIGHT + 2) + 2 * PAD, "a heading and a line per entry");
        let centre_left = |y: u32| image.pixels[3 * (y * 400) as usize];
        assert!((0..300).all(|y| centre_left(y) == 128), "centred, with the view showing beside it");
    }

    #[test]
    fn a_description_too_long_for_the_view_goes_on_under_itself() {
        let (w, h) = (320, 200);
        let mut image = grey(w, h);
        let what = "a description far longer than this narrow view is wide";
        help(&mut image, &[("a, d".to_string(), what)]);
        let shaded_rows = (0..h).filter(|&y| image.pixels[3 * (y * w + w / 2) as usize] != 128).count() as u32;
        assert!(shaded_rows >= 3 * (LINE_HEIGHT + 2) + 2 * PAD, "the heading and two lines at least");
        let row = h / 2;
        let shaded: Vec<u32> = (0..w).filter(|&x| image.pixels[3 * (row * w + x) as usize] != 128).collect();
        let (left, right) = (shaded[0], shaded[shaded.len() - 1]);
        assert!(right - left + 1 < w, "narrower than the view: nothing cut off");
    }

    #[test]
    fn a_colour_bar_on_a_narrow_view_stays_inside_it() {
        let mut image = grey(40, 30);
        colour_bar(&mut image, &key(Scale::Signed { max: 1.0 }, vec![]));
        assert_eq!(image.pixels.len(), 40 * 30 * 3);
    }

    #[test]
    fn the_colour_bar_draws_the_scale_ends() {
        let mut image = grey(300, 200);
        let scale = Scale::Signed { max: 0.5 };
        colour_bar(&mut image, &key(scale, vec![]));
        let has = |c: [u8; 3]| image.pixels.chunks_exact(3).any(|p| p == c);
        assert!(has(scale.color(-0.5)) && has(scale.color(0.5)), "both ends of the bar");
        assert!(has(OVER_RANGE), "the colour beyond the scale, labelled");
    }

    #[test]
    fn the_colour_bar_labels_the_special_colours_its_view_shows() {
        let scale = Scale::Magnitude { max: 10.0 };
        let labels = crate::compare::SpecialLabels { no_value: "a gradient vanishes", infinite: "infinite" };
        let shown = ColourKey::of(&[1.0, f32::NAN, 20.0], scale, ("angle", "deg"), &labels);
        assert_eq!(shown.specials.len(), 2, "no value and beyond the scale: {:?}", shown.specials);
        let (mut with, mut without) = (grey(300, 200), grey(300, 200));
        colour_bar(&mut with, &shown);
        colour_bar(&mut without, &ColourKey::of(&[1.0], scale, ("angle", "deg"), &labels));
        let has = |image: &Rgb8Image, c: [u8; 3]| image.pixels.chunks_exact(3).any(|p| p == c);
        assert!(has(&with, NO_VALUE) && has(&with, OVER_RANGE), "both specials drawn");
        assert!(!has(&without, NO_VALUE) && has(&without, OVER_RANGE), "only what the view shows, and the scale's end");
        let shaded = |image: &Rgb8Image| image.pixels.chunks_exact(3).filter(|p| *p != [128, 128, 128]).count();
        assert!(shaded(&with) > shaded(&without), "a line more for the value that vanishes");
    }

    /// A key of `scale` for the depth difference, with `specials`.
    fn key(scale: Scale, specials: Vec<([u8; 3], String)>) -> ColourKey {
        ColourKey { scale, title: "depth", unit: "cells", specials }
    }
}
