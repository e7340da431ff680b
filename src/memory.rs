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
