//! The run's command line as a person copies it: words quoted for a POSIX
//! shell, and the commit of the scenes' repository.

use std::path::Path;
use std::process::{Command, Stdio};

/// `word` as one word of a POSIX shell command: as it is when it holds only
/// characters no shell treats specially, else in single quotes (a quote
/// inside closes them, escapes itself and reopens them).
#[must_use]
pub fn shell_quote(word: &str) -> String {
    let plain = |c: char| c.is_ascii_alphanumeric() || "_-./:=@%+,".contains(c);
    if !word.is_empty() && word.chars().all(plain) {
        return word.to_string();
    }
    format!("'{}'", word.replace('\'', "'\\''"))
}

/// `git rev-parse HEAD` in `folder`: the commit of the repository holding
/// it, when it is in one and git runs; `None` otherwise.
#[must_use]
pub fn repository_commit(folder: &Path) -> Option<String> {
    let out = Command::new("git")
        .arg("-C")
        .arg(folder)
        .args(["rev-parse", "HEAD"])
        .stdin(Stdio::null())
        .stderr(Stdio::null())
        .output()
        .ok()?;
    let commit = String::from_utf8(out.stdout).ok()?.trim().to_string();
    let hex = commit.len() >= 40 && commit.chars().all(|c| c.is_ascii_hexdigit());
    (out.status.success() && hex).then_some(commit)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn words_a_shell_would_split_or_expand_are_quoted_so_it_reads_them_back_as_given() {
        assert_eq!(shell_quote("images/ref"), "images/ref");
        assert_eq!(shell_quote("a b"), "'a b'");
        assert_eq!(shell_quote(""), "''");
        assert_eq!(shell_quote("it's $HOME & <x>"), "'it'\\''s $HOME & <x>'");
        for word in ["plain", "a b", "it's", "$(rm -rf /)", "ü \"q\" & 'x'", ""] {
            let out = Command::new("sh").args(["-c", &format!("printf %s {}", shell_quote(word))]).output().unwrap();
            assert_eq!(String::from_utf8(out.stdout).unwrap(), word);
        }
    }
}
