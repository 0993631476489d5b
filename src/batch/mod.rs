//! Batch runs: one pipeline over a library of maps and parameter sweeps (`hdrflow batch`).
//!
//! 1. **Items.** Every `--over NODE.FIELD=GLOB_OR_LIST` and `--sweep NODE.FIELD=V1,V2,...` is an
//!    axis of values; the items are their cross product (first axis outermost), or with `zip`
//!    their pairing. Each item has an index (its position in the whole list, before sharding)
//!    and a folder from a template. Two items in one folder is an error before anything runs.
//! 2. **Shards.** `--shard I/N` keeps the items whose index is congruent to I mod N: the N
//!    shards are disjoint and cover every item, and round-robin spreads a sweep's costly values
//!    over all shards.
//! 3. **Validation.** Every item's pipeline (the file with the item's values as overrides) is
//!    validated before any runs.
//! 4. **Shared nodes first** (`shared`). Each item is planned against the cache; a node key that several
//!    items would compute (anything not downstream of the swept field: a Fresnel plot, a sample
//!    set, one map's distribution under a sweep of counts) is computed once, in a first phase
//!    that runs those nodes one item at a time on the whole pool. In the second phase every item
//!    runs and finds them in the cache, so items running at once never compute the same key. A
//!    shared `Save` runs in the first phase too, into the folder of the first item that has it;
//!    the others load it from the cache and write their own copy.
//! 5. **Items** run `jobs` at a time, each on its own pool of `threads / jobs` threads, and each
//!    item's values are dropped when it ends (only its metrics stay): the batch never holds more
//!    items' values than it runs at once.
//! 6. **Disk.** Each computed result is stored or not by the cache's persistence policy
//!    (`engine::cache::policy`: huge cheap intermediates are not). After each item the cache
//!    folder is pruned to `cache_limit_bytes`, least recently used first, sparing the entries
//!    of items still running (their leases) and the shared entries that items yet to finish
//!    will load; each item may add at most that much itself.

mod items;
mod report;
mod run;
mod shared;
mod summary;

pub use items::{default_template, items, shard, Axis, Item};
pub use report::{csv, json_rows};
pub use run::{run, validate, BatchObserver, BatchOptions, BatchOutcome, ItemRow, ItemStatus};
pub use summary::{metrics_csv, summarise, summary_csv, summary_markdown, FieldSummary};
