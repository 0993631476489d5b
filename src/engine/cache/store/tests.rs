//! Tests of the disk store: round trips, corrupt entries, eviction order, pinned keys and leases.

use super::eviction::{this_host, FOREIGN_LEASE_SECS};
use super::*;
use crate::engine::value::FileBlob;

fn blob(n: usize) -> Vec<(String, Value)> {
    vec![(String::new(), Value::new(FileBlob::new("a.bin".into(), vec![7; n])))]
}

fn store() -> (tempfile::TempDir, CacheStore) {
    let dir = tempfile::tempdir().unwrap();
    let s = CacheStore::new(dir.path(), DEFAULT_LIMIT_BYTES);
    (dir, s)
}

#[test]
fn put_get_round_trip() {
    let (_d, s) = store();
    let key = [7u8; 32];
    let r = Registry::empty();
    assert!(s.get(&key, &r).unwrap().is_none());
    s.put(&key, &blob(12)).unwrap();
    let back = s.get(&key, &r).unwrap().unwrap();
    assert_eq!(back[0].1.get::<FileBlob>().unwrap().bytes.len(), 12);
}

#[test]
fn corrupt_and_truncated_entries_are_errors_and_removed() {
    let (_d, s) = store();
    let key = [9u8; 32];
    let r = Registry::empty();
    s.put(&key, &blob(48)).unwrap();
    let path = s.path_for(&key);
    let mut bytes = fs::read(&path).unwrap();
    let last = bytes.len() - 1;
    bytes[last] ^= 0xff;
    fs::write(&path, &bytes).unwrap();
    assert!(matches!(s.get(&key, &r), Err(CacheError::Corrupt { .. })));
    assert!(!path.exists());
    s.put(&key, &blob(48)).unwrap();
    let bytes = fs::read(&path).unwrap();
    fs::write(&path, &bytes[..bytes.len() / 2]).unwrap();
    assert!(!s.contains(&key), "a truncated entry is not planned as cached");
    assert!(matches!(s.get(&key, &r), Err(CacheError::Corrupt { .. })));
}

#[test]
fn eviction_removes_least_recently_used_first() {
    let dir = tempfile::tempdir().unwrap();
    let s = CacheStore::new(dir.path(), DEFAULT_LIMIT_BYTES);
    let old = [1u8; 32];
    let new = [2u8; 32];
    s.put(&old, &blob(192)).unwrap();
    let f = fs::File::options().write(true).open(s.path_for(&old)).unwrap();
    f.set_modified(SystemTime::UNIX_EPOCH + std::time::Duration::from_secs(1000)).unwrap();
    s.put(&new, &blob(192)).unwrap();
    let size = fs::metadata(s.path_for(&new)).unwrap().len();
    let report = s.prune(size).unwrap();
    assert_eq!(report.removed, 1);
    assert!(!s.contains(&old));
    assert!(s.contains(&new));
}

#[test]
fn pinned_keys_are_spared_and_forks_count_from_zero() {
    let dir = tempfile::tempdir().unwrap();
    let s = CacheStore::new(dir.path(), 1000);
    let (pinned, other) = ([3u8; 32], [4u8; 32]);
    s.put(&pinned, &blob(300)).unwrap();
    s.put(&other, &blob(300)).unwrap();
    assert!(matches!(s.put(&[5u8; 32], &blob(300)), Err(CacheError::LimitReached { .. })), "past the add limit");
    assert!(s.fork().put(&[5u8; 32], &blob(300)).is_ok(), "a fork has its own limit");
    for k in [pinned, other, [5u8; 32]] {
        let f = fs::File::options().write(true).open(s.path_for(&k)).unwrap();
        f.set_modified(SystemTime::UNIX_EPOCH + std::time::Duration::from_secs(1000)).unwrap();
    }
    let report = s.prune_sparing(0, &|k| *k == pinned).unwrap();
    assert_eq!(report.removed, 2);
    assert!(s.contains(&pinned) && !s.contains(&other));
    assert_eq!(key_of_entry(&s.path_for(&pinned)), Some(pinned));
    assert_eq!(key_of_entry(Path::new("ab/xyz.val")), None);
}

#[test]
fn a_live_lease_spares_the_entries_used_since_it_was_taken() {
    let dir = tempfile::tempdir().unwrap();
    let s = CacheStore::new(dir.path(), DEFAULT_LIMIT_BYTES);
    let old = [1u8; 32];
    s.put(&old, &blob(64)).unwrap();
    let f = fs::File::options().write(true).open(s.path_for(&old)).unwrap();
    f.set_modified(SystemTime::UNIX_EPOCH + std::time::Duration::from_secs(1000)).unwrap();
    let lease = s.lease().unwrap();
    let used = [2u8; 32];
    s.put(&used, &blob(64)).unwrap();
    assert_eq!(s.stats().unwrap().live_runs, 1);
    let report = s.clear().unwrap();
    assert_eq!(report.removed, 1, "only the entry older than the live run goes");
    assert!(s.contains(&used) && !s.contains(&old));
    drop(lease);
    assert_eq!(s.stats().unwrap().live_runs, 0);
    s.clear().unwrap();
    assert!(!s.contains(&used));

    // On a shared folder: another machine's fresh lease is live (its pid means nothing
    // here), a day-old one is not; this machine's lease of a gone process is not.
    let live = s.root().join("live");
    let foreign = live.join("4000000-0@some-other-node");
    fs::write(&foreign, b"").unwrap();
    fs::write(live.join(format!("4000001-0@{}", this_host())), b"").unwrap();
    assert_eq!(s.stats().unwrap().live_runs, 1);
    let f = fs::File::options().write(true).open(&foreign).unwrap();
    f.set_modified(SystemTime::now() - std::time::Duration::from_secs(FOREIGN_LEASE_SECS + 60)).unwrap();
    assert_eq!(s.stats().unwrap().live_runs, 0);
    assert!(!foreign.exists());
}

#[test]
fn a_handle_adds_at_most_its_limit() {
    let dir = tempfile::tempdir().unwrap();
    let s = CacheStore::new(dir.path(), 300);
    s.put(&[1u8; 32], &blob(64)).unwrap();
    assert!(matches!(s.put(&[2u8; 32], &blob(400)), Err(CacheError::LimitReached { .. })));
    assert!(!s.contains(&[2u8; 32]));
    assert!(s.added_bytes() < 300);
}
