//! The process's memory as Linux reports it: what is available, what the
//! process holds, and its peak, which a measurement can reset to the present
//! so that the peak it reads is its own. Elsewhere each answer is `None`.

/// Memory available to the process in bytes (Linux `MemAvailable`).
#[must_use]
pub fn available_memory_bytes() -> Option<f64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = info.lines().find(|l| l.starts_with("MemAvailable:"))?;
    Some(line.split_whitespace().nth(1)?.parse::<f64>().ok()? * 1024.0)
}

/// The memory the process holds now, in bytes (Linux `VmRSS`).
#[must_use]
pub fn resident_bytes() -> Option<f64> {
    status_bytes("VmRSS:")
}

/// The most memory the process has held since it started or since
/// [`reset_peak_resident`], in bytes (Linux `VmHWM`).
#[must_use]
pub fn peak_resident_bytes() -> Option<f64> {
    status_bytes("VmHWM:")
}

/// Makes the process's peak the memory it holds now (Linux: writing 5 to
/// `/proc/self/clear_refs`), so that a later [`peak_resident_bytes`] is the
/// peak of what ran in between.
pub fn reset_peak_resident() {
    let _ = std::fs::write("/proc/self/clear_refs", "5");
}

/// A `kB` line of `/proc/self/status`, in bytes.
fn status_bytes(key: &str) -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with(key))?;
    Some(line.split_whitespace().nth(1)?.parse::<f64>().ok()? * 1024.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_peak_after_a_reset_holds_what_ran_since() {
        let (Some(_), Some(_)) = (resident_bytes(), peak_resident_bytes()) else {
            eprintln!("no /proc/self/status here");
            return;
        };
        // Other tests of this process allocate and free memory meanwhile, so
        // what it held before the block says nothing of what it holds with
        // it: the peak is checked against what it holds with the block.
        reset_peak_resident();
        let block = std::hint::black_box(vec![1u8; 64 << 20]);
        let holding = resident_bytes().unwrap();
        let peak = peak_resident_bytes().unwrap();
        assert!(holding >= 60.0 * 1024.0 * 1024.0, "the block is held: {holding}");
        assert!(peak >= holding, "{peak} against {holding}");
        assert_eq!(std::hint::black_box(&block)[12345], 1);
        drop(block);
        assert!(available_memory_bytes().is_some_and(|a| a > 0.0));
    }
}
