//! The static city's cast shadows, binned once per sun direction and kept for a few suns.

use super::{Episode, Simulator};
use crate::render::shadow::Shadows;
use std::sync::Arc;

/// Sun directions whose static shadows are kept at once (episodes are rendered a few at a
/// time; each set holds about a megabyte).
const SHADOW_SETS_KEPT: usize = 8;

impl Simulator {
    /// The shadows the city's static objects cast under `episode`'s sun, if shadows are cast
    /// (built on first use of that sun).
    pub(super) fn static_shadows(&self, episode: &Episode) -> Option<Arc<Shadows>> {
        if !self.config.cast_shadows {
            return None;
        }
        let key = episode.sun_dir.map(f32::to_bits);
        let mut kept = self.shadows.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        if let Some(i) = kept.iter().position(|(k, _)| *k == key) {
            let entry = kept.remove(i);
            kept.push(entry);
        } else {
            let boxes = self
                .city
                .objects
                .iter()
                .filter(|o| o.motion.is_static())
                .flat_map(|o| o.boxes_at(0.0).map(|(b, _)| b));
            let shadows = Arc::new(Shadows::new(boxes, episode.sun_dir)?.keeping_faces());
            if kept.len() == SHADOW_SETS_KEPT {
                kept.remove(0);
            }
            kept.push((key, shadows));
        }
        kept.last().map(|(_, s)| Arc::clone(s))
    }
}
