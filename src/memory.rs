//! Process memory measurements (Linux `/proc`), used for the memory budget of the sweep
//! schedule and for the per-phase peak memory of `sparsemor bench`, and the free disk space
//! of line-fitting's spill file.

/// Bytes the kernel reports as available for new allocations (`MemAvailable`), if known.
pub fn available_bytes() -> Option<usize> {
    proc_kib("/proc/meminfo", "MemAvailable:")
}

/// The default budget of concurrent factorizations (the sweep's workers, the eigensolver's
/// slices): `1/share` of [`available_bytes`], or of 8 GiB when that is unknown.
pub fn default_budget(share: usize) -> usize {
    available_bytes().unwrap_or(8 << 30) / share.max(1)
}

/// Bytes free for an unprivileged user on the file system of `dir` (`statvfs`), if known.
pub fn free_disk_bytes(dir: &std::path::Path) -> Option<u64> {
    #[cfg(unix)]
    {
        let st = rustix::fs::statvfs(dir).ok()?;
        Some(st.f_bavail.saturating_mul(st.f_frsize))
    }
    #[cfg(not(unix))]
    {
        let _ = dir;
        None
    }
}

/// Peak resident set size of this process so far (`VmHWM`), if known.
pub fn peak_rss_bytes() -> Option<usize> {
    proc_kib("/proc/self/status", "VmHWM:")
}

/// Current resident set size (`VmRSS`), if known.
pub fn rss_bytes() -> Option<usize> {
    proc_kib("/proc/self/status", "VmRSS:")
}

/// Resets the peak RSS counter to the current RSS (writes 5 to `/proc/self/clear_refs`), so
/// the next [`peak_rss_bytes`] measures one phase. Returns false where unsupported.
pub fn reset_peak_rss() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

fn proc_kib(file: &str, key: &str) -> Option<usize> {
    let text = std::fs::read_to_string(file).ok()?;
    let line = text.lines().find(|l| l.starts_with(key))?;
    let kib: usize = line[key.len()..]
        .trim()
        .trim_end_matches("kB")
        .trim()
        .parse()
        .ok()?;
    Some(kib * 1024)
}
