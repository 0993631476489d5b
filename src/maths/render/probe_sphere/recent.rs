//! Values made once each and kept by key, the least recently used dropped first: the frames'
//! plans and what each plan keeps per map size or material ([`super::plan`]), and the texel
//! trees' level 0 per map size ([`super::texel_tree`]).

use std::sync::{Arc, Mutex, OnceLock};

/// Values made once each, by key, most recently used last.
pub(super) type Recent<K, T> = Mutex<Vec<(K, Arc<OnceLock<T>>)>>;

/// The slot of `key` in `list` (most recently used last), made empty when missing, the least
/// recently used dropped to keep at most `kept`. A poisoned list (a panic while it was held) is
/// only a list of finished values.
pub(super) fn recent_slot<K: PartialEq, T>(list: &Recent<K, T>, key: K, kept: usize) -> Arc<OnceLock<T>> {
    let mut list = list.lock().unwrap_or_else(|e| e.into_inner());
    match list.iter().position(|(k, _)| *k == key) {
        Some(i) => {
            let entry = list.remove(i);
            let slot = entry.1.clone();
            list.push(entry);
            slot
        }
        None => {
            if list.len() >= kept {
                list.remove(0);
            }
            let slot = Arc::new(OnceLock::new());
            list.push((key, slot.clone()));
            slot
        }
    }
}
