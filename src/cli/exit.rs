//! Exit codes and error messages, one convention across commands: 0 success,
//! 1 an error (a bad scene or script, a failed write, a failed check), 64 a
//! usage error (a bad option or option value) in every command. `diff` keeps
//! idiff's codes for its verdicts (0 pass, 1 warn, 2 fail, 3 size mismatch
//! for the metrics that need one size, 4 file error).

use crate::pipeline::PipelineError;

/// Success.
pub const SUCCESS: u8 = 0;
/// An error: bad input, a failed write, a failed check.
pub const FAILURE: u8 = 1;
/// A bad option or option value (`EX_USAGE`).
pub const USAGE: u8 = 64;

/// A bad option value found after parsing, reported as a usage error.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct UsageError(pub String);

/// The message and exit code of a command's error. A pipeline's bad setting
/// is named as the option that set it (`res` → `--res`).
#[must_use]
pub fn describe(err: &anyhow::Error) -> (String, u8) {
    if let Some(p) = err.chain().find_map(|e| e.downcast_ref::<PipelineError>()) {
        let code = if p.bad_setting().is_some() { USAGE } else { FAILURE };
        let text = with_flags(p);
        // Keep any context added above the pipeline's error.
        let outer: Vec<String> =
            err.chain().take_while(|e| e.downcast_ref::<PipelineError>().is_none()).map(|e| e.to_string()).collect();
        let text = if outer.is_empty() { text } else { format!("{}: {text}", outer.join(": ")) };
        return (text, code);
    }
    let usage = err.chain().any(|e| e.downcast_ref::<UsageError>().is_some());
    (format!("{err:#}"), if usage { USAGE } else { FAILURE })
}

/// `err` as the command line says it: settings as their options.
fn with_flags(err: &PipelineError) -> String {
    match err {
        PipelineError::Setting { setting, problem } => format!("--{} {problem}", setting.replace('_', "-")),
        PipelineError::At { at, source } => format!("{at}: {}", with_flags(source)),
        _ => err.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_settings_are_usage_errors_named_as_options() {
        let bad = anyhow::Error::from(PipelineError::setting("cache_budget", "must be at least 1 MB").at("frame 3"));
        assert_eq!(describe(&bad), ("frame 3: --cache-budget must be at least 1 MB".into(), USAGE));
        let usage = anyhow::Error::from(UsageError("--threads must be between 1 and 1024".into()));
        assert_eq!(describe(&usage).1, USAGE);
        let other = anyhow::Error::from(PipelineError::Unsuitable("no caches".into())).context("mesh");
        assert_eq!(describe(&other), ("mesh: no caches".into(), FAILURE));
        assert_eq!(describe(&anyhow::anyhow!("disk full")).1, FAILURE);
    }
}
