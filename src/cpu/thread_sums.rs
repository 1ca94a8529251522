//! The targets a CPU frame traced in passes records (`super::passes`), one set of
//! sums per rayon thread: a table's sums are tens of megabytes, too large to make
//! one per row or per split of a parallel loop, and a thread traces one row at a
//! time. Whole frames group their rows by thread instead (`FrameSetup::trace_whole`),
//! which also fixes the order the sums are added in.

use crate::guide::{FrameSums, Recorder};
use std::sync::{Mutex, MutexGuard};

/// One slot of sums per thread of the pool, made on a thread's first recording row.
pub(super) struct ThreadSums<'a> {
    slots: Vec<Mutex<Option<FrameSums>>>,
    no_sums: &'a (dyn Fn() -> FrameSums + Sync),
}

/// A row's hold on its thread's sums.
pub(super) struct RowSums<'s> {
    slot: MutexGuard<'s, Option<FrameSums>>,
    no_sums: &'s (dyn Fn() -> FrameSums + Sync),
}

impl<'a> ThreadSums<'a> {
    /// Empty slots; `no_sums` makes a thread's sums when it first records.
    pub(super) fn new(no_sums: &'a (dyn Fn() -> FrameSums + Sync)) -> ThreadSums<'a> {
        ThreadSums { slots: (0..rayon::current_num_threads()).map(|_| Mutex::new(None)).collect(), no_sums }
    }

    /// The calling thread's sums for a row that records (None where it does not):
    /// no other thread takes them while it traces the row.
    pub(super) fn for_row(&self, records: bool) -> Option<RowSums<'_>> {
        records.then(|| {
            let i = rayon::current_thread_index().unwrap_or(0) % self.slots.len();
            RowSums { slot: self.slots[i].lock().unwrap_or_else(|e| e.into_inner()), no_sums: self.no_sums }
        })
    }

    /// Every thread's sums added up; None where no row recorded.
    pub(super) fn into_sums(self) -> Option<FrameSums> {
        self.slots
            .into_iter()
            .filter_map(|s| s.into_inner().unwrap_or_else(|e| e.into_inner()))
            .reduce(FrameSums::merge)
    }
}

impl RowSums<'_> {
    pub(super) fn recorder(&mut self) -> &mut dyn Recorder {
        self.slot.get_or_insert_with(self.no_sums)
    }
}
