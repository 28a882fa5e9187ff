//! Memory: how much this process may still take, and estimates of what an
//! input will need, so that a file too large for the machine is refused with
//! the figures before it is built, not ended by the allocator's abort.
//!
//! Everything here is read from `/proc` and `/sys` (Linux); where those
//! cannot be read, nothing is known and nothing is refused.

use std::path::Path;

/// Bytes this process can still allocate, as far as the system says: the
/// least of the memory available (`MemAvailable` in `/proc/meminfo`), what
/// its address-space limit leaves (`RLIMIT_AS`, as `ulimit -v` sets it,
/// from `/proc/self/limits`, less `VmSize`) and what its cgroup's
/// `memory.max` leaves (cgroup v2, less `memory.current`). `None` where none
/// of these can be read.
pub fn available_bytes() -> Option<u64> {
    let free = meminfo_available();
    let address_space = address_space_left();
    let cgroup = cgroup_left();
    [free, address_space, cgroup].into_iter().flatten().min()
}

/// Peak resident set size of this process (`VmHWM` in `/proc/self/status`),
/// 0 where that cannot be read.
pub fn peak_memory_bytes() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| kb_field(&s, "VmHWM:"))
        .unwrap_or(0)
}

fn meminfo_available() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/meminfo").ok()?;
    kb_field(&s, "MemAvailable:")
}

/// A `Name:   1234 kB` field of a `/proc` status file, in bytes.
fn kb_field(s: &str, name: &str) -> Option<u64> {
    let v = s.lines().find_map(|l| l.strip_prefix(name))?;
    let kb: u64 = v.trim().trim_end_matches("kB").trim().parse().ok()?;
    Some(kb * 1024)
}

fn address_space_left() -> Option<u64> {
    let limits = std::fs::read_to_string("/proc/self/limits").ok()?;
    // "Max address space   <soft>   <hard>   bytes"
    let soft = limits
        .lines()
        .find_map(|l| l.strip_prefix("Max address space"))?
        .split_whitespace()
        .next()?;
    let soft: u64 = soft.parse().ok()?; // "unlimited" is no limit
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let used = kb_field(&status, "VmSize:")?;
    Some(soft.saturating_sub(used))
}

fn cgroup_left() -> Option<u64> {
    // cgroup v2: one line "0::/path"
    let cg = std::fs::read_to_string("/proc/self/cgroup").ok()?;
    let rel = cg.lines().find_map(|l| l.strip_prefix("0::"))?;
    let dir = Path::new("/sys/fs/cgroup").join(rel.trim_start_matches('/'));
    let read = |f: &str| std::fs::read_to_string(dir.join(f)).ok();
    let max: u64 = read("memory.max")?.trim().parse().ok()?; // "max" is none
    let current: u64 = read("memory.current")?.trim().parse().ok()?;
    Some(max.saturating_sub(current))
}

/// Bytes of peak memory per table (`{...}` or a `[header]`) of a TOML scene,
/// reading and building together. Measured with `/usr/bin/time -f %M` on
/// `render` of files of 200,000 and 500,000 instance tables (this project's
/// 2-core VM, toml 1.2): 1.4 to 1.9 KB per `{of = "a"}` table to read it
/// alone, 1.8 KB with the scene built.
const TOML_BYTES_PER_TABLE: u64 = 2048;

/// Bytes per value or array of a TOML scene: 85 to 140 B were measured per
/// number added to those tables (as above).
const TOML_BYTES_PER_VALUE: u64 = 160;

/// An estimate of the peak memory that reading and building the TOML scene
/// `text` takes, from a scan of its tables and values that skips strings and
/// comments. It errs high (by 10 to 30 % on the measured files).
pub fn toml_scene_estimate(text: &str) -> TomlEstimate {
    let (tables, values) = toml_counts(text.as_bytes());
    TomlEstimate {
        tables,
        values,
        bytes: tables * TOML_BYTES_PER_TABLE
            + values * TOML_BYTES_PER_VALUE
            + 4 * text.len() as u64,
    }
}

/// What [`toml_scene_estimate`] found.
#[derive(Debug, Clone, Copy)]
pub struct TomlEstimate {
    /// Tables, inline tables and arrays.
    pub tables: u64,
    /// Keys and elements.
    pub values: u64,
    /// The estimated peak, bytes.
    pub bytes: u64,
}

impl TomlEstimate {
    /// Refuses the scene when [`available_bytes`] cannot hold the estimate.
    pub fn check(&self) -> Result<(), String> {
        check_fits(
            self.bytes,
            &format!("its {} tables and {} values", self.tables, self.values),
        )
    }
}

/// `(tables, values)` of TOML text: `{` and `[` outside strings and comments
/// count as tables (array headers and arrays included, which errs high);
/// `=` and `,` count as values.
fn toml_counts(b: &[u8]) -> (u64, u64) {
    let (mut tables, mut values) = (0u64, 0u64);
    let mut i = 0;
    while i < b.len() {
        match b[i] {
            b'#' => {
                while i < b.len() && b[i] != b'\n' {
                    i += 1;
                }
            }
            q @ (b'"' | b'\'') => {
                let multi = b[i..].starts_with(&[q, q, q]);
                let close: &[u8] = if multi { &[q, q, q] } else { &[q] };
                i += close.len();
                while i < b.len() && !b[i..].starts_with(close) {
                    // a basic string's backslash escapes its next byte
                    i += if q == b'"' && b[i] == b'\\' { 2 } else { 1 };
                }
                i += close.len() - 1;
            }
            b'{' | b'[' => tables += 1,
            b'=' | b',' => values += 1,
            _ => {}
        }
        i += 1;
    }
    (tables, values)
}

/// Refuses an input whose estimated peak (`need` bytes) is more than this
/// process can still allocate, with both figures: `what` names the input's
/// contents ("its 2500000 tables").
pub fn check_fits(need: u64, what: &str) -> Result<(), String> {
    match available_bytes() {
        Some(have) if need > have => Err(format!(
            "{what} need about {} of memory to read and build, and only {} is available; nothing was built",
            gib(need),
            gib(have)
        )),
        _ => Ok(()),
    }
}

fn gib(bytes: u64) -> String {
    format!("{:.2} GiB", bytes as f64 / f64::from(1u32 << 30))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn toml_counts_skip_strings_and_comments() {
        let text = r#"
# a comment { [ = ,
name = "a { [ = , \" still a string"
raw = 'b { ['
multi = """
{ [ = ,
"""
[[instance]]
of = "x"
matrix = [1, 2, 3]
inline = { a = 1, b = 2 }
"#;
        // tables: [[instance]] (2 brackets), [1, 2, 3], { }: 4
        // values: 7 `=` (name raw multi of matrix inline a b is 8) and
        // 3 `,` in the array and table
        let (t, v) = toml_counts(text.as_bytes());
        assert_eq!(t, 4);
        assert_eq!(v, 8 + 3);
    }

    #[test]
    fn an_unterminated_string_ends_the_scan() {
        assert_eq!(toml_counts(b"a = \"{{{"), (0, 1));
        assert_eq!(toml_counts(b"a = '''[[["), (0, 1));
    }

    #[test]
    fn estimates_grow_with_tables() {
        let one = toml_scene_estimate("instance = [{of = \"a\"}]").bytes;
        let many =
            toml_scene_estimate(&format!("instance = [{}]", "{of=\"a\"},".repeat(1000))).bytes;
        assert!(many > 1000 * TOML_BYTES_PER_TABLE, "{many}");
        assert!(one < 3 * TOML_BYTES_PER_TABLE, "{one}");
    }

    #[test]
    fn a_need_beyond_any_machine_is_refused_with_both_figures() {
        // 2^62 bytes is more than any machine this runs on has; Linux always
        // has /proc/meminfo
        assert!(available_bytes().is_some());
        let e = check_fits(1 << 62, "its tables").unwrap_err();
        assert!(e.contains("4294967296.00 GiB"), "{e}");
        assert!(e.contains("is available"), "{e}");
        assert!(check_fits(1 << 20, "its tables").is_ok());
    }
}
