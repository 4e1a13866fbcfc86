//! JUnit XML for a regression run, the report CI systems (GitHub Actions,
//! GitLab, Buildkite, Jenkins) read: one test case per entry, each failure
//! with its statistics.

use std::fmt::Write as _;

use super::markup::escape;
use super::summary::{Outcome, RegressRow};

/// The JUnit XML of `rows`, as the suite `suite`.
#[must_use]
pub fn junit_xml(suite: &str, rows: &[RegressRow]) -> String {
    let failures = rows.iter().filter(|r| r.outcome == Outcome::Failed).count();
    let mut xml = String::from("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    let suite = escape(suite);
    let _ = writeln!(xml, "<testsuites name=\"{suite}\" tests=\"{}\" failures=\"{failures}\">", rows.len());
    let _ = writeln!(xml, "  <testsuite name=\"{suite}\" tests=\"{}\" failures=\"{failures}\">", rows.len());
    for row in rows {
        let name = escape(&row.name);
        let failure = match &row.judgement {
            None => Some("no readable reference (bless to create it)".to_string()),
            Some(d) if row.outcome == Outcome::Failed => Some(format!(
                "max {:.4}, {} of {} pixels above {} ({:.3}%), mean {:.3e}",
                d.max, d.over_fail_px, d.pixels, row.tolerances.fail, d.over_fail_percent, d.mean
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_and_messages_are_escaped_and_missing_references_fail() {
        let row = crate::pipeline::regress::summary::missing_row("x\"y.png");
        let xml = junit_xml("regress <a&b>", &[row]);
        assert!(xml.contains("name=\"regress &lt;a&amp;b&gt;\"") && xml.contains("name=\"x&quot;y.png\""), "{xml}");
        assert!(xml.contains("failures=\"1\"") && xml.contains("<failure message=\"no readable reference"), "{xml}");
    }
}
