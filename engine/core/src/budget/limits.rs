//! The memory this process may use, as a batch system bounds it: the machine's available
//! memory, the process's address-space and data-size limits (`ulimit -v`, `ulimit -d`, which
//! Slurm and PBS set per job) less what the process has mapped already, and the memory
//! cgroup's limit (`memory.max` in cgroup v2, `memory.limit_in_bytes` in v1, the way Slurm's
//! `--mem` and container runtimes bound a job) less what the group uses. The smallest wins.
//!
//! Everything is read from `/proc` and `/sys/fs/cgroup` as text, so no system call needs
//! `unsafe`, and each reader is a pure function of the texts, tested on samples.

use std::path::Path;

/// What set the memory a run may use.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MemoryBound {
    /// `FRACTUM_MEMORY_LIMIT`, given by the user.
    Variable,
    /// The machine's available memory (`MemAvailable` of `/proc/meminfo`).
    Machine,
    /// The address-space limit (`RLIMIT_AS`, `ulimit -v`) less the process's mapped memory.
    AddressSpace,
    /// The data-size limit (`RLIMIT_DATA`, `ulimit -d`) less the process's data segment.
    DataSize,
    /// The memory cgroup's limit less its use (page cache it can reclaim not counted).
    Cgroup,
    /// Nothing could be read: no bound.
    Unknown,
}

impl MemoryBound {
    /// The bound as a person reads it, for a refusal or `fractum check`.
    pub fn describe(self) -> &'static str {
        match self {
            MemoryBound::Variable => "set by FRACTUM_MEMORY_LIMIT",
            MemoryBound::Machine => "the machine's available memory",
            MemoryBound::AddressSpace => {
                "the process's address-space limit (ulimit -v) less what it has mapped"
            }
            MemoryBound::DataSize => {
                "the process's data-size limit (ulimit -d) less its data segment"
            }
            MemoryBound::Cgroup => "the memory cgroup's limit less what the group uses",
            MemoryBound::Unknown => "unknown",
        }
    }
}

/// The memory a run may use and what bounds it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Available {
    /// Bytes; infinite when nothing bounds it.
    pub bytes: f64,
    /// What set `bytes`.
    pub bound: MemoryBound,
}

impl Available {
    /// No bound known.
    pub const UNKNOWN: Available = Available {
        bytes: f64::INFINITY,
        bound: MemoryBound::Unknown,
    };

    /// `3.7 GiB available (what bounds it)`, or that it is unknown.
    pub fn describe(&self) -> String {
        if self.bytes.is_finite() {
            format!(
                "{} available ({})",
                super::describe_bytes(self.bytes),
                self.bound.describe()
            )
        } else {
            "available memory unknown".to_string()
        }
    }

    /// The smaller of `self` and `bytes` set by `bound` (ties keep `self`).
    fn tighten(self, bytes: Option<f64>, bound: MemoryBound) -> Available {
        match bytes {
            Some(b) if b < self.bytes => Available {
                bytes: b.max(0.0),
                bound,
            },
            _ => self,
        }
    }
}

/// The memory this process may use now: the smallest of the machine's available memory, the
/// headroom under the address-space and data-size limits, and the memory cgroup's headroom.
pub fn process_available() -> Available {
    let read = |path: &str| std::fs::read_to_string(path).ok();
    let meminfo = read("/proc/meminfo");
    let limits = read("/proc/self/limits");
    let status = read("/proc/self/status");
    let machine = meminfo.as_deref().and_then(mem_available);
    let mut available = Available::UNKNOWN.tighten(machine, MemoryBound::Machine);
    if let (Some(limits), Some(status)) = (limits.as_deref(), status.as_deref()) {
        let headroom = |limit: &str, used: &str| {
            let limit = soft_limit(limits, limit)?;
            Some(limit - status_bytes(status, used).unwrap_or(0.0))
        };
        available = available.tighten(
            headroom("Max address space", "VmSize:"),
            MemoryBound::AddressSpace,
        );
        available = available.tighten(headroom("Max data size", "VmData:"), MemoryBound::DataSize);
    }
    if let Some(groups) = read("/proc/self/cgroup") {
        available = available.tighten(
            cgroup_headroom(&groups, Path::new("/sys/fs/cgroup")),
            MemoryBound::Cgroup,
        );
    }
    available
}

/// `MemAvailable` of a `/proc/meminfo` text, in bytes.
pub(super) fn mem_available(meminfo: &str) -> Option<f64> {
    let line = meminfo.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024.0)
}

/// The soft limit in bytes of the `/proc/self/limits` row named `name` (`Max address
/// space`); `None` when unlimited or absent.
fn soft_limit(limits: &str, name: &str) -> Option<f64> {
    let rest = limits.lines().find_map(|l| l.strip_prefix(name))?;
    rest.split_whitespace().next()?.parse().ok()
}

/// A `kB` field of `/proc/self/status` (`VmSize:`), in bytes.
fn status_bytes(status: &str, field: &str) -> Option<f64> {
    let rest = status.lines().find_map(|l| l.strip_prefix(field))?;
    let kib: f64 = rest.split_whitespace().next()?.parse().ok()?;
    Some(kib * 1024.0)
}

/// The least headroom (limit less use) of the memory cgroups this process is in, and of their
/// ancestors, under the cgroup file systems mounted at `root`: cgroup v2 (`0::/path`, files
/// `memory.max` and `memory.current`) and v1 (`N:memory:/path`, under `root/memory`, files
/// `memory.limit_in_bytes` and `memory.usage_in_bytes`). Inactive page cache, which the kernel
/// reclaims before it fails an allocation, is not counted as used. Inside a container the
/// mount shows only the container's own subtree, so the group's path may not exist under it;
/// every level that does exist, the mount's root included, is read. `None` where no level
/// sets a limit.
pub fn cgroup_headroom(proc_cgroup: &str, root: &Path) -> Option<f64> {
    let mut least: Option<f64> = None;
    for line in proc_cgroup.lines() {
        let mut parts = line.splitn(3, ':');
        let (Some(_), Some(controllers), Some(path)) = (parts.next(), parts.next(), parts.next())
        else {
            continue;
        };
        let version = if controllers.is_empty() {
            CgroupVersion::Two
        } else if controllers.split(',').any(|c| c == "memory") {
            CgroupVersion::One
        } else {
            continue;
        };
        let mount = match version {
            CgroupVersion::Two => root.to_path_buf(),
            CgroupVersion::One => root.join("memory"),
        };
        let mut levels = vec![mount.clone()];
        let mut walked = mount;
        for part in path.split('/').filter(|p| !p.is_empty()) {
            walked = walked.join(part);
            levels.push(walked.clone());
        }
        for level in levels {
            if let Some(headroom) = version.headroom(&level) {
                least = Some(least.map_or(headroom, |l: f64| l.min(headroom)));
            }
        }
    }
    least
}

#[derive(Clone, Copy)]
enum CgroupVersion {
    One,
    Two,
}

impl CgroupVersion {
    /// Limit less use at one cgroup directory; `None` without a limit there.
    fn headroom(self, dir: &Path) -> Option<f64> {
        let read = |name: &str| std::fs::read_to_string(dir.join(name)).ok();
        let number = |text: String| text.trim().parse::<f64>().ok();
        let (limit, usage, cache_key) = match self {
            CgroupVersion::Two => (
                number(read("memory.max")?)?,
                read("memory.current").and_then(number),
                "inactive_file",
            ),
            CgroupVersion::One => (
                number(read("memory.limit_in_bytes")?)?,
                read("memory.usage_in_bytes").and_then(number),
                "total_inactive_file",
            ),
        };
        // cgroup v1 writes "no limit" as the largest page-aligned i64.
        if limit >= V1_UNLIMITED {
            return None;
        }
        let cache = read("memory.stat")
            .and_then(|stat| stat_value(&stat, cache_key))
            .unwrap_or(0.0);
        let used = (usage.unwrap_or(0.0) - cache).max(0.0);
        Some(limit - used)
    }
}

/// Limits from here up mean "none" (v1's unlimited is 2^63 rounded down to a page).
const V1_UNLIMITED: f64 = 9.0e18;

/// A `name value` line of a cgroup `memory.stat`.
fn stat_value(stat: &str, name: &str) -> Option<f64> {
    stat.lines().find_map(|l| {
        let mut words = l.split_whitespace();
        (words.next()? == name).then(|| words.next()?.parse().ok())?
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const LIMITS: &str = "Limit                     Soft Limit           Hard Limit           Units     \n\
        Max cpu time              unlimited            unlimited            seconds   \n\
        Max data size             unlimited            unlimited            bytes     \n\
        Max address space         4096000000           unlimited            bytes     \n";

    #[test]
    fn meminfo_is_read_in_bytes() {
        let text = "MemTotal:       24000000 kB\nMemFree:  100 kB\nMemAvailable:   2048 kB\n";
        assert_eq!(mem_available(text), Some(2048.0 * 1024.0));
        assert_eq!(mem_available("MemTotal: 1 kB\n"), None);
    }

    #[test]
    fn the_address_space_limit_is_read_and_unlimited_is_none() {
        assert_eq!(
            soft_limit(LIMITS, "Max address space"),
            Some(4_096_000_000.0)
        );
        assert_eq!(soft_limit(LIMITS, "Max data size"), None);
        assert_eq!(soft_limit(LIMITS, "Max stack size"), None);
        let status = "Name:\tfractum\nVmPeak:\t  9000 kB\nVmSize:\t  8192 kB\nVmData:\t 100 kB\n";
        assert_eq!(status_bytes(status, "VmSize:"), Some(8192.0 * 1024.0));
    }

    #[test]
    fn the_smallest_bound_wins_and_ties_keep_the_first() {
        let machine = Available::UNKNOWN.tighten(Some(8e9), MemoryBound::Machine);
        let bounded = machine.tighten(Some(4e9), MemoryBound::AddressSpace);
        assert_eq!(bounded.bound, MemoryBound::AddressSpace);
        assert_eq!(bounded.tighten(Some(4e9), MemoryBound::Cgroup), bounded);
        assert_eq!(bounded.tighten(None, MemoryBound::Cgroup), bounded);
        let spent = bounded.tighten(Some(-1e6), MemoryBound::DataSize);
        assert_eq!(spent.bytes, 0.0);
    }

    fn write(dir: &Path, name: &str, text: &str) {
        std::fs::create_dir_all(dir).unwrap();
        std::fs::write(dir.join(name), text).unwrap();
    }

    #[test]
    fn a_cgroup_v2_limit_counts_use_less_inactive_cache_at_every_level() {
        let root = std::env::temp_dir().join(format!("fractum-cgroup2-{}", std::process::id()));
        let job = root.join("slurm/job_42");
        write(&root.join("slurm"), "memory.max", "max\n");
        write(&job, "memory.max", "4294967296\n");
        write(&job, "memory.current", "1073741824\n");
        write(
            &job,
            "memory.stat",
            "anon 1\ninactive_file 536870912\nactive_file 0\n",
        );
        let headroom = cgroup_headroom("0::/slurm/job_42\n", &root);
        assert_eq!(headroom, Some(4294967296.0 - 536870912.0));
        // A tighter parent wins.
        write(&root.join("slurm"), "memory.max", "1000\n");
        assert_eq!(cgroup_headroom("0::/slurm/job_42\n", &root), Some(1000.0));
        std::fs::remove_dir_all(&root).unwrap();
    }

    #[test]
    fn a_cgroup_v1_limit_is_read_from_the_memory_controller_and_unlimited_is_none() {
        let root = std::env::temp_dir().join(format!("fractum-cgroup1-{}", std::process::id()));
        let memory = root.join("memory");
        write(&memory, "memory.limit_in_bytes", "9223372036854771712\n");
        let groups = "4:memory:/process_api/abc\n3:cpuset:/\n0::/\n";
        assert_eq!(cgroup_headroom(groups, &root), None);
        // Inside a container the mount's root is the container's own group.
        write(&memory, "memory.limit_in_bytes", "2147483648\n");
        write(&memory, "memory.usage_in_bytes", "1073741824\n");
        write(
            &memory,
            "memory.stat",
            "cache 5\ntotal_inactive_file 73741824\n",
        );
        assert_eq!(cgroup_headroom(groups, &root), Some(2147483648.0 - 1e9));
        assert_eq!(cgroup_headroom("garbage\n1:cpu:/\n", &root), None);
        std::fs::remove_dir_all(&root).unwrap();
    }
}
