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

/// Ask the allocator for `bytes` at once and give them back, so that memory the budget let through
/// but the machine (or `ulimit -v`) has not got is an error naming `what`, its size and the budget,
/// not an abort halfway through allocating it. Nothing is touched, so nothing becomes resident.
/// For what is allocated in many pieces or inside other crates (ECS tables, the BVH): one block of
/// the whole is the stricter test, and the address space it proves is given back for them.
pub fn reserve(what: &str, bytes: u64, budget: u64) -> crate::error::Result<()> {
    let refused = || crate::error::Error::OutOfMemory { what: what.to_string(), bytes, budget };
    let mut probe: Vec<u8> = Vec::new();
    probe.try_reserve_exact(usize::try_from(bytes).map_err(|_| refused())?).map_err(|_| refused())
}

/// `len` copies of `value`, or the error of [`reserve`] where the allocator has not got them.
pub fn try_filled<T: Clone>(what: &str, len: usize, value: T, budget: u64) -> crate::error::Result<Vec<T>> {
    let mut vec = Vec::new();
    vec.try_reserve_exact(len).map_err(|_| crate::error::Error::OutOfMemory {
        what: what.to_string(),
        bytes: (len as u64).saturating_mul(size_of::<T>() as u64),
        budget,
    })?;
    vec.resize(len, value);
    Ok(vec)
}

/// How a host counts what its process holds, when it counts better than the resident memory: a
/// counting allocator, jemalloc's statistics. `None`: the resident memory.
static HELD_PROBE: std::sync::RwLock<Option<fn() -> u64>> = std::sync::RwLock::new(None);

/// Have the memory budget count what the process holds with `probe` (bytes) instead of its resident
/// memory: for a host whose allocator keeps its own count, and for tests that compare the budget's
/// count with the allocator's.
pub fn count_held_with(probe: fn() -> u64) {
    *HELD_PROBE.write().unwrap_or_else(|e| e.into_inner()) = Some(probe);
}

/// What the process holds now, as the budget counts it: the host's probe, else the resident memory.
pub fn held_bytes() -> Option<u64> {
    match *HELD_PROBE.read().unwrap_or_else(|e| e.into_inner()) {
        Some(probe) => Some(probe()),
        None => resident_bytes(),
    }
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
