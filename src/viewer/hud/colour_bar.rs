//! The colour bar of a heat-map view, along the bottom left: the key's
//! metric and unit (wrapped to the window), the colours of its scale with
//! as many ticks as fit apart (five, three or its two ends), and a line for
//! each special colour the view shows (values beyond the scale always have
//! one). Where the window is too short, the special colours' lines go first.

use super::{Item, LINE_STEP, Mark, PAD, Panel, Rect, TEXT, chars_across, panel_around, wrapped};
use crate::draw::{CHAR_WIDTH, ColourKey, LINE_HEIGHT, OVER_RANGE, Rgb8Image, Scale};

/// The bar's height.
const BAR_HEIGHT: u32 = 8;
/// A swatch and the gap after it, before its label.
const SWATCH: u32 = 8;

/// The colour bar of `key` in a `width × height` view, below `top` (the
/// status band's bottom); none where not even the bar fits.
#[must_use]
pub fn colour_bar(width: u32, height: u32, top: u32, key: &ColourKey) -> Option<Panel> {
    let bar_width = (width / 3).max(120).min(width.saturating_sub(2 * PAD));
    let (lo, hi) = match key.scale {
        Scale::Signed { max } => (-max, max),
        Scale::Magnitude { max } => (0.0, max),
    };
    let title = if key.unit.is_empty() { key.title.to_string() } else { format!("{} ({})", key.title, key.unit) };
    let title = wrapped(&title, chars_across(width));
    let mut specials = key.specials.clone();
    if !specials.iter().any(|&(colour, _)| colour == OVER_RANGE) {
        specials.push((OVER_RANGE, "beyond the scale".into()));
    }
    let special_chars = chars_across(width).saturating_sub(((SWATCH + 4) / CHAR_WIDTH + 1) as usize);
    let mut special_lines: Vec<(Option<[u8; 3]>, String)> = vec![];
    for (colour, text) in &specials {
        for (k, line) in wrapped(text, special_chars).into_iter().enumerate() {
            special_lines.push(((k == 0).then_some(*colour), line));
        }
    }
    // The title, the bar, its ticks, then the special colours' lines, as many as fit.
    let fixed = title.len() as u32 * LINE_STEP + BAR_HEIGHT + PAD + LINE_HEIGHT + 2 * PAD;
    let room = height.saturating_sub(top);
    if fixed > room || bar_width < 2 * CHAR_WIDTH {
        return None;
    }
    special_lines.truncate(((room - fixed) / LINE_STEP) as usize);
    let y0 = height - fixed - special_lines.len() as u32 * LINE_STEP;
    let mut items: Vec<Item> = vec![];
    let mut y = y0 + PAD;
    for line in title {
        items.push(Item::text(PAD, y, line, TEXT));
        y += LINE_STEP;
    }
    let bar = Rect { x: PAD, y, w: bar_width, h: BAR_HEIGHT };
    items.push(Item { rect: bar, mark: Mark::Scale(key.scale, lo, hi) });
    y += BAR_HEIGHT + PAD;
    items.extend(ticks(lo, hi, bar, y));
    y += LINE_STEP;
    for (colour, line) in special_lines {
        if let Some(colour) = colour {
            items.push(Item { rect: Rect { x: PAD, y, w: SWATCH, h: SWATCH }, mark: Mark::Fill(colour) });
        }
        items.push(Item::text(PAD + SWATCH + 4, y, line, TEXT));
        y += LINE_STEP;
    }
    Some(panel_around(0, y0, items))
}

/// The tick labels under `bar`, at `y`: five, three or two of them, as many
/// as stand a character apart, each centred on its value (the ends kept
/// inside the bar's width).
fn ticks(lo: f32, hi: f32, bar: Rect, y: u32) -> Vec<Item> {
    let label = |v: f32| match (lo < 0.0, hi >= 10.0) {
        (true, _) => format!("{v:+.3}"),
        (false, true) => format!("{v:.0}"),
        (false, false) => format!("{v:.3}"),
    };
    for count in [5u32, 3, 2] {
        let items: Vec<Item> = (0..count)
            .map(|i| {
                let v = lo + (hi - lo) * i as f32 / (count - 1) as f32;
                let text = label(v);
                let w = Rgb8Image::text_width(&text);
                let centre = bar.x + i * (bar.w - 1) / (count - 1);
                let x = centre.saturating_sub(w / 2).clamp(bar.x, (bar.x + bar.w).saturating_sub(w).max(bar.x));
                Item::text(x, y, text, TEXT)
            })
            .collect();
        let apart = items.windows(2).all(|p| p[0].rect.x + p[0].rect.w + CHAR_WIDTH <= p[1].rect.x);
        let inside = items.iter().all(|i| i.rect.x + i.rect.w <= bar.x + bar.w);
        if apart && inside {
            return items;
        }
    }
    vec![]
}

#[cfg(test)]
mod tests {
    use super::super::tests::assert_fits;
    use super::*;

    fn key(scale: Scale, specials: Vec<([u8; 3], String)>) -> ColourKey {
        ColourKey { scale, title: "mesh depth - field depth, 1 cell full scale", unit: "scene units", specials }
    }

    fn ticks_of(panel: &Panel) -> Vec<String> {
        let bar = panel.items.iter().find(|i| matches!(i.mark, Mark::Scale(..))).expect("a bar").rect;
        let texts = panel.items.iter().filter(|i| i.rect.y == bar.y + BAR_HEIGHT + PAD);
        texts.filter_map(|i| if let Mark::Text(t, _) = &i.mark { Some(t.clone()) } else { None }).collect()
    }

    #[test]
    fn ticks_never_touch_fewer_where_the_bar_is_short() {
        let specials = vec![([40, 40, 46], "hit in one render only".to_string())];
        let k = key(Scale::Signed { max: 0.05 }, specials);
        for (w, h, expected) in [(160, 120, 2), (320, 240, 2), (640, 480, 3), (1920, 1080, 5)] {
            let panel = colour_bar(w, h, 16, &k).expect("a bar fits");
            assert_fits(std::slice::from_ref(&panel), w, h, &format!("{w}x{h}"));
            assert_eq!(ticks_of(&panel).len(), expected, "{w}x{h}: {:?}", ticks_of(&panel));
            assert!(panel.rect.y >= 16, "below the status band");
        }
        assert_eq!(
            ticks_of(&colour_bar(1920, 1080, 16, &k).unwrap()),
            ["-0.050", "-0.025", "+0.000", "+0.025", "+0.050"]
        );
    }

    #[test]
    fn the_bar_draws_its_ends_and_labels_the_special_colours_its_view_shows() {
        let scale = Scale::Magnitude { max: 10.0 };
        let labels = crate::draw::SpecialLabels { no_value: "a gradient vanishes", infinite: "infinite" };
        let shown = ColourKey::of(&[1.0, f32::NAN, 20.0], scale, ("angle", "deg"), &labels);
        let plain = ColourKey::of(&[1.0], scale, ("angle", "deg"), &labels);
        let (with, without) = (colour_bar(300, 200, 16, &shown).unwrap(), colour_bar(300, 200, 16, &plain).unwrap());
        let fills = |p: &Panel| p.items.iter().filter(|i| matches!(i.mark, Mark::Fill(_))).count();
        assert_eq!((fills(&with), fills(&without)), (2, 1), "no value and beyond the scale; beyond the scale only");
        let mut image = Rgb8Image::filled(300, 200, [128, 128, 128]);
        super::super::draw(&mut image, &with);
        let has = |c: [u8; 3]| image.pixels.chunks_exact(3).any(|p| p == c);
        assert!(has(scale.color(0.0)) && has(scale.color(10.0)) && has(OVER_RANGE), "both ends, and the colour beyond");
    }

    #[test]
    fn a_short_view_drops_the_special_lines_before_the_bar() {
        let specials: Vec<_> = (0..6).map(|k| ([k, k, k], format!("special {k}"))).collect();
        let k = key(Scale::Signed { max: 1.0 }, specials);
        let panel = colour_bar(640, 100, 16, &k).expect("the bar fits");
        assert_fits(std::slice::from_ref(&panel), 640, 100, "short");
        assert!(panel.rect.y >= 16);
        assert!(colour_bar(40, 30, 16, &k).is_none(), "nothing where not even the bar fits");
    }
}
