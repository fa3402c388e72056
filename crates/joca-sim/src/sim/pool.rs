//! Render buffers kept between frames, shared by every simulator of the process.
//!
//! A view's buffers are large (colour, depth and ids: 1.5 MB at 320×240) and a blurred frame
//! needs up to [`super::MAX_SUBFRAMES`] of them. Allocations of that size come from the kernel
//! as fresh pages, and every page is faulted in and zeroed on first touch: for every sub-frame
//! of every frame, when the buffers are dropped after each frame. The pool hands the same
//! buffers back instead. [`crate::render::render`] overwrites every value of a target, so a
//! reused target renders exactly as a fresh one (tested). One pool for the process bounds the
//! memory it keeps however many towns a run drives through.

use crate::render::Target;
use std::sync::Mutex;

/// Most bytes of buffers the pool keeps; beyond it, the longest-held buffers are freed (so that
/// a change of design, and so of image size, does not leave the pool full of the old size).
const MAX_POOLED_BYTES: usize = 256 << 20;

static FREE: Mutex<Vec<Target>> = Mutex::new(Vec::new());

fn bytes(t: &Target) -> usize {
    4 * (t.colour.capacity()
        + t.inv_depth.capacity()
        + t.id.capacity()
        + t.light_depth.capacity()
        + t.coverage.capacity())
}

/// A target for a `width × height` view of a scene of `objects` objects, with a colour buffer
/// or without ([`Target::ids_only`]); its contents are unspecified until rendered into.
pub(super) fn take(width: usize, height: usize, objects: usize, colour: bool) -> Target {
    let mut free = FREE.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let fits = |t: &Target| t.width == width && t.height == height && t.colour.is_empty() != colour;
    if let Some(i) = free.iter().rposition(fits) {
        let mut t = free.swap_remove(i);
        drop(free);
        // Another town may have another number of objects.
        t.coverage.resize(objects + 1, 0);
        return t;
    }
    drop(free);
    if colour {
        Target::new(width, height, objects)
    } else {
        Target::ids_only(width, height, objects)
    }
}

/// Returns targets to the pool, freeing the longest-held ones beyond its size limit.
pub(super) fn give(targets: impl IntoIterator<Item = Target>) {
    let mut free = FREE.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    free.extend(targets);
    let mut held: usize = free.iter().map(bytes).sum();
    let mut oldest = 0;
    while held > MAX_POOLED_BYTES && oldest < free.len() {
        held -= bytes(&free[oldest]);
        oldest += 1;
    }
    free.drain(..oldest);
}
