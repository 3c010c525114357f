//! Live heap bytes, counted by a thin wrapper around the system allocator.
//!
//! Why: the soak (`oldbf soak`) asks "does memory stay flat over hours", and
//! the resident set answers it badly. glibc's malloc keeps freed memory in
//! per-thread arenas and raises its mmap threshold as it sees large blocks
//! freed, so the resident set steps up by megabytes, once, at a moment that
//! depends on which thread ran which world; and the executable's own pages
//! come and go with the machine's memory pressure. Bytes allocated and not
//! freed are what a leak grows, and nothing else moves them.
//!
//! Only a binary that installs [`CountingAlloc`] as its `#[global_allocator]`
//! counts (the `oldbf` CLI does; the ROS nodes do not); elsewhere
//! [`live_heap_bytes`] is `None`. The cost is one relaxed atomic add per
//! allocation and per free.

// A global allocator is an `unsafe impl`: the workspace denies unsafe code
// everywhere else.
#![allow(unsafe_code)]

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicBool, AtomicI64, Ordering};

/// Bytes allocated and not yet freed through [`CountingAlloc`].
static LIVE_BYTES: AtomicI64 = AtomicI64::new(0);
/// Set by the first allocation through [`CountingAlloc`].
static COUNTING: AtomicBool = AtomicBool::new(false);

/// The system allocator, counting live bytes.
pub struct CountingAlloc;

impl CountingAlloc {
    fn add(bytes: usize) {
        LIVE_BYTES.fetch_add(bytes as i64, Ordering::Relaxed);
        if !COUNTING.load(Ordering::Relaxed) {
            COUNTING.store(true, Ordering::Relaxed);
        }
    }
    fn sub(bytes: usize) {
        LIVE_BYTES.fetch_sub(bytes as i64, Ordering::Relaxed);
    }
}

// SAFETY: every call is forwarded unchanged to `System`, which upholds the
// GlobalAlloc contract; the counters only observe sizes.
unsafe impl GlobalAlloc for CountingAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: forwarded with the caller's layout.
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            Self::add(layout.size());
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        // SAFETY: forwarded with the caller's layout.
        let p = unsafe { System.alloc_zeroed(layout) };
        if !p.is_null() {
            Self::add(layout.size());
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` was allocated by `System` with `layout` (every
        // allocation above is System's).
        unsafe { System.dealloc(ptr, layout) };
        Self::sub(layout.size());
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: forwarded unchanged; `ptr` is System's.
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            Self::add(new_size);
            Self::sub(layout.size());
        }
        p
    }
}

/// Bytes allocated and not freed so far, or `None` if this binary does not
/// count (no [`CountingAlloc`] installed).
pub fn live_heap_bytes() -> Option<i64> {
    COUNTING
        .load(Ordering::Relaxed)
        .then(|| LIVE_BYTES.load(Ordering::Relaxed))
}
