//! The help card: every key and what it does, below the status band. Its
//! entries go down a column, then across into more columns where the window
//! is wide, then onto pages where it is small; the heading says which page
//! shows and that H turns to the next. A description too long for the
//! window goes on under itself.

use super::{HEADING, Item, LINE_STEP, PAD, Panel, TEXT, chars_across, panel_around, wrapped};
use crate::draw::CHAR_WIDTH;

/// Characters between two columns.
const GUTTER: u32 = 3;
/// Characters across from which the names of keys get a column of their own.
const NAME_COLUMN_FROM: usize = 48;

/// The card as laid out for one window: its entries' lines, each entry's
/// lines kept together on one column of one page.
pub struct HelpCard {
    /// Pages of columns of lines.
    pages: Vec<Vec<Vec<String>>>,
    /// Characters in the widest column.
    column_chars: usize,
    /// Lines the heading takes.
    heading_lines: usize,
}

impl HelpCard {
    /// How many pages the card takes.
    #[must_use]
    pub fn pages(&self) -> usize {
        self.pages.len()
    }
}

/// Lays out `keys` (names, what they do) for a `width × height` window
/// whose status band ends at `top`.
#[must_use]
pub fn help(width: u32, height: u32, top: u32, keys: &[(String, &str)]) -> HelpCard {
    let across = chars_across(width);
    // Names in a column of their own where the window is wide enough for
    // one; where not, and where a name is longer than a third of the line,
    // it goes on a line of its own, its description indented under it.
    let key_width = keys.iter().map(|(k, _)| k.chars().count()).max().unwrap_or(0);
    let key_width = if across < NAME_COLUMN_FROM { 0 } else { key_width.min(across / 3) };
    let indent = " ".repeat(if key_width == 0 { 2 } else { key_width + 2 });
    let entries: Vec<Vec<String>> = keys
        .iter()
        .map(|(k, what)| {
            let mut lines = vec![];
            if k.chars().count() > key_width {
                lines.extend(wrapped(k, across));
            }
            for (i, part) in wrapped(what, across.saturating_sub(indent.len())).into_iter().enumerate() {
                let first = i == 0 && k.chars().count() <= key_width;
                lines.push(if first { format!("{k:<key_width$}  {part}") } else { format!("{indent}{part}") });
            }
            lines
        })
        .collect();
    let column_chars = entries.iter().flatten().map(|l| l.chars().count()).max().unwrap_or(0);
    // The longest heading a page may have (see `heading`).
    let heading_lines = wrapped("Keys, page 99 of 99 (H: next page)", across).len();
    // Lines below the heading on a page.
    let rows = ((height.saturating_sub(top + 2 * PAD) / LINE_STEP) as usize).saturating_sub(heading_lines).max(1);
    let columns = ((across + GUTTER as usize) / (column_chars + GUTTER as usize)).max(1);
    HelpCard { pages: paged(entries, rows, columns), column_chars, heading_lines }
}

/// `entries` into pages of `columns` columns of `rows` lines, each entry
/// whole in one column (an entry longer than a column is cut).
fn paged(entries: Vec<Vec<String>>, rows: usize, columns: usize) -> Vec<Vec<Vec<String>>> {
    let mut pages: Vec<Vec<Vec<String>>> = vec![vec![vec![]]];
    for mut entry in entries {
        entry.truncate(rows);
        let page = pages.last_mut().expect("a page");
        if page.last().expect("a column").len() + entry.len() > rows {
            if page.len() < columns {
                page.push(vec![]);
            } else {
                pages.push(vec![vec![]]);
            }
        }
        pages.last_mut().and_then(|p| p.last_mut()).expect("a column").extend(entry);
    }
    pages
}

impl HelpCard {
    /// Page `page` (from 0) of the card, centred below `top` in a `width × height` window.
    #[must_use]
    pub fn panel(&self, page: usize, width: u32, height: u32, top: u32) -> Panel {
        let page = page.min(self.pages.len() - 1);
        let heading = wrapped(&self.heading(page), chars_across(width));
        let heading_lines = heading.len().min(self.heading_lines) as u32;
        let columns = &self.pages[page];
        let column_width = (self.column_chars as u32 + GUTTER) * CHAR_WIDTH;
        let lines = columns.iter().map(Vec::len).max().unwrap_or(0) as u32 + heading_lines;
        let heading_width = heading.iter().map(|l| l.chars().count()).max().unwrap_or(0) as u32 * CHAR_WIDTH;
        let card_width = (columns.len() as u32 * column_width - GUTTER * CHAR_WIDTH).max(heading_width) + 2 * PAD;
        let card_height = lines * LINE_STEP + 2 * PAD;
        let x = width.saturating_sub(card_width) / 2;
        let y = top + height.saturating_sub(top + card_height) / 2;
        let mut items = vec![];
        for (r, line) in heading.into_iter().take(heading_lines as usize).enumerate() {
            items.push(Item::text(x + PAD, y + PAD + r as u32 * LINE_STEP, line, HEADING));
        }
        for (c, column) in columns.iter().enumerate() {
            for (r, line) in column.iter().enumerate() {
                let at = (x + PAD + c as u32 * column_width, y + PAD + (r as u32 + heading_lines) * LINE_STEP);
                items.push(Item::text(at.0, at.1, line.trim_end(), TEXT));
            }
        }
        panel_around(x, y, items)
    }

    /// The heading of page `page`: which page it is, and what H does next.
    fn heading(&self, page: usize) -> String {
        match self.pages.len() {
            1 => "Keys (H or F1 hides this card)".to_string(),
            n if page + 1 < n => format!("Keys, page {} of {n} (H: next page)", page + 1),
            n => format!("Keys, page {n} of {n} (H hides this card)"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::assert_fits;
    use super::*;

    fn keys() -> Vec<(String, &'static str)> {
        (0..24).map(|k| (format!("key{k}"), "does something the card says in a few words")).collect()
    }

    #[test]
    fn the_card_fits_every_window_in_columns_or_pages_and_shows_every_entry() {
        for (w, h) in [(160, 120), (320, 240), (640, 480), (1920, 1080), (3840, 2160)] {
            let card = help(w, h, 16, &keys());
            let mut seen = vec![];
            for page in 0..card.pages() {
                let panel = card.panel(page, w, h, 16);
                assert_fits(std::slice::from_ref(&panel), w, h, &format!("{w}x{h} page {page}"));
                assert!(panel.rect.y >= 16, "below the status band");
                for item in &panel.items {
                    if let super::super::Mark::Text(t, _) = &item.mark {
                        seen.extend(t.split_whitespace().filter(|w| w.starts_with("key")).map(String::from));
                    }
                }
            }
            for k in 0..24 {
                assert!(seen.contains(&format!("key{k}")), "{w}x{h}: key{k} is on a page");
            }
            let expect_pages = if w >= 640 { 1 } else { 2 };
            assert!(card.pages() >= expect_pages, "{w}x{h}: {} pages", card.pages());
            if w >= 1920 {
                assert_eq!(card.pages(), 1, "{w}x{h}: one page");
            }
        }
    }

    #[test]
    fn a_page_says_which_it_is_and_how_to_turn() {
        let card = help(160, 120, 16, &keys());
        assert!(card.pages() > 1);
        let heading = |page: usize| {
            let panel = card.panel(page, 160, 120, 16);
            let lines = panel.items.iter().filter_map(|i| match &i.mark {
                super::super::Mark::Text(t, c) if *c == HEADING => Some(t.clone()),
                _ => None,
            });
            lines.collect::<Vec<_>>().join(" ")
        };
        assert!(heading(0).starts_with("Keys, page 1 of"), "{}", heading(0));
        assert!(heading(card.pages() - 1).contains("H hides"), "{}", heading(card.pages() - 1));
    }
}
