//! The status band: one line across the top of the view, its parts joined
//! by bars. Where the window is too narrow for them all, a part gives its
//! short form, then parts are left out from the least important up (the
//! window's title keeps the whole status); the band never grows over the
//! picture.

use super::{Item, PAD, Panel, Rect, TEXT, chars_across};
use crate::draw::LINE_HEIGHT;

/// One part of the status, whole and shortened.
#[derive(Clone, Debug, PartialEq)]
pub struct StatusPart {
    pub full: String,
    pub short: String,
}

impl StatusPart {
    /// A part with no shorter form.
    #[must_use]
    pub fn new(text: impl Into<String>) -> Self {
        let full = text.into();
        Self { short: full.clone(), full }
    }

    /// A part that shortens to `short`.
    #[must_use]
    pub fn shortened(full: impl Into<String>, short: impl Into<String>) -> Self {
        Self { full: full.into(), short: short.into() }
    }
}

/// The height of the band.
pub const BAND_HEIGHT: u32 = LINE_HEIGHT + 2 * PAD;

/// The band across the top of a `width`-wide view: `parts` in order of
/// importance, the last (how to get help) kept at the end while it fits.
#[must_use]
pub fn status(width: u32, parts: &[StatusPart]) -> Panel {
    let line = fitted(parts, chars_across(width));
    let items = if line.is_empty() { vec![] } else { vec![Item::text(PAD, PAD, line, TEXT)] };
    let w = items.first().map_or(0, |i| i.rect.w + 2 * PAD).min(width);
    Panel { rect: Rect { x: 0, y: 0, w, h: BAND_HEIGHT }, items }
}

/// The line of at most `chars` characters that `parts` make: the first
/// always (cut short if it must be), the last when it fits after the rest.
fn fitted(parts: &[StatusPart], chars: usize) -> String {
    const BAR: &str = " | ";
    let len = |s: &str| s.chars().count();
    let (Some(first), Some(last)) = (parts.first(), parts.last()) else { return String::new() };
    if len(&first.short) > chars {
        let kept: String = first.short.chars().take(chars.saturating_sub(2)).collect();
        return if chars >= 3 { format!("{kept}..") } else { String::new() };
    }
    let mut line = if len(&first.full) <= chars { first.full.clone() } else { first.short.clone() };
    if parts.len() == 1 {
        return line;
    }
    let room = chars.saturating_sub(len(&last.short) + len(BAR));
    for part in &parts[1..parts.len() - 1] {
        if let Some(longer) =
            [&part.full, &part.short].map(|t| format!("{line}{BAR}{t}")).into_iter().find(|l| len(l) <= room)
        {
            line = longer;
        }
    }
    let with_last = format!("{line}{BAR}{}", last.short);
    if len(&with_last) <= chars { with_last } else { line }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parts() -> Vec<StatusPart> {
        vec![
            StatusPart::new("field"),
            StatusPart::new("moving body"),
            StatusPart::shortened("frame 6: first pass 24 ms, refined 290 ms (0.3 M rays/s)", "frame 6: 24 / 290 ms"),
            StatusPart::new("indexed"),
            StatusPart::new("H: help"),
        ]
    }

    #[test]
    fn a_wide_view_shows_every_part_whole() {
        let panel = status(1000, &parts());
        let super::super::Mark::Text(line, _) = &panel.items[0].mark else { panic!() };
        assert_eq!(
            line,
            "field | moving body | frame 6: first pass 24 ms, refined 290 ms (0.3 M rays/s) | indexed | H: help"
        );
    }

    #[test]
    fn a_narrow_view_shortens_then_leaves_parts_out_and_keeps_one_line() {
        let line = |width: u32| {
            let panel = status(width, &parts());
            assert_eq!(panel.rect.h, BAND_HEIGHT, "one line");
            assert!(panel.rect.w <= width);
            match panel.items.first().map(|i| &i.mark) {
                Some(super::super::Mark::Text(line, _)) => line.clone(),
                _ => String::new(),
            }
        };
        assert_eq!(line(640), "field | moving body | frame 6: 24 / 290 ms | indexed | H: help");
        assert_eq!(line(320), "field | moving body | indexed | H: help");
        assert_eq!(line(160), "field | H: help");
        assert_eq!(line(112), "field", "the first part always, the last only when it fits");
        assert_eq!(line(40), "fi..");
        assert_eq!(line(8), "");
    }
}
