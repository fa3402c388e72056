//! Detection metrics: IoU, COCO-style AP@[.50:.05:.95] with pycocotools' conventions, AP50 and the
//! TP ratio over objects visible in a 180° field, as accumulators over many frames.
//!
//! Not implemented yet: this crate marks its boundary in the workspace (see ARCHITECTURE.md).
#![deny(missing_docs)]
