//! JUnit XML for a regression run, the report CI systems (GitHub Actions,
//! GitLab, Buildkite, Jenkins) read: one test case per entry, each failure
//! with its statistics.

use std::fmt::Write as _;

use super::summary::RegressRow;
use crate::compare::Verdict;

/// The JUnit XML of `rows`, as the suite `suite`.
#[must_use]
pub fn junit_xml(suite: &str, rows: &[RegressRow]) -> String {
    let failures = rows.iter().filter(|(_, d)| d.as_ref().is_none_or(|d| d.verdict == Verdict::Fail)).count();
    let mut xml = String::from("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    let suite = escape(suite);
    let _ = writeln!(xml, "<testsuites name=\"{suite}\" tests=\"{}\" failures=\"{failures}\">", rows.len());
    let _ = writeln!(xml, "  <testsuite name=\"{suite}\" tests=\"{}\" failures=\"{failures}\">", rows.len());
    for (name, diff) in rows {
        let name = escape(name);
        let failure = match diff {
            None => Some("no readable reference (bless to create it)".to_string()),
            Some(d) if d.verdict == Verdict::Fail => Some(format!(
                "max {:.4}, {} of {} pixels above {} ({:.3}%), mean {:.3e}",
                d.max, d.over_fail_px, d.compared, d.thresholds.fail, d.over_fail_percent, d.mean
            )),
            Some(_) => None,
        };
        match failure {
            None => {
                let _ = writeln!(xml, "    <testcase classname=\"{suite}\" name=\"{name}\"/>");
            }
            Some(message) => {
                let message = escape(&message);
                let _ = writeln!(xml, "    <testcase classname=\"{suite}\" name=\"{name}\">");
                let _ = writeln!(xml, "      <failure message=\"{message}\">{message}</failure>");
                let _ = writeln!(xml, "    </testcase>");
            }
        }
    }
    xml.push_str("  </testsuite>\n</testsuites>\n");
    xml
}

/// `text` safe inside XML text and attribute values.
fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            c => out.push(c),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_and_messages_are_escaped_and_missing_references_fail() {
        let xml = junit_xml("regress <a&b>", &[("x\"y.png".into(), None)]);
        assert!(xml.contains("name=\"regress &lt;a&amp;b&gt;\"") && xml.contains("name=\"x&quot;y.png\""), "{xml}");
        assert!(xml.contains("failures=\"1\"") && xml.contains("<failure message=\"no readable reference"), "{xml}");
    }
}
