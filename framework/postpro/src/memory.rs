//! The process's peak memory, for `--timing`: the high-water mark of its resident set where the
//! system keeps one (Linux: `VmHWM` in `/proc/self/status`); elsewhere nothing is said.

/// The most resident memory this process has held so far, in bytes, if the system says.
pub(crate) fn peak_resident() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    parse_peak(&status)
}

/// `VmHWM` of a `/proc/<pid>/status` text, in bytes.
fn parse_peak(status: &str) -> Option<u64> {
    let value = status.lines().find_map(|line| line.strip_prefix("VmHWM:"))?;
    let kib: u64 = value.trim().strip_suffix("kB")?.trim().parse().ok()?;
    Some(kib * 1024)
}

/// `; peak memory 23.4 MB`, the end of a `--timing` line; empty where the system does not say.
pub(crate) fn peak_note() -> String {
    peak_resident().map_or_else(String::new, |bytes| format!("; peak memory {:.1} MB", bytes as f64 / 1e6))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_high_water_mark_is_read_in_bytes() {
        let status = "Name:\tpostpro\nVmPeak:\t  123456 kB\nVmHWM:\t   23456 kB\nVmRSS:\t   20000 kB\n";
        assert_eq!(parse_peak(status), Some(23456 * 1024));
        assert_eq!(parse_peak("Name:\tpostpro\n"), None);
        assert_eq!(parse_peak("VmHWM:\t  12 MB\n"), None);
    }

    #[test]
    #[cfg(target_os = "linux")]
    fn linux_says_it() {
        let peak = peak_resident().expect("/proc/self/status has VmHWM");
        assert!(peak > 1 << 20, "{peak}");
        assert!(peak_note().starts_with("; peak memory "), "{}", peak_note());
    }
}
