//! The machine's memory, which budgets are fractions of.

/// Physical memory in bytes (Linux `/proc/meminfo`; 8 GiB where it cannot be read).
pub fn physical_bytes() -> u64 {
    std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|text| {
            let line = text.lines().find(|l| l.starts_with("MemTotal:"))?;
            line.split_whitespace().nth(1)?.parse::<u64>().ok().map(|kib| kib * 1024)
        })
        .unwrap_or(8 << 30)
}

/// This process's resident memory now (`VmRSS`), where the system says (Linux).
pub fn resident_bytes() -> Option<u64> {
    status_kib("VmRSS:").map(|kib| kib * 1024)
}

/// The most resident memory this process has held (`VmHWM`), where the system says (Linux).
pub fn peak_resident_bytes() -> Option<u64> {
    status_kib("VmHWM:").map(|kib| kib * 1024)
}

/// A `KEY: N kB` line of /proc/self/status.
fn status_kib(key: &str) -> Option<u64> {
    let text = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = text.lines().find(|l| l.starts_with(key))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

#[cfg(test)]
mod tests {
    #[test]
    #[cfg(target_os = "linux")]
    fn resident_memory_grows_with_what_is_touched() {
        let before = super::resident_bytes().unwrap();
        // black_box: an allocation nothing reads may be optimised away.
        let held = std::hint::black_box(vec![1u8; 64 << 20]);
        let after = super::resident_bytes().unwrap();
        assert!(after >= before + (60 << 20), "{before} -> {after}");
        assert!(super::peak_resident_bytes().unwrap() >= after);
        drop(held);
    }
}
